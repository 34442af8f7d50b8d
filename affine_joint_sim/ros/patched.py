"""A message serialized once whose changing numbers are then written into its bytes.

Markers and poses change only in their poses and stamps, at up to 30 Hz; building and
serializing a MarkerArray each time costs more than a simulation step. Instead every changing
field gets a distinct sentinel, the message is serialized once, the sentinels' byte offsets
are found, and each update writes the new numbers there (CDR keeps a field's offset when no
string or sequence changes length). The bytes serve publishing and recording alike.
"""

import struct

import numpy as np
from rclpy.serialization import serialize_message

__all__ = ['PatchedMessage']


class PatchedMessage:
    """``msg`` as CDR bytes with float64 fields and stamps writable in place.

    Args:
        msg: the message, complete but for the fields below.
        floats: (object, attribute) of every float64 field to write, in update order.
        headers: std_msgs/Header objects whose stamps are written on every update.
        parts: sizes that split ``floats`` into consecutive parts, each updated from an array
            of its own (a sensor's orientation, angular velocity, ...: no array of them all
            is made); None: one part, every value in one array.
    """

    def __init__(self, msg, floats: list, headers: list, parts: list[int] | None = None):
        for i, (obj, attr) in enumerate(floats):
            setattr(obj, attr, _float_sentinel(i))
        for i, header in enumerate(headers):
            header.stamp.sec, header.stamp.nanosec = _int_sentinel(i), _int_sentinel(i) + 1
        raw = serialize_message(msg)
        float_at = [_offset(raw, struct.pack('<d', _float_sentinel(i)))
                    for i in range(len(floats))]
        sec_at = [_offset(raw, struct.pack('<i', _int_sentinel(i))) for i in range(len(headers))]
        nsec_at = [_offset(raw, struct.pack('<I', _int_sentinel(i) + 1))
                   for i in range(len(headers))]
        self.buffer = bytearray(raw)
        # Typed views of the buffer at the fields' alignment (CDR aligns a field to its size
        # from a fixed origin, so all float64 fields share one phase mod 8, all int32 one mod 4)
        self._floats, float_index = _view(self.buffer, float_at, '<f8')
        self._parts = parts is not None
        self._float_indices = np.split(float_index, np.cumsum(parts)[:-1]) if self._parts \
            else [float_index]
        self._secs, self._sec_index = _view(self.buffer, sec_at, '<i4')
        self._nsecs, self._nsec_index = _view(self.buffer, nsec_at, '<u4')

    def update(self, values, stamp_ns: int) -> bytes:
        """Write ``values`` (float64, in the order of ``floats``: one array, or with ``parts``
        a sequence of one array per part) and the stamp [ns]; returns the serialized
        message."""
        for index, part in zip(self._float_indices, values if self._parts else [np.ravel(values)]):
            self._floats[index] = part
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        self._secs[self._sec_index] = sec
        self._nsecs[self._nsec_index] = nsec
        return bytes(self.buffer)


def _view(buffer: bytearray, offsets: list[int], dtype: str):
    """(an array view of ``buffer`` as ``dtype``, the element index of each offset)."""
    size = np.dtype(dtype).itemsize
    phase = offsets[0] % size if offsets else 0
    if any(o % size != phase for o in offsets):
        raise ValueError('fields of one type at different alignments')
    view = np.frombuffer(buffer, dtype=dtype, offset=phase,
                         count=(len(buffer) - phase) // size)
    return view, (np.asarray(offsets, dtype=np.int64) - phase) // size


def _float_sentinel(i: int) -> float:
    """A large finite float64 no real pose has, distinct per i."""
    return struct.unpack('<d', struct.pack('<Q', 0x7FE5A5A500000000 + i))[0]


def _int_sentinel(i: int) -> int:
    return 0x3A5A0000 + 2 * i


def _offset(raw: bytes, pattern: bytes) -> int:
    first = raw.find(pattern)
    if first < 0 or raw.find(pattern, first + 1) >= 0:
        raise ValueError('a sentinel is missing or not unique in the serialized message')
    return first
