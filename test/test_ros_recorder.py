"""The bag recorder's writer thread, on real bags: the recording thread never waits for a split
to close, listing a split costs the same at split 10 and split 200, and a failure of the
writer thread stops the recording once, as a failed write does."""

import errno
import itertools
import threading
import time
from pathlib import Path

import yaml
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import JointState

from affine_joint_sim.ros.recorder import BagRecorder, BagTopic
from affine_joint_sim.ros.recording import RunRecording
from affine_joint_sim.ros.topics import load_topics

STATES = '/joint_states'
_STATES_TOPIC = load_topics()['joint_states']
TOPICS = [BagTopic(STATES, _STATES_TOPIC.type, _STATES_TOPIC.qos)]


def state(k: int) -> bytes:
    """The CDR bytes of a joint_states message whose position is ``k``."""
    return serialize_message(JointState(name=['shoulder'], position=[float(k)]))


def recorded(bag) -> list[int]:
    """Bag times [ns] of every message rosbags reads from ``bag``."""
    with Reader(bag) as reader:
        return [t_ns for _, t_ns, _ in reader.messages()]


def wait_until(predicate, poll=lambda: None, timeout=30.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        poll()
        time.sleep(0.001)
    return True


class FileSystem(type(Path())):
    """A path on a file system that the test controls: moving a file (``Path.replace``) from
    any thread but the test's waits until ``go`` is set, and moving a file whose name ends in
    ``full_at`` fails as on a full disk. Each test makes its own subclass (``file_system``)."""

    go: threading.Event
    moving: threading.Event         # a move from another thread is waiting for ``go``
    full_at: str | None

    def replace(self, target):
        if self.full_at is not None and str(target).endswith(self.full_at):
            raise OSError(errno.ENOSPC, 'No space left on device', str(target))
        if threading.current_thread() is not threading.main_thread():
            self.moving.set()
            self.go.wait(timeout=30.0)
        return super().replace(target)


def file_system(path, held: bool = False, full_at: str | None = None) -> FileSystem:
    """``path`` on a FileSystem of its own: its moves wait for ``go`` if ``held``."""
    go = threading.Event()
    if not held:
        go.set()
    own = type('OwnFileSystem', (FileSystem,),
               {'go': go, 'moving': threading.Event(), 'full_at': full_at})
    return own(path)


def yaml_nodes_per_split(path, splits: int) -> tuple[float, float]:
    """Record ``splits`` splits of one message each, every one listed before the next is
    written; return the YAML nodes dumped and parsed per split, counted in every thread."""
    counts = {'represent_data': itertools.count(), 'construct_object': itertools.count()}

    def profile(frame, event, arg):
        if event == 'call' and frame.f_code.co_name in counts:
            next(counts[frame.f_code.co_name])

    recorder = BagRecorder(path, 'mcap', TOPICS)
    threading.setprofile_all_threads(profile)
    try:
        for k in range(splits):
            recorder.write(STATES, k, state(k))
            recorder.flush()
            assert wait_until(lambda: recorder.last_split == f'{path.name}_{k}.mcap',
                              recorder.flush_if_due)
    finally:
        threading.setprofile_all_threads(None)
    recorder.close()
    assert recorded(path) == list(range(splits))
    dumped, parsed = (next(c) / splits for c in counts.values())
    return dumped, parsed


def test_listing_a_split_costs_the_same_yaml_work_at_split_10_and_split_200(tmp_path):
    dumped_10, parsed_10 = yaml_nodes_per_split(tmp_path / 'short', 10)
    dumped_200, parsed_200 = yaml_nodes_per_split(tmp_path / 'long', 200)
    # The recorder before the writer thread re-read each split's metadata (91 nodes parsed
    # per split) and re-dumped the whole growing metadata.yaml: 366 nodes dumped per split
    # over 10 splits, 1,696 over 200. Now 221 and 224: the last split's successor is opened
    # after counting stops.
    assert dumped_200 < 1.1 * dumped_10, (dumped_10, dumped_200)
    assert parsed_10 == parsed_200 == 0       # metadata.yaml comes from memory
    # Made of pieces, metadata.yaml is still what one dump of the whole gives.
    text = (tmp_path / 'long' / 'metadata.yaml').read_text()
    assert yaml.safe_dump(yaml.safe_load(text)) == text
    assert len(yaml.safe_load(text)['rosbag2_bagfile_information']['files']) == 200


def test_a_slow_split_close_holds_up_nothing_and_a_late_split_is_said_once(tmp_path):
    bag = file_system(tmp_path / 'held', held=True)
    errors, warnings = [], []
    recording = RunRecording(BagRecorder(bag, 'mcap', TOPICS, split_seconds=0.0),
                             errors.append, warnings.append)
    recording.write(STATES, 0, state(0))
    recording.flush()
    assert type(bag).moving.wait(timeout=10.0), 'split 0 should be moved by another thread'
    # The writer thread is stuck moving split 0; recording goes on, every split due at once.
    for k in range(1, 200):
        recording.write(STATES, k, state(k))
        recording.flush_if_due()
    assert not (bag / 'metadata.yaml').exists()
    assert recording.recorder.late_splits == 1 and len(warnings) == 1, warnings
    assert 'the simulation does not wait' in warnings[0]
    type(bag).go.set()
    recording.close()
    assert recorded(bag) == list(range(200)) and not errors
    files = yaml.safe_load((bag / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']['files']
    assert [f['message_count'] for f in files] == [1, 199]
    assert not list(bag.glob('.split_*'))


def _recording_a_split_per_message(bag):
    """(a RunRecording of ``bag`` that closes a split after every message, the errors it
    reported, ``record_one()`` that records the next state and lets a split go)."""
    errors = []
    recording = RunRecording(BagRecorder(bag, 'mcap', TOPICS, split_seconds=0.0),
                             errors.append, lambda message: None)
    written = itertools.count()

    def record_one():
        k = next(written)
        recording.write(STATES, k, state(k))
        recording.flush_if_due()

    return recording, errors, record_one


def test_a_failure_in_the_writer_thread_stops_the_recording_once(tmp_path):
    bag = file_system(tmp_path / 'full', full_at='full_1.mcap')
    recording, errors, record_one = _recording_a_split_per_message(bag)
    assert wait_until(lambda: errors, record_one), 'moving split 1 should fail'
    for _ in range(10):
        record_one()                    # nothing more is recorded, nothing raised
    recording.close()
    assert len(errors) == 1 and 'No space left on device' in errors[0]
    assert 'last closed split (full_0.mcap' in errors[0]
    assert not recording.active and 'No space left on device' in recording.stopped
    assert recorded(bag) == [0]
    assert not list(bag.glob('.split_*')) and not (bag / 'full_1.mcap').exists()


def test_a_failed_metadata_write_names_the_split_the_bag_really_ends_at(tmp_path):
    """Listing split 1 fails at metadata.yaml (a full disk): the error must name split 0, which
    metadata.yaml lists, not split 1, which it does not (before, the index had already taken
    split 1 in)."""
    writes = itertools.count()

    class MetadataFull(type(Path())):
        def replace(self, target):
            if str(target).endswith('metadata.yaml') and next(writes) == 1:
                raise OSError(errno.ENOSPC, 'No space left on device', str(target))
            return super().replace(target)

    recording, errors, record_one = _recording_a_split_per_message(MetadataFull(tmp_path / 'full'))
    bag = recording.recorder.path
    assert wait_until(lambda: errors, record_one), 'listing split 1 should fail'
    recording.close()
    assert 'last closed split (full_0.mcap' in errors[0], errors[0]
    assert recorded(bag) == [0]
