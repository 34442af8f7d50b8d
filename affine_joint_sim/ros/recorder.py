"""rosbag2 recording with the ``rosbags`` library, crash-safe by splitting.

A bag is a rosbag2 directory (``metadata.yaml`` version 9 plus ``<name>_<k>.mcap`` or
``.db3`` files), as ``ros2 bag record`` writes it with splitting on. Each split file is written
by ``rosbags.rosbag2.Writer`` in a hidden scratch directory, closed (so it is complete), moved
into the bag, and only then listed in ``metadata.yaml`` (replaced atomically). A process killed
at any moment therefore leaves a bag that every reader opens, holding everything up to the last
closed split (at most ``split_seconds`` of wall time is lost); a normal close lists the rest.
Messages go in as CDR bytes, exactly as ROS 2 serializes them.
"""

import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import yaml
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                               QosTime)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

__all__ = ['BagRecorder', 'BagTopic', 'STORAGE_PLUGINS']

STORAGE_PLUGINS = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
_SUFFIX = {'mcap': '.mcap', 'sqlite3': '.db3'}
_INFINITE = QosTime(sec=2147483647, nsec=4294967295)    # what rosbag2 records for "infinite"
_TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


@dataclass(frozen=True)
class BagTopic:
    """A topic of the bag: full name, message type (``pkg/msg/Name``) and rclpy QoS profile."""

    name: str
    type: str
    qos: object


def _offered_qos(profile) -> Qos:
    return Qos(
        history=QosHistory.KEEP_LAST, depth=profile.depth,
        reliability=(QosReliability.RELIABLE if profile.reliability == ReliabilityPolicy.RELIABLE
                     else QosReliability.BEST_EFFORT),
        durability=(QosDurability.TRANSIENT_LOCAL
                    if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                    else QosDurability.VOLATILE),
        deadline=_INFINITE, lifespan=_INFINITE, liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=_INFINITE, avoid_ros_namespace_conventions=False)


class BagRecorder:
    """Write one bag, split every ``split_seconds`` of wall time.

    Args:
        path: the bag directory to create (must not exist).
        storage: ``mcap`` | ``sqlite3``.
        topics: every topic that will be written, in a fixed order.
        custom_data: strings stored in metadata.yaml (``custom_data``).
        split_seconds: wall seconds [s] after which the current split is closed.

    Raises:
        FileExistsError: ``path`` exists (a bag is never overwritten).
    """

    def __init__(self, path, storage: str, topics: list[BagTopic],
                 custom_data: dict[str, str] | None = None, split_seconds: float = 1.0):
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f'{self.path} exists; a bag is never overwritten')
        longest = f'{self.path.name}_999999{_SUFFIX[storage]}'
        if len(longest.encode()) > 255:
            raise OSError(f'{self.path}: the bag name is too long for its split files '
                          f'({self.path.name}_<k>{_SUFFIX[storage]} must fit 255 bytes)')
        self.storage = storage
        self.topics = {t.name: t for t in topics}
        self.custom_data = dict(custom_data or {})
        self.split_seconds = split_seconds
        self._splits: list[dict] = []       # metadata of the closed splits
        self._writer = None
        self.path.mkdir(parents=True)
        self._open_split()

    # ---- writing ----------------------------------------------------------------------------

    def write(self, topic: str, t_ns: int, data: bytes) -> None:
        """Write one CDR-serialized message on ``topic`` at bag time ``t_ns`` [ns]."""
        self._writer.write(self._connections[topic], t_ns, data)
        self._count += 1

    def flush_if_due(self) -> None:
        """Close the current split if it is older than ``split_seconds`` (and not empty)."""
        if self._count and time.monotonic() - self._opened > self.split_seconds:
            self.flush()

    def flush(self) -> None:
        """Close the current split, list it in metadata.yaml, open the next one."""
        self._close_split()
        self._open_split()

    def close(self) -> None:
        """Close the last split and finalise metadata.yaml."""
        if self._writer is not None:
            self._close_split()

    def abandon(self) -> None:
        """Stop after a write failed (e.g. a full disk): drop the split being written; the bag
        stays readable as of its last closed split."""
        writer, self._writer = self._writer, None
        try:
            if writer is not None:
                writer.abort()
        except Exception:          # noqa: BLE001 - the writer already failed; drop its split
            pass
        shutil.rmtree(self._scratch, ignore_errors=True)

    @property
    def bytes_written(self) -> int:
        """Bytes of the closed splits [B]."""
        return sum((self.path / s['relative_file_paths'][0]).stat().st_size
                   for s in self._splits)

    @property
    def last_split(self) -> str | None:
        """File name of the last closed split, if any."""
        return self._splits[-1]['relative_file_paths'][0] if self._splits else None

    # ---- splits -----------------------------------------------------------------------------

    def _open_split(self):
        k = len(self._splits)
        self._scratch = self.path / f'.split_{k}'
        self._writer = Writer(self._scratch, version=9,
                              storage_plugin=STORAGE_PLUGINS[self.storage])
        self._writer.open()
        self._connections = {
            name: self._writer.add_connection(name, t.type, typestore=_TYPESTORE,
                                              offered_qos_profiles=[_offered_qos(t.qos)])
            for name, t in self.topics.items()}
        self._count = 0
        self._opened = time.monotonic()

    def _close_split(self):
        writer, self._writer = self._writer, None
        if self._count == 0 and self._splits:
            writer.abort()
            shutil.rmtree(self._scratch)
            return
        writer.close()
        info = yaml.safe_load((self._scratch / 'metadata.yaml').read_text())
        info = info['rosbag2_bagfile_information']
        name = f'{self.path.name}_{len(self._splits)}{_SUFFIX[self.storage]}'
        (self._scratch / info['relative_file_paths'][0]).replace(self.path / name)
        shutil.rmtree(self._scratch)
        info['relative_file_paths'] = [name]
        info['files'][0]['path'] = name
        self._splits.append(info)
        self._write_metadata()

    def _write_metadata(self):
        first = self._splits[0]
        counts = {}
        for split in self._splits:
            for entry in split['topics_with_message_count']:
                counts[entry['topic_metadata']['name']] = \
                    counts.get(entry['topic_metadata']['name'], 0) + entry['message_count']
        files = [s['files'][0] for s in self._splits if s['message_count']]
        start = min((f['starting_time']['nanoseconds_since_epoch'] for f in files), default=0)
        end = max((f['starting_time']['nanoseconds_since_epoch'] + f['duration']['nanoseconds']
                   for f in files), default=0)
        info = dict(first)
        info.update({
            'relative_file_paths': [s['relative_file_paths'][0] for s in self._splits],
            'duration': {'nanoseconds': end - start},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(counts.values()),
            'topics_with_message_count': [
                dict(entry, message_count=counts[entry['topic_metadata']['name']])
                for entry in first['topics_with_message_count']],
            'files': [s['files'][0] for s in self._splits],
            'custom_data': self.custom_data or None,
        })
        scratch = self.path / 'metadata.yaml.tmp'
        scratch.write_text(yaml.safe_dump({'rosbag2_bagfile_information': info},
                                          sort_keys=False))
        scratch.replace(self.path / 'metadata.yaml')
