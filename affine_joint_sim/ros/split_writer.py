"""One split file of a bag: a ``rosbags`` Writer, opened and closed by the bag's writer thread
and written by the stepping thread.

A split is written in a hidden scratch directory of the bag (``.split_<n>``). Closing it
finishes the storage file (index, and the split's metadata embedded as rosbag2 does) and
returns that metadata, so the bag's metadata.yaml is made from memory; the split writes no
metadata.yaml of its own. Its YAML goes through PyYAML's C emitter (``bag_metadata.dump_yaml``)
instead of rosbags' pure-Python one. Two threads touch a split, one after the other, never at
once (the writer thread opens it, the stepping thread writes it, the writer thread closes it),
so the sqlite3 connection is allowed to cross threads.
"""

import shutil
import sqlite3
from dataclasses import dataclass
from pathlib import Path

from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from rosbags.interfaces import (Connection, ConnectionExtRosbag2, MessageDefinition,
                               MessageDefinitionFormat, Qos, QosDurability, QosHistory,
                               QosLiveliness, QosReliability, QosTime)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.rosbag2.storage_mcap import McapWriter
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer
from rosbags.typesys import Stores, get_typestore

from affine_joint_sim.ros.bag_metadata import dump_yaml

__all__ = ['BagTopic', 'SplitWriter', 'STORAGE_PLUGINS', 'SUFFIX']

STORAGE_PLUGINS = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
SUFFIX = {'mcap': '.mcap', 'sqlite3': '.db3'}
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


class _Sqlite3Storage(Sqlite3Writer):
    """rosbags' sqlite3 storage, with a connection that another thread may use."""

    def __init__(self, path: Path, compression):
        self.path = path / f'{path.name}.db3'
        self.conn = sqlite3.connect(f'file:{self.path}', uri=True, check_same_thread=False)
        self.conn.executescript(self.SQLITE_SCHEMA)
        self.cursor = self.conn.cursor()


class SplitWriter(Writer):
    """One split, open for writing.

    Args:
        scratch: its scratch directory (must not exist), inside the bag directory.
        storage: ``mcap`` | ``sqlite3``.
        topics: every topic of the bag, in a fixed order.

    Attributes:
        scratch: the scratch directory, as given.
        file: the split file inside ``scratch``.
        connections_by_topic: the rosbags connection of each topic name.
    """

    STORAGE_PLUGINS = {StoragePlugin.MCAP: McapWriter, StoragePlugin.SQLITE3: _Sqlite3Storage}

    def __init__(self, scratch: Path, storage: str, topics: list[BagTopic]):
        super().__init__(scratch, version=9, storage_plugin=STORAGE_PLUGINS[storage])
        self.scratch = scratch
        try:
            self.open()
            self.file = scratch / self.storage.path.name
            self.connections_by_topic = {t.name: self.connect(t) for t in topics}
        except BaseException:
            self.discard()
            raise

    def connect(self, topic: BagTopic) -> Connection:
        """``Writer.add_connection`` for a topic of the typestore, with the QoS text from the C
        emitter (rosbags dumps it with pure-Python YAML: most of the cost of a split)."""
        msgdef, _ = _TYPESTORE.generate_msgdef(topic.type, ros_version=2)
        qos = [_offered_qos(topic.qos)]
        connection = Connection(
            id=len(self.connections) + 1, topic=topic.name, msgtype=topic.type,
            msgdef=MessageDefinition(MessageDefinitionFormat.MSG, msgdef),
            digest=_TYPESTORE.hash_rihs01(topic.type), msgcount=0,
            ext=ConnectionExtRosbag2(serialization_format='cdr', offered_qos_profiles=qos),
            owner=self)
        if topic.type not in self.added_types:
            self.storage.add_msgtype(connection)
            self.added_types.add(topic.type)
        self.storage.add_connection(connection, dump_yaml(dump_qos_v9(qos)).strip())
        self.connections.append(connection)
        self.counts[connection.id] = 0
        return connection

    def close(self, name: str) -> dict:
        """Finish the split file; ``name``: the file name it will have in the bag.

        Returns:
            its ``rosbag2_bagfile_information``, as rosbags would write it (one file).
        """
        count = sum(self.counts.values())
        start = self.min_timestamp                  # 2**63 - 1 when empty, as rosbags has it
        times = {'starting_time': {'nanoseconds_since_epoch': start},
                 'duration': {'nanoseconds': max(0, self.max_timestamp - start)}}
        info = {
            'version': self.version,
            'storage_identifier': self.storage_plugin.name.lower(),
            'relative_file_paths': [name],
            **times,
            'message_count': count,
            'topics_with_message_count': [
                {'topic_metadata': {
                    'name': c.topic, 'type': c.msgtype,
                    'serialization_format': c.ext.serialization_format,
                    'offered_qos_profiles': dump_qos_v9(c.ext.offered_qos_profiles),
                    'type_description_hash': c.digest},
                 'message_count': self.counts[c.id]}
                for c in self.connections],
            'compression_format': '',
            'compression_mode': '',
            'files': [{'path': name, **times, 'message_count': count}],
            'custom_data': None,
            'ros_distro': 'rosbags',
        }
        storage, self.storage = self.storage, None
        storage.close(self.version, dump_yaml(info).strip())
        return info

    def discard(self) -> None:
        """Drop the split: its storage and its scratch directory."""
        try:
            self.abort()
        except Exception:          # noqa: BLE001 - e.g. the disk failed under it; drop it anyway
            pass
        shutil.rmtree(self.scratch, ignore_errors=True)
