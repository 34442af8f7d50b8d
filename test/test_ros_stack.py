"""The ROS 2 stack from PyPI wheels: messages cross processes over loopback DDS."""

import os
import pathlib

import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

TALKER = pathlib.Path(__file__).resolve().parent / 'helpers' / 'talker.py'
# [s] Discovery takes well under 1 s with the fast-discovery profile and up to ~3 s without.
TIMEOUT = 10.0
CHILD_ENV_CHECK = """
import os
import rclpy
for name in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_DOMAIN_ID', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
    print(os.environ[name])
rclpy.init()
rclpy.create_node('env_check')
rclpy.shutdown()
"""


def receive_from_talker(ros_node, wait_for, spawn, msg_type, topic, *talker_args):
    """Start a talker process on `topic`, return the first message received, stop the talker.

    Fails with the talker's output if it does not match or send within TIMEOUT, or if it does
    not shut down cleanly.
    """
    received = []
    subscription = ros_node.create_subscription(msg_type, topic, received.append, 10)
    talker = spawn(TALKER, topic, *talker_args)
    if not wait_for(lambda: subscription.get_publisher_count() > 0, TIMEOUT):
        pytest.fail(f'talker on {topic} not matched within {TIMEOUT} s:\n{talker.stop()}')
    if not wait_for(lambda: received, TIMEOUT):
        pytest.fail(f'nothing received on {topic} within {TIMEOUT} s:\n{talker.stop()}')
    output = talker.stop()
    assert talker.returncode == 0, f'talker did not exit cleanly:\n{output}'
    return received[0]


def test_float64_from_another_process(ros_node, wait_for, spawn):
    value = 2.718281828459045
    message = receive_from_talker(
        ros_node, wait_for, spawn, Float64, '/stack_test/float64', 'float64', repr(value))
    assert message.data == value


def test_joint_state_from_another_process(ros_node, wait_for, spawn):
    joints = {'shoulder': 0.25, 'elbow': -1.5, 'wrist': 3.0e-3}
    message = receive_from_talker(
        ros_node, wait_for, spawn, JointState, '/stack_test/joint_states', 'joint_state',
        *(f'{name}={position!r}' for name, position in joints.items()))
    assert list(message.name) == list(joints)
    assert list(message.position) == list(joints.values())
    assert len(message.velocity) == len(message.effort) == 0


def test_children_get_loopback_dds_and_the_fast_discovery_profile(spawn):
    profile = pathlib.Path(os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'])
    assert profile.is_file()
    child = spawn('-c', CHILD_ENV_CHECK)
    output, _ = child.communicate(timeout=30.0)
    assert child.returncode == 0, output
    # Fast DDS reports a profile it cannot parse as "[XMLPARSER Error] ..." and goes on.
    assert 'XMLPARSER' not in output, output
    assert output.split() == [
        'LOCALHOST', os.environ['ROS_DOMAIN_ID'], os.environ['FASTRTPS_DEFAULT_PROFILES_FILE']]
