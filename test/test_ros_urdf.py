"""A URDF robot in the node over real DDS: its URDF on robot_description, its joint names in
joint_states and joint_commands, per-joint topics under sanitized tokens, bags that hold the
URDF. The node runs in a child process; every wait is on a condition."""

from pathlib import Path

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from helpers.ros_client import Inbox, publisher, stamp_ns

DATA = Path(__file__).resolve().parent / 'data' / 'urdf'


def odd_names(tmp_path) -> Path:
    """The test double pendulum with joint names outside the topic alphabet."""
    text = (DATA / 'double_pendulum.urdf').read_text()
    path = tmp_path / 'odd.urdf'
    path.write_text(text.replace('"shoulder"', '"arm/shoulder-1"').replace('"elbow"',
                                                                           '"elbow.2"'))
    return path


def test_node_serves_a_urdf_robot_under_its_joint_names(sim, ros_node, wait_for, tmp_path):
    urdf = odd_names(tmp_path)
    child = sim('--scene', urdf, '--mode', 'realtime')
    description = Inbox(ros_node, 'robot_description')      # latched: a late joiner gets it
    assert wait_for(lambda: description.last is not None)
    assert description.last.data == urdf.read_text()
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: states.last is not None)
    assert list(states.last.name) == ['arm/shoulder-1', 'elbow.2']
    publisher(ros_node, wait_for, 'joint_commands').publish(
        JointState(name=['elbow.2', 'arm/shoulder-1'], effort=[-0.5, 1.25]))
    assert wait_for(lambda: list(states.last.effort) == [1.25, -0.5])
    # the per-joint topic of 'elbow.2' is joints/elbow_2/external_torque
    torque = publisher(ros_node, wait_for, 'joint_torque', 'elbow.2')
    assert torque.topic_name == '/joints/elbow_2/external_torque'
    torque.publish(Float64(data=0.75))
    assert wait_for(lambda: list(states.last.effort) == [1.25, 0.75])
    assert 'Traceback' not in child.stop()


def test_a_bad_urdf_is_one_line_and_exit_2(spawn, tmp_path):
    path = tmp_path / 'broken.urdf'
    path.write_text('<robot name="r"><link name="a"><inertial><mass value="1"/></inertial>'
                    '</link><joint name="j" type="continuous"><parent link="a"/></joint></robot>')
    child = spawn('-m', 'affine_joint_sim.cli', 'run', '--scene', path, '--duration', '1')
    output, _ = child.communicate(timeout=60)
    assert child.returncode == 2, output
    assert output.strip().splitlines()[-1].startswith(
        f'affine-joint-sim: error: {path}:1: <joint> \'j\' needs <child'), output
    assert 'Traceback' not in output


def test_a_recorded_urdf_run_holds_the_urdf_and_replays_without_it(
        sim, ros_node, wait_for, tmp_path):
    from test_ros_bags import bag_messages, cli

    urdf = odd_names(tmp_path)
    bag = tmp_path / 'run'
    child = sim('--scene', urdf, '--mode', 'realtime', '--real-time-factor', '4',
                '--record', bag)
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_torque', 'arm/shoulder-1').publish(Float64(data=1.5))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.5)
    assert wait_for(lambda: stamp_ns(states.last) > 20 * 10_000_000)
    assert 'Traceback' not in child.stop()
    recorded = bag_messages(bag)
    assert [m.data for m in recorded['/robot_description']] == [urdf.read_text()]
    assert [m.data for m in recorded['/joints/arm_shoulder_1/external_torque']] == [1.5]
    urdf.unlink()                          # the bag's scene stands alone
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert 'largest difference 0.000e+00' in replayed.stdout
