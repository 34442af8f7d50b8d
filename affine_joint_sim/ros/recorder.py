"""rosbag2 recording with the ``rosbags`` library, crash-safe by splitting, at no cost to the
thread that records.

A bag is a rosbag2 directory (``metadata.yaml`` version 9 plus ``<name>_<k>.mcap`` or
``.db3`` files), as ``ros2 bag record`` writes it with splitting on. The recording thread
writes each split (``SplitWriter``) in a hidden scratch directory; when it is due, the split
goes to the bag's writer thread (``SplitCloser``), which closes it (so it is complete), moves
it into the bag, and only then lists it in ``metadata.yaml`` (replaced atomically), made from
an in-memory index (``BagIndex``). A process killed at any moment therefore leaves a bag that
every reader opens, holding everything up to the last listed split (about ``split_seconds`` of
wall time is lost, more if the writer thread was behind); a normal close lists the rest.
Messages go in as CDR bytes, exactly as ROS 2 serializes them.

The recording thread never waits for a split to close: if the writer thread is still busy with
the previous split, the current one stays open and closes at a later ``flush_if_due``; each
such late split is counted in ``late_splits``.
"""

import itertools
import time
from pathlib import Path

from affine_joint_sim.ros.bag_metadata import BagIndex
from affine_joint_sim.ros.split_closer import SplitCloser
from affine_joint_sim.ros.split_writer import STORAGE_PLUGINS, SUFFIX, BagTopic, SplitWriter

__all__ = ['BagRecorder', 'BagTopic', 'STORAGE_PLUGINS']


class BagRecorder:
    """Write one bag, split every ``split_seconds`` of wall time.

    Args:
        path: the bag directory to create (must not exist).
        storage: ``mcap`` | ``sqlite3``.
        topics: the topics to write, in a fixed order (``add_topic`` adds more).
        custom_data: strings stored in metadata.yaml (``custom_data``).
        split_seconds: wall seconds [s] after which the current split is due to close.

    Raises:
        FileExistsError: ``path`` exists (a bag is never overwritten).
    """

    def __init__(self, path, storage: str, topics: list[BagTopic],
                 custom_data: dict[str, str] | None = None, split_seconds: float = 1.0):
        self.path = path if isinstance(path, Path) else Path(path)   # a subclass stays one
        if self.path.exists():
            raise FileExistsError(f'{self.path} exists; a bag is never overwritten')
        longest = f'{self.path.name}_999999{SUFFIX[storage]}'
        if len(longest.encode()) > 255:
            raise OSError(f'{self.path}: the bag name is too long for its split files '
                          f'({self.path.name}_<k>{SUFFIX[storage]} must fit 255 bytes)')
        self.storage = storage
        self.split_seconds = split_seconds
        self.late_splits = 0            # splits that stayed open because the writer was busy
        self.path.mkdir(parents=True)
        opened = itertools.count()
        self._topics = list(topics)     # read by the writer thread as it opens a split

        def open_split():
            return SplitWriter(self.path / f'.split_{next(opened)}', storage, self._topics)

        self._writer = open_split()
        try:
            spare = open_split()
        except BaseException:
            self._writer.discard()
            raise
        self._closer = SplitCloser(self.path, BagIndex(custom_data), open_split, spare)
        self._handed = 0                # splits handed to the writer thread
        self._asked = False             # flush() asked for the current split to close
        self._late = False              # the current split is late (counted)
        self._start_split()

    # ---- writing ----------------------------------------------------------------------------

    def write(self, topic: str, t_ns: int, data: bytes) -> None:
        """Write one CDR-serialized message on ``topic`` at bag time ``t_ns`` [ns]."""
        self._writer.write(self._connections[topic], t_ns, data)
        self._count += 1

    def add_topic(self, topic: BagTopic) -> None:
        """Write ``topic`` too from now on (a robot spawned while recording), after the
        others in every split from the current one."""
        if topic.name not in self._connections:
            self._topics.append(topic)
            self._connections[topic.name] = self._writer.connect(topic)

    def flush_if_due(self) -> None:
        """Hand the current split to the writer thread if it is older than ``split_seconds``
        (and not empty) or ``flush`` asked for it, and the writer thread is ready; never waits.

        Raises:
            the writer thread's failure (e.g. an OSError for a full disk), once it has one.
        """
        if self._closer.failure is not None:
            raise self._closer.failure
        if self._asked or (self._count and
                           time.monotonic() - self._opened > self.split_seconds):
            self._hand_over()

    def flush(self) -> None:
        """Hand the current split to the writer thread to close: now if it is ready, else at a
        later ``flush_if_due``."""
        self._asked = True
        self.flush_if_due()

    def close(self) -> None:
        """Close the last split, wait until the writer thread has listed every split in
        metadata.yaml, and end it. After ``abandon``: wait for the writer thread to end."""
        writer, self._writer = self._writer, None
        last = None
        if writer is not None:
            if self._count == 0 and self._handed:
                writer.discard()
            else:
                last = (writer, self._split_name())
        self._closer.finish(last)

    def abandon(self) -> None:
        """Stop after a write failed (e.g. a full disk): drop the split being written and
        those not listed yet; the bag stays readable as of its last listed split."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.discard()
        self._closer.abandon()

    @property
    def bytes_written(self) -> int:
        """Bytes of the listed splits [B]."""
        return self._closer.index.bytes

    @property
    def last_split(self) -> str | None:
        """File name of the last listed split, if any."""
        names = self._closer.index.names
        return names[-1] if names else None

    # ---- splits -----------------------------------------------------------------------------

    def _split_name(self) -> str:
        return f'{self.path.name}_{self._handed}{SUFFIX[self.storage]}'

    def _start_split(self):
        # a spare opened before a topic was added has it added now, in the bag's order
        for topic in self._topics:
            if topic.name not in self._writer.connections_by_topic:
                self._writer.connections_by_topic[topic.name] = self._writer.connect(topic)
        self._connections = self._writer.connections_by_topic
        self._count = 0
        self._opened = time.monotonic()
        self._asked = self._late = False

    def _hand_over(self):
        if self._count == 0 and self._handed:
            self._asked = False         # nothing to close: the split goes on
            return
        spare = self._closer.swap(self._writer, self._split_name())
        if spare is None:
            if not self._late:
                self._late = True
                self.late_splits += 1
            return
        self._handed += 1
        self._writer = spare
        self._start_split()
