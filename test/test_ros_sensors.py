"""Sensors over ROS: the node publishes each sensor of its scene on sensors/<name> every step
(real processes over loopback DDS), records them in its bag, and replay reproduces them."""

import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader
from std_msgs.msg import Float64

from affine_joint_sim.ros.topics import message_class
from helpers.cli import cli
from helpers.ros_client import Inbox, publisher, stamp_ns

G = 9.81
SCENE = '''
name: sensed
dt: 0.01
ground: {height: 0.0}
contact: {}
bodies:
  - {name: base, shape: {box: [0.2, 0.2, 0.2]}, mass: 1.0, fixed: true, position: [0, 0, 2.0]}
  - {name: link, shape: {box: [0.1, 0.1, 1.0]}, mass: 1.0, position: [0, 0, 1.5]}
  - {name: box, shape: {box: [0.1, 0.1, 0.1]}, mass: 1.0, position: [1.0, 0, 0.0507],
     collision: shape}
joints:
  - {name: shoulder, parent: base, child: link, x0: [-0.05, 0, 2.0], x1: [0.05, 0, 2.0]}
sensors:
  - {name: link_imu, type: imu, body: link}
  - {name: box_imu, type: imu, body: box}
  - {name: box_touch, type: contact, body: box}
'''
TYPES = {'/sensors/link_imu': 'sensor_msgs/msg/Imu', '/sensors/box_imu': 'sensor_msgs/msg/Imu',
         '/sensors/box_touch': 'geometry_msgs/msg/WrenchStamped'}


def _bag(path) -> tuple[dict, dict]:
    """Every message of a bag by topic (decoded), and each topic's message type."""
    by_topic, types = {}, {}
    with Reader(path) as reader:
        for connection, _, raw in reader.messages():
            types[connection.topic] = connection.msgtype
            by_topic.setdefault(connection.topic, []).append(
                deserialize_message(bytes(raw), message_class(connection.msgtype)))
    return by_topic, types


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / 'sensed.yaml'
    path.write_text(SCENE)
    return path


def test_the_node_publishes_records_and_replay_reproduces_its_sensors(sim, ros_node, wait_for,
                                                                      tmp_path, scene):
    bag = tmp_path / 'run'
    child = sim('--scene', scene, '--mode', 'realtime', '--real-time-factor', '4',
                '--record', bag)
    link_imu = Inbox(ros_node, 'sensor_imu', '/sensors/link_imu')
    box_imu = Inbox(ros_node, 'sensor_imu', '/sensors/box_imu')
    box_touch = Inbox(ros_node, 'sensor_contact', '/sensors/box_touch')
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=2.0))
    # the torque turns the link about x: its gyro sees it
    assert wait_for(lambda: link_imu.last is not None
                    and link_imu.last.angular_velocity.x > 0.1, timeout=20.0)
    # the box has come to rest on the ground: gravity up and its weight
    assert wait_for(lambda: box_touch.last is not None and stamp_ns(box_touch.last) > 1.5e9
                    and box_imu.last is not None and stamp_ns(box_imu.last) > 1.5e9,
                    timeout=20.0)
    imu, touch = box_imu.last, box_touch.last
    assert imu.header.frame_id == 'box' and touch.header.frame_id == 'box'
    assert link_imu.last.header.frame_id == 'link'
    acceleration = imu.linear_acceleration
    assert [acceleration.x, acceleration.y, acceleration.z] == pytest.approx([0, 0, G], abs=1e-3)
    assert [imu.orientation.x, imu.orientation.y, imu.orientation.z, imu.orientation.w] == \
        pytest.approx([0, 0, 0, 1], abs=1e-5)
    force, torque = touch.wrench.force, touch.wrench.torque
    assert [force.x, force.y, force.z] == pytest.approx([0, 0, G], rel=1e-4, abs=1e-6)
    assert max(abs(torque.x), abs(torque.y), abs(torque.z)) < 1e-6
    # each sensor message has the stamp of a published state
    assert wait_for(lambda: states.last is not None and stamp_ns(states.last) > 1.5e9)
    output = child.stop()
    assert 'Traceback' not in output and f'bag: {bag}' in output, (child.returncode, output)
    assert ('sensors: /sensors/link_imu (imu on link), /sensors/box_imu (imu on box), '
            '/sensors/box_touch (contact on box)') in output, output

    recorded, types = _bag(bag)
    stamps = [stamp_ns(m) for m in recorded['/joint_states']]
    assert len(stamps) > 150 and stamps == sorted(stamps)
    for topic, msgtype in TYPES.items():
        # every step, after the state: one message per joint_states, with its stamp
        assert types[topic] == msgtype
        assert [stamp_ns(m) for m in recorded[topic]] == stamps, topic
    # the messages received over DDS are the recorded ones
    at = {stamp_ns(m): m for m in recorded['/sensors/box_touch']}
    assert at[stamp_ns(touch)] == touch
    at = {stamp_ns(m): m for m in recorded['/sensors/box_imu']}
    assert at[stamp_ns(imu)] == imu
    # before the first step (and at t = 0) an accelerometer reads -g
    first = recorded['/sensors/link_imu'][0].linear_acceleration
    assert (first.x, first.y, first.z) == (0.0, 0.0, G)

    replayed = cli('replay', bag, '--out', tmp_path / 'again')
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert f'({3 * len(stamps)} messages; each value in its unit)' in replayed.stdout
    for name in ('link_imu', 'box_imu', 'box_touch'):
        assert any(line.split() == [name, '0.000e+00'] for line in replayed.stdout.splitlines()), \
            replayed.stdout
    assert 'largest difference 0.000e+00' in replayed.stdout
    # the what-if bag holds the re-simulated sensors, the same
    again, again_types = _bag(tmp_path / 'again')
    for topic, msgtype in TYPES.items():
        assert again_types[topic] == msgtype and again[topic] == recorded[topic], topic


def test_replay_reports_a_sensor_that_differs(tmp_path, scene):
    """A recorded sensor message changed by hand is a divergence of that sensor (exit 1)."""
    from affine_joint_sim.ros.recorder import BagRecorder, BagTopic
    from affine_joint_sim.ros.replay import read_bag, replay
    from affine_joint_sim.ros.topics import load_topics
    from rclpy.serialization import serialize_message

    bag = tmp_path / 'run'
    done = cli('run', '--scene', scene, '--mode', 'fast', '--duration', 0.2, '--record', bag)
    assert done.returncode == 0, done.stderr
    assert replay(read_bag(bag)).worst() == 0.0
    topics = load_topics()
    changed = tmp_path / 'changed'
    with Reader(bag) as reader:
        connections = reader.connections
        recorder = BagRecorder(changed, 'mcap', [
            BagTopic(c.topic, c.msgtype, topics['joint_states'].qos) for c in connections])
        for connection, t_ns, raw in reader.messages():
            if connection.topic == '/sensors/box_imu' and t_ns == 100_000_000:
                msg = deserialize_message(bytes(raw), message_class(connection.msgtype))
                msg.linear_acceleration.z += 0.25
                raw = serialize_message(msg)
            recorder.write(connection.topic, t_ns, bytes(raw))
    recorder.close()
    divergence = replay(read_bag(changed))
    assert divergence.sensors['box_imu'] == pytest.approx(0.25)
    assert divergence.sensors['link_imu'] == 0.0 and divergence.max_angle.max() == 0.0
    assert math.isclose(divergence.worst(), 0.25)
    replayed = cli('replay', changed)
    assert replayed.returncode == 1 and 'ABOVE --tol' in replayed.stdout, replayed.stdout
    # a what-if with a scene without sensors compares the joints and says what it left out
    plain = tmp_path / 'plain.yaml'
    plain.write_text(SCENE.split('sensors:')[0])
    divergence = replay(read_bag(bag), scene_path=plain)
    assert divergence.sensors == {} and np.all(divergence.max_angle == 0.0)
    assert sorted(divergence.uncompared) == ['box_imu', 'box_touch', 'link_imu']


def test_a_sensor_name_too_long_for_a_topic_is_refused_in_one_line(tmp_path):
    path = tmp_path / 'long.yaml'
    path.write_text(SCENE.replace('name: box_touch', 'name: ' + 'touch' * 60))
    done = cli('run', '--scene', path, '--mode', 'fast', '--duration', 0.1)
    assert done.returncode == 2 and 'Traceback' not in done.stderr, done.stderr
    line = done.stderr.strip().splitlines()[-1]
    assert line.startswith("affine-joint-sim: error: sensor 'touchtouch") and \
        line.endswith('use a shorter sensor name'), line


def test_the_messages_carry_every_reading_bit_for_bit(scene):
    """SensorMessages writes each value of a reading (``Stepper.sensors``) into its message
    field, signed zeros and all, with the stamp and the sensor's frame."""
    from affine_joint_sim import Scene
    from affine_joint_sim.ros.sensor_messages import SensorMessages, message_values, sensor_values
    from affine_joint_sim.ros.topics import load_topics
    from affine_joint_sim.sensors import FIELDS

    topics = load_topics()
    messages = SensorMessages(Scene.load(scene), topics)
    rng = np.random.default_rng(3)
    readings = {name: {key: rng.standard_normal(size) for key, size in FIELDS[kind].items()}
                for name, kind, _ in messages.sensors}
    readings['box_touch']['torque'][:] = [0.0, -0.0, 0.0]
    filled = messages.fill(readings, 12_000_000_034)
    assert [name for name, _ in filled] == ['link_imu', 'box_imu', 'box_touch']
    for (name, raw), (_, kind, key) in zip(filled, messages.sensors):
        msg = deserialize_message(raw, topics[key].msg_class)
        assert message_values(kind, msg).tobytes() == \
            sensor_values(kind, readings[name]).tobytes(), name
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (12, 34)
        assert msg.header.frame_id == name.split('_')[0]
