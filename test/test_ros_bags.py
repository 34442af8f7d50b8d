"""Recording and replay: real bags written by the node, read back by rosbags and by replay."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger

from affine_joint_sim.ros.recorder import BagRecorder, BagTopic
from affine_joint_sim.ros.topics import load_topics
from helpers.cli import cli
from helpers.logged_node import LoggedNode
from helpers.ros_client import Inbox, call, publisher, stamp_ns

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
DT_10 = 10 * 10_000_000         # ten steps of the pendulum [ns]

REPO = Path(__file__).resolve().parent.parent
SAMPLE_BAGS = sorted(p.parent for p in (REPO / 'bags').glob('*/metadata.yaml'))


def bag_messages(path) -> dict[str, list]:
    """Every message of a bag, decoded with rclpy, by topic."""
    from affine_joint_sim.ros.topics import message_class

    by_topic = {}
    with Reader(path) as reader:
        for connection, _, raw in reader.messages():
            msg = deserialize_message(bytes(raw), message_class(connection.msgtype))
            by_topic.setdefault(connection.topic, []).append(msg)
    return by_topic


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_record_then_replay_is_exact(sim, ros_node, wait_for, tmp_path, storage):
    bag = tmp_path / 'run'
    child = sim('--scene', 'double_pendulum', '--mode', 'realtime', '--real-time-factor', '4',
                '--record', bag, '--storage', storage)
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=1.5))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.5)
    publisher(ros_node, wait_for, 'joint_commands').publish(
        JointState(name=['elbow'], effort=[-0.7]))
    assert wait_for(lambda: states.last.effort[1] == -0.7)
    publisher(ros_node, wait_for, 'joint_enable', 'shoulder').publish(Bool(data=False))
    assert wait_for(lambda: states.last.effort[0] == 0.0)
    assert call(ros_node, wait_for, Trigger, '/affine_joint_sim/reset', Trigger.Request()).success
    assert wait_for(lambda: stamp_ns(states.last) > 20 * 10_000_000 and
                    states.last.effort[1] == 0.0)
    output = child.stop()
    assert 'Traceback' not in output and f'bag: {bag}' in output, (child.returncode, output)

    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert metadata['version'] == 9 and metadata['storage_identifier'] == storage
    recorded = bag_messages(bag)
    assert sum(len(v) for v in recorded.values()) == metadata['message_count']
    assert recorded['/affine_joint_sim/scene'][0].data.startswith('name: double_pendulum')
    assert [e.data.split('\n')[0] for e in recorded['/affine_joint_sim/events']] == \
        ['event: start', 'event: reset', 'event: reset']
    assert [m.data for m in recorded['/joints/shoulder/external_torque']] == [1.5]

    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert f"{len(recorded['/joint_states'])} recorded states" in replayed.stdout
    assert 'largest difference 0.000e+00' in replayed.stdout


def test_prismatic_forces_are_recorded_and_replay_exactly(sim, ros_node, wait_for, tmp_path):
    bag = tmp_path / 'gantry'
    child = sim('--scene', 'gantry', '--mode', 'realtime', '--real-time-factor', '4',
                '--record', bag)
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_force', 'rail').publish(Float64(data=4.0))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 4.0)
    publisher(ros_node, wait_for, 'joint_commands').publish(
        JointState(name=['rail', 'swing'], effort=[-1.0, 0.2]))
    assert wait_for(lambda: list(states.last.effort[:2]) == [-1.0, 0.2])
    assert wait_for(lambda: stamp_ns(states.last) > 30 * 10_000_000)
    assert 'Traceback' not in child.stop()
    assert [m.data for m in bag_messages(bag)['/joints/rail/external_force']] == [4.0]
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert 'largest difference 0.000e+00' in replayed.stdout


def test_array_commands_are_recorded_and_replay_exactly(sim, ros_node, wait_for, tmp_path):
    data = yaml.safe_load((SCENES / 'double_pendulum.yaml').read_text())
    data['joints'][1]['drive'] = {'target': 0.0, 'strength_ratio': 0.01}
    scene, bag = tmp_path / 'driven.yaml', tmp_path / 'arrays'
    scene.write_text(yaml.safe_dump(data))
    child = sim('--scene', scene, '--mode', 'realtime', '--real-time-factor', '4', '--record',
                bag, '--command-joints', 'elbow,shoulder')
    states = Inbox(ros_node, 'joint_states')
    positions = publisher(ros_node, wait_for, 'position_commands')
    positions.publish(Float64MultiArray(data=[0.3, 0]))
    publisher(ros_node, wait_for, 'effort_commands').publish(Float64MultiArray(data=[0, 0.8]))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 0.8)
    assert wait_for(lambda: states.last.position[1] > 0.1)
    assert 'Traceback' not in child.stop()
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert 'largest difference 0.000e+00' in replayed.stdout


def _splits(bag):
    """The splits listed in a bag's metadata.yaml (0 before it exists)."""
    try:
        info = yaml.safe_load((bag / 'metadata.yaml').read_text())
    except FileNotFoundError:
        return 0
    return len(info['rosbag2_bagfile_information']['relative_file_paths'])


def test_a_long_wait_still_closes_the_split_with_the_computed_steps(sim, ros_node, wait_for,
                                                                     tmp_path):
    bag = tmp_path / 'waiting'
    child = sim('--mode', 'lockstep', '--record', bag)      # no controller: waits on state 0
    assert wait_for(lambda: _splits(bag) >= 2, timeout=20.0)
    os.kill(child.pid, signal.SIGKILL)
    child.communicate()
    assert [stamp_ns(m) for m in bag_messages(bag)['/joint_states']] == [0]


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs (needs root, as CI and the development machines have)."""
    disk = tmp_path / 'disk'
    disk.mkdir()
    mounted = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=1m', 'tmpfs', str(disk)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {mounted.stderr.strip()}')
    yield disk
    subprocess.run(['umount', '-l', str(disk)], check=False)


def test_a_full_disk_stops_recording_not_the_simulation(ros_node, wait_for, small_disk,
                                                        tmp_path):
    bag = small_disk / 'run'
    # ~0.4 MB of states a second: the first 1 s split fits, a later one does not
    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'realtime', '--real-time-factor',
                      '20', '--record', bag)
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: node.said('recording stopped:'), timeout=30.0)
    full_at = stamp_ns(states.last) if states.last is not None else 0
    assert wait_for(lambda: states.last is not None and stamp_ns(states.last) > full_at + DT_10)
    output = node.stop()
    assert 'recording stopped:' in output
    assert 'stays readable up to its last closed split' in output
    assert '(recording stopped early:' in output and 'steps/s' in output, output
    assert 'Traceback' not in output
    assert not any(p.name.startswith('.split_') for p in bag.iterdir())
    assert len(bag_messages(bag)['/joint_states']) > 100
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr


def test_a_bag_name_too_long_for_its_split_files_is_refused(tmp_path):
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--record',
                           tmp_path / ('b' * 250)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and 'too long for its split files' in done.stderr, done.stderr
    assert 'Traceback' not in done.stderr


def test_sigkill_leaves_a_readable_bag_up_to_the_last_split(sim, ros_node, wait_for, tmp_path):
    bag = tmp_path / 'killed'
    child = sim('--mode', 'fast', '--record', bag)
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=0.5))

    def splits():
        return _splits(bag)

    assert wait_for(lambda: splits() >= 3, timeout=20.0)
    os.kill(child.pid, signal.SIGKILL)
    child.communicate()
    recorded = bag_messages(bag)
    stamps = [stamp_ns(m) for m in recorded['/joint_states']]
    assert len(stamps) > 100 and stamps == [k * 10_000_000 for k in range(len(stamps))]
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    leftovers = [p.name for p in bag.glob('.split_*')]
    assert all(f'note: {name} is a split the recorder had not listed when it was killed'
               in replayed.stderr for name in leftovers)


@pytest.fixture(scope='module')
def sample_bag():
    """The torque step response (``make bags``): a torque command, then the response."""
    return REPO / 'bags' / 'torque_step'


def test_sample_bags_are_there_and_small():
    assert [p.name for p in SAMPLE_BAGS] == ['demo_pd', 'torque_step']
    for bag in SAMPLE_BAGS:
        assert sum(f.stat().st_size for f in bag.iterdir()) < 300_000


@pytest.mark.parametrize('bag', SAMPLE_BAGS, ids=lambda p: p.name)
def test_sample_bags_replay_exactly(bag):
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert 'largest difference 0.000e+00' in replayed.stdout


def test_what_if_with_another_dt_reports_a_divergence(sample_bag, tmp_path):
    scene = yaml.safe_load(bag_messages(sample_bag)['/affine_joint_sim/scene'][0].data)
    scene['dt'] = scene['dt'] / 2
    other = tmp_path / 'half_dt.yaml'
    other.write_text(yaml.safe_dump(scene))
    replayed = cli('replay', sample_bag, '--scene', other, '--out', tmp_path / 'out')
    assert replayed.returncode == 1, replayed.stdout + replayed.stderr
    worst = float(replayed.stdout.split('largest difference ')[1].split(':')[0])
    assert 1e-4 < worst < 10.0
    # The re-simulated run is a bag of its own that replays exactly.
    again = cli('replay', tmp_path / 'out')
    assert again.returncode == 0, again.stdout + again.stderr


def _copy(source, target, drop='', damage=''):
    """Rewrite a bag without the topic ending in ``drop`` (as another recorder might), and
    with the payload of the 10th message on the topic ending in ``damage`` garbled."""
    topics = load_topics()
    with Reader(source) as reader:
        kept = [c for c in reader.connections if not (drop and c.topic.endswith(drop))]
        recorder = BagRecorder(target, 'mcap', [
            BagTopic(c.topic, c.msgtype, topics['joint_commands'].qos) for c in kept])
        seen = 0
        for connection, t_ns, raw in reader.messages(connections=kept):
            raw = bytes(raw)
            if damage and connection.topic.endswith(damage):
                seen += 1
                if seen == 10:
                    raw = raw[:8] + b'\xff' * (len(raw) - 8)
            recorder.write(connection.topic, t_ns, raw)
    recorder.close()


def test_a_bag_without_a_scene_needs_one_given(sample_bag, tmp_path):
    bare = tmp_path / 'bare'
    _copy(sample_bag, bare, drop='/scene')
    refused = cli('replay', bare)
    assert refused.returncode == 2 and 'holds no scene' in refused.stderr
    assert '--scene' in refused.stderr and 'Traceback' not in refused.stderr
    scene = tmp_path / 'scene.yaml'
    scene.write_text(bag_messages(sample_bag)['/affine_joint_sim/scene'][0].data)
    assert cli('replay', bare, '--scene', scene).returncode == 0


def _truncated(bag, tmp_path):
    damaged = tmp_path / 'truncated'
    damaged.mkdir()
    for f in bag.iterdir():
        data = f.read_bytes()
        (damaged / f.name).write_bytes(data if f.name == 'metadata.yaml' else data[:len(data) // 2])
    return damaged


def _corrupt(bag, tmp_path):
    damaged = tmp_path / 'corrupt'
    damaged.mkdir()
    for f in bag.iterdir():
        data = f.read_bytes()
        (damaged / f.name).write_bytes(data if f.name == 'metadata.yaml' else
                                       data[:64] + bytes(len(data) - 64))
    return damaged


@pytest.mark.parametrize('make', [_truncated, _corrupt,
                                  lambda bag, tmp: tmp,                     # a plain directory
                                  lambda bag, tmp: REPO / 'README.md',      # a plain file
                                  lambda bag, tmp: tmp / 'missing'],
                         ids=['truncated', 'corrupt', 'directory', 'file', 'missing'])
def test_damaged_or_foreign_paths_give_a_clear_error(sample_bag, tmp_path, make):
    path = make(sample_bag, tmp_path)
    replayed = cli('replay', path)
    assert replayed.returncode == 2, replayed.stdout + replayed.stderr
    assert replayed.stderr.startswith('affine-joint-sim replay: error: ')
    assert 'Traceback' not in replayed.stderr


def test_a_damaged_payload_is_a_damaged_bag_not_a_divergence(sample_bag, tmp_path):
    damaged = tmp_path / 'damaged'
    _copy(sample_bag, damaged, damage='/joint_states')
    replayed = cli('replay', damaged)
    assert replayed.returncode == 2, replayed.stdout + replayed.stderr
    assert 'damaged bag: the message on /joint_states at bag time' in replayed.stderr
    assert 'Traceback' not in replayed.stderr


@pytest.mark.parametrize('flags, message', [
    (['--tol', 'nan'], 'argument --tol: expected a finite number >= 0'),
    (['--tol', '-1'], 'argument --tol: expected a finite number >= 0'),
    (['--scene', 'no_such_scene'], "--scene: scene 'no_such_scene' is neither a file nor a "
                                   'packaged scene'),
])
def test_bad_replay_flags_exit_2_with_one_line(sample_bag, flags, message):
    replayed = cli('replay', sample_bag, *flags)
    assert replayed.returncode == 2 and message in replayed.stderr, replayed.stderr
    assert 'Traceback' not in replayed.stderr


def test_replay_takes_a_packaged_scene_name(sample_bag):
    replayed = cli('replay', sample_bag, '--scene', 'pendulum')
    assert replayed.returncode in (0, 1), replayed.stderr         # a what-if: it may diverge
    assert 'max |Δθ|' in replayed.stdout and 'Traceback' not in replayed.stderr


def test_publish_drives_a_running_node_in_another_namespace(sample_bag, spawn, ros_node,
                                                             wait_for):
    commands = [m for topic, msgs in bag_messages(sample_bag).items()
                if topic.endswith('/external_torque') for m in msgs]
    assert commands, 'the sample bag should hold torque commands'
    spawn('-m', 'affine_joint_sim.cli', 'run', '--ros-args', '-r', '__ns:=/r1')
    states = Inbox(ros_node, 'joint_states', name='/r1/joint_states')
    assert wait_for(lambda: states.last is not None, timeout=30.0)
    played = cli('replay', sample_bag, '--publish', '--rate', 10, '--namespace', '/r1')
    assert played.returncode == 0, played.stdout + played.stderr
    assert wait_for(lambda: states.last.effort[0] == commands[-1].data)


def test_replay_refuses_bags_it_cannot_reproduce(sample_bag, tmp_path):
    foreign = tmp_path / 'foreign'
    _copy(sample_bag, foreign, drop='/events')
    refused = cli('replay', foreign)
    assert refused.returncode == 2 and 'no start event' in refused.stderr, refused.stderr
    device = cli('replay', sample_bag, '--device', 'cuda:7')
    assert device.returncode == 2 and '--device cuda:7' in device.stderr
    assert 'Traceback' not in refused.stderr + device.stderr
    assert cli('replay', sample_bag, '--publish', '--rate', 0).returncode == 2


def test_sigterm_ends_the_run_cleanly_and_finalises_the_bag(sim, ros_node, wait_for, tmp_path):
    bag = tmp_path / 'terminated'
    child = sim('--mode', 'realtime', '--real-time-factor', '4', '--record', bag)
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: len(states.messages) > 5)
    child.send_signal(signal.SIGTERM)
    output = child.stop()
    assert child.returncode == 0 and 'Traceback' not in output, output
    assert f'bag: {bag}' in output
    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    recorded = bag_messages(bag)
    assert metadata['message_count'] == sum(len(v) for v in recorded.values())
    steps = int(output.split(' steps,')[0].split()[-1])
    assert len(recorded['/joint_states']) == steps + 1      # the initial state and every step
    assert not list(bag.glob('.split_*'))                     # no scratch left behind


def test_paths_that_are_no_bag_say_what_they_are(tmp_path):
    """Before: an empty directory and a bag directory without metadata.yaml gave rosbags'
    own words, and one split of a bag 'no joint_states' without naming the bag."""
    empty = tmp_path / 'empty'
    empty.mkdir()
    unlisted = tmp_path / 'unlisted'
    unlisted.mkdir()
    (unlisted / 'unlisted_0.mcap').write_bytes(
        (REPO / 'bags' / 'torque_step' / 'torque_step_0.mcap').read_bytes())
    split = REPO / 'bags' / 'torque_step' / 'torque_step_1.mcap'
    for path, words in ((empty, 'an empty directory: no bag in it'),
                        (unlisted, 'split files but no metadata.yaml'),
                        (split, 'one of the 4 split files of the bag '
                                f'{split.parent}: replay the bag directory')):
        replayed = cli('replay', path)
        assert replayed.returncode == 2, replayed.stdout + replayed.stderr
        assert words in replayed.stderr and 'Traceback' not in replayed.stderr, replayed.stderr
