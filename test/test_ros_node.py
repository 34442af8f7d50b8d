"""The node over real DDS: the node runs in a child process, the client is this test's node.

Every wait is on a condition with a timeout (conftest `wait_for`), never a fixed sleep.
"""

import math
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from rclpy.duration import Duration
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from helpers.ros_client import DT_NS, Inbox, call, node_services, publisher, stamp_ns

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / 'msg_configs' / 'scenes'


def test_topics_services_and_types(sim, ros_node, wait_for):
    child = sim('--scene', 'double_pendulum')
    expected = {
        '/joint_states': 'sensor_msgs/msg/JointState',
        '/joint_commands': 'sensor_msgs/msg/JointState',
        '/clock': 'rosgraph_msgs/msg/Clock',
        '/affine_joint_sim/scene': 'std_msgs/msg/String',
        '/joints/shoulder/external_torque': 'std_msgs/msg/Float64',
        '/joints/elbow/external_torque': 'std_msgs/msg/Float64',
        '/joints/shoulder/external_torque/is_constrained': 'std_msgs/msg/Bool',
        '/joints/elbow/external_torque/is_constrained': 'std_msgs/msg/Bool',
    }

    def seen():
        topics = dict(ros_node.get_topic_names_and_types())
        return all(topics.get(name) == [kind] for name, kind in expected.items())

    assert wait_for(seen), dict(ros_node.get_topic_names_and_types())
    services = node_services(ros_node)
    assert services['/affine_joint_sim/reset'] == ['std_srvs/srv/Trigger']
    assert services['/affine_joint_sim/pause'] == ['std_srvs/srv/SetBool']
    assert services['/affine_joint_sim/step'] == ['std_srvs/srv/Trigger']
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: states.last is not None)
    assert list(states.last.name) == ['shoulder', 'elbow']
    assert 'Traceback' not in child.stop()


@pytest.mark.parametrize('torque', [2.0, -2.0])
def test_torque_turns_the_joint_by_the_right_hand_rule(sim, ros_node, wait_for, torque):
    sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    pub = publisher(ros_node, wait_for, 'joint_torque', 'shoulder')
    pub.publish(Float64(data=torque))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == torque)
    # From rest, +tau about +x (x1 - x0) raises the angle: it passes 0.2 rad within ~0.3 s.
    assert wait_for(lambda: math.copysign(1.0, torque) * states.last.position[0] > 0.2)


def test_prismatic_joints_take_a_force_and_fixed_joints_no_command(sim, ros_node, wait_for):
    child = sim('--scene', 'gantry', '--mode', 'realtime', '--real-time-factor', '2.0')
    topics = {'/joints/rail/external_force': 'std_msgs/msg/Float64',
              '/joints/rail/external_force/is_constrained': 'std_msgs/msg/Bool',
              '/joints/swing/external_torque': 'std_msgs/msg/Float64'}
    assert wait_for(lambda: all(dict(ros_node.get_topic_names_and_types()).get(name) == [kind]
                                for name, kind in topics.items()))
    names = [n for n, _ in ros_node.get_topic_names_and_types()]
    assert not any('hook_weld' in n or n == '/joints/rail/external_torque' for n in names), names
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_force', 'rail').publish(Float64(data=3.0))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 3.0)
    # a positive force moves the carriage along +x: distance in m, velocity in m/s
    assert wait_for(lambda: states.last.position[0] > 0.02 and states.last.velocity[0] > 0.0)
    assert list(states.last.name) == ['rail', 'swing']       # a fixed joint has no state
    publisher(ros_node, wait_for, 'joint_force_enable', 'rail').publish(Bool(data=False))
    assert wait_for(lambda: states.last.effort[0] == 0.0)
    assert 'Traceback' not in child.stop()


def test_effort_commands_move_the_joints_of_command_joints(sim, ros_node, wait_for):
    child = sim('--scene', 'double_pendulum', '--mode', 'realtime', '--real-time-factor', '2.0',
                '--command-joints', 'elbow,shoulder')
    states = Inbox(ros_node, 'joint_states')
    efforts = publisher(ros_node, wait_for, 'effort_commands')
    efforts.publish(Float64MultiArray(data=[-0.7, 1.5]))       # elbow, shoulder
    assert wait_for(lambda: states.last is not None and list(states.last.effort) == [1.5, -0.7])
    efforts.publish(Float64MultiArray(data=[1.0]))
    seen = len(states.messages)
    assert wait_for(lambda: len(states.messages) > seen + 10)
    assert list(states.last.effort) == [1.5, -0.7]
    output = child.stop()
    assert '1 efforts but command_joints has 2 (elbow, shoulder): message dropped' in output


def test_position_commands_drive_the_joints_that_have_a_drive(sim, ros_node, wait_for,
                                                              tmp_path):
    data = yaml.safe_load(SCENES.joinpath('double_pendulum.yaml').read_text())
    data['joints'][0]['drive'] = {'target': 0.0, 'strength_ratio': 0.01}
    for joint in data['joints']:
        # undamped, this soft drive swings the double pendulum for seconds (0.1..0.7 rad at
        # step 300): the phase, not the drive, would decide the assertion below
        joint['damping'] = 3.0
    scene = tmp_path / 'driven.yaml'
    scene.write_text(yaml.safe_dump(data))
    child = sim('--scene', scene, '--mode', 'lockstep')
    states = Inbox(ros_node, 'joint_states')
    positions = publisher(ros_node, wait_for, 'position_commands')
    # in lockstep every array answers the current state: one step per message
    for _ in range(300):
        count = len(states.messages)
        positions.publish(Float64MultiArray(data=[0.4, 0.0]))
        assert wait_for(lambda: len(states.messages) > count)
    # the drive holds 0.4 rad less the sag of its spring K/dt² under the links' weight
    settled = [state.position[0] for state in states.messages[-50:]]
    assert 0.3 < min(settled) and max(settled) < 0.4 and max(settled) - min(settled) < 1e-3
    output = child.stop()
    assert "joint 'elbow' has no drive" in output and output.count('has no drive') == 1


def test_joint_commands_positions_track_as_the_ros2_control_topic_interface_sends_them(
        sim, ros_node, wait_for, tmp_path):
    """The message sequence of ros2_control's JointStateTopicSystem (its write() each update:
    every joint named, a position per joint with a position command interface, velocity and
    effort empty, stamped with the controller manager's clock, published with QoS depth 1;
    its read() subscribes to joint_states with the sensor-data QoS): the drives take the
    positions as targets and the joints settle on them (no gravity: no sag)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

    data = yaml.safe_load(SCENES.joinpath('double_pendulum.yaml').read_text())
    data['gravity'] = [0.0, 0.0, 0.0]
    for joint in data['joints']:
        joint['drive'] = {'target': 0.0, 'strength_ratio': 0.1}
        joint['damping'] = 20.0
    scene = tmp_path / 'driven.yaml'
    scene.write_text(yaml.safe_dump(data))
    child = sim('--scene', scene, '--mode', 'realtime', '--real-time-factor', '4.0')
    states = []
    ros_node.create_subscription(JointState, '/joint_states', states.append,
                                 qos_profile_sensor_data)
    commands = ros_node.create_publisher(
        JointState, '/joint_commands', QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
    assert wait_for(lambda: commands.get_subscription_count() > 0)

    def tracked(targets):
        message = JointState(name=['shoulder', 'elbow'], position=list(targets))
        message.header.stamp = ros_node.get_clock().now().to_msg()
        commands.publish(message)           # each update of the controller manager
        return bool(states) and all(abs(p - t) < 1e-3
                                    for p, t in zip(states[-1].position, targets))

    for targets in ((0.4, -0.3), (-0.2, 0.5)):
        assert wait_for(lambda: tracked(targets), timeout=30.0), states[-1].position
    assert list(states[-1].effort) == [0.0, 0.0]        # no torque was commanded
    output = child.stop()
    assert 'Traceback' not in output and 'dropped' not in output and 'ignored' not in output


def test_joint_commands_velocities_spin_the_damped_joints_to_those_speeds(sim, ros_node,
                                                                          wait_for, tmp_path):
    """A velocity command interface's messages (velocity filled, position and effort empty):
    each joint's damping pulls it to the commanded speed (no gravity, no drive)."""
    data = yaml.safe_load(SCENES.joinpath('double_pendulum.yaml').read_text())
    data['gravity'] = [0.0, 0.0, 0.0]
    for joint in data['joints']:
        joint['damping'] = 5.0
    scene = tmp_path / 'damped.yaml'
    scene.write_text(yaml.safe_dump(data))
    child = sim('--scene', scene, '--mode', 'realtime', '--real-time-factor', '4.0')
    states = Inbox(ros_node, 'joint_states')
    commands = publisher(ros_node, wait_for, 'joint_commands')
    speeds = (0.5, -0.3)

    def spinning():
        commands.publish(JointState(name=['shoulder', 'elbow'], velocity=list(speeds)))
        return states.last is not None and all(
            abs(v - s) < 1e-3 for v, s in zip(states.last.velocity, speeds))

    assert wait_for(spinning, timeout=30.0), states.last.velocity
    output = child.stop()
    assert 'Traceback' not in output and 'ignored' not in output


def test_a_non_physical_torque_is_clamped_and_the_joint_keeps_moving(sim, ros_node, wait_for):
    child = sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    pub = publisher(ros_node, wait_for, 'joint_torque', 'shoulder')
    pub.publish(Float64(data=1e308))
    pub.publish(Float64(data=0.5))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 0.5)
    assert wait_for(lambda: states.last.position[0] > 0.01)
    output = child.stop()
    assert 'torque/force 1e+308' in output and 'beyond what one step can represent' in output


def test_a_flood_of_1000_commands_per_second_is_taken_without_loss(sim, ros_node, wait_for):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    child = sim('--mode', 'fast')
    states = Inbox(ros_node, 'joint_states')
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     history=HistoryPolicy.KEEP_ALL)
    flood = ros_node.create_publisher(JointState, 'joint_commands', qos)
    assert wait_for(lambda: flood.get_subscription_count() > 0)
    msg, start = JointState(name=['shoulder'], effort=[0.1]), time.monotonic()
    for k in range(2000):                   # 1000/s for 2 s, paced by the wall clock
        while time.monotonic() < start + k / 1000.0:
            pass
        msg.effort = [0.2 if k == 1999 else 0.1]
        flood.publish(msg)
    assert flood.wait_for_all_acked(Duration(seconds=10.0))
    # in order from one reliable publisher: the last one applied means all were taken
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 0.2)
    output = child.stop()
    assert 'commands taken: 2000' in output, output


def test_an_oversized_command_is_dropped_undecoded_and_stepping_goes_on(sim, ros_node,
                                                                          wait_for):
    child = sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    commands = publisher(ros_node, wait_for, 'joint_commands')
    names = [f'joint_{k}' for k in range(100_000)]
    commands.publish(JointState(name=names, effort=[1.0] * len(names)))
    commands.publish(JointState(name=['shoulder'], effort=[0.25]))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 0.25)
    output = child.stop()
    assert 'over max_command_bytes (65536): dropped undecoded' in output
    assert 'commands taken: 1; dropped: 1 oversized' in output


def test_live_parameter_changes_are_checked_then_applied_between_steps(sim, ros_node,
                                                                        wait_for):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')

    def set_parameter(name, **value):
        kind = {'double_value': ParameterType.PARAMETER_DOUBLE,
                'string_value': ParameterType.PARAMETER_STRING}[next(iter(value))]
        request = SetParameters.Request(parameters=[Parameter(
            name=name, value=ParameterValue(type=kind, **value))])
        return call(ros_node, wait_for, SetParameters, '/affine_joint_sim/set_parameters',
                    request).results[0]

    refused = set_parameter('real_time_factor', double_value=0.0)
    assert not refused.successful and 'out of range' in refused.reason
    refused = set_parameter('scene', string_value='arm')
    assert not refused.successful and 'read-only parameter: scene' in refused.reason
    assert set_parameter('mode', string_value='lockstep').successful
    # lockstep now: the node holds its state and publishes it again while it waits
    assert wait_for(lambda: len(states.messages) >= 2 and
                    stamp_ns(states.messages[-1]) == stamp_ns(states.messages[-2]))
    held = stamp_ns(states.last)
    publisher(ros_node, wait_for, 'joint_commands').publish(JointState(name=['shoulder'],
                                                                       effort=[0.0]))
    assert wait_for(lambda: stamp_ns(states.last) == held + DT_NS)


def test_every_parameter_describes_itself_and_the_fixed_ones_are_read_only(sim, ros_node,
                                                                           wait_for):
    from rcl_interfaces.srv import DescribeParameters

    from affine_joint_sim.ros.parameters import PARAMETERS

    sim()
    names = list(PARAMETERS)
    described = call(ros_node, wait_for, DescribeParameters,
                     '/affine_joint_sim/describe_parameters',
                     DescribeParameters.Request(names=names)).descriptors
    assert [d.name for d in described] == names
    for descriptor in described:
        assert descriptor.description == PARAMETERS[descriptor.name].help != ''
    # the ones the README lists as changeable while the node runs
    assert {d.name for d in described if not d.read_only} == {
        'mode', 'real_time_factor', 'lockstep_publishers', 'max_command_bytes', 'publish_clock',
        'command_timeout', 'duration'}


def test_disabled_torque_is_not_applied(sim, ros_node, wait_for):
    sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=1.5))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.5)
    publisher(ros_node, wait_for, 'joint_enable', 'shoulder').publish(Bool(data=False))
    assert wait_for(lambda: states.last.effort[0] == 0.0)
    seen = len(states.messages)
    assert wait_for(lambda: len(states.messages) > seen + 20)
    assert all(m.effort[0] == 0.0 for m in states.since(seen))


def test_nan_torque_is_dropped_with_a_warning_and_the_node_stays_up(sim, ros_node, wait_for):
    child = sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    pub = publisher(ros_node, wait_for, 'joint_torque', 'shoulder')
    pub.publish(Float64(data=0.75))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 0.75)
    pub.publish(Float64(data=float('nan')))
    pub.publish(Float64(data=float('inf')))
    seen = len(states.messages)
    assert wait_for(lambda: len(states.messages) > seen + 30)
    assert all(m.effort[0] == 0.75 and math.isfinite(m.position[0])
               for m in states.since(seen))
    assert child.poll() is None
    output = child.stop()
    assert '/joints/shoulder/external_torque: torque nan' in output, output
    assert 'Traceback' not in output


def test_joint_commands_set_several_joints_at_once(sim, ros_node, wait_for):
    sim('--scene', 'double_pendulum', '--mode', 'realtime')
    states = Inbox(ros_node, 'joint_states')
    pub = publisher(ros_node, wait_for, 'joint_commands')
    pub.publish(JointState(name=['elbow', 'shoulder'], effort=[-0.5, 1.25]))
    assert wait_for(lambda: states.last is not None and list(states.last.effort) == [1.25, -0.5])


def test_command_timeout_drops_a_silent_joints_torque_once(sim, ros_node, wait_for):
    child = sim('--mode', 'realtime', '--real-time-factor', '2.0', '--command-timeout', '0.2')
    states = Inbox(ros_node, 'joint_states')
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=1.0))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.0)
    applied = [stamp_ns(m) for m in states.messages if m.effort[0] == 1.0]
    assert wait_for(lambda: states.last.effort[0] == 0.0)
    dropped = stamp_ns(next(m for m in states.messages
                            if stamp_ns(m) > applied[0] and m.effort[0] == 0.0))
    # The torque acts in the steps starting up to 0.2 s after the one it was applied to.
    assert dropped - applied[0] == pytest.approx(0.2e9, abs=1.5 * DT_NS)
    output = child.stop()
    assert output.count('command_timeout 0.2 s') == 1, output


def test_pause_step_reset_and_clock(sim, ros_node, wait_for):
    sim('--mode', 'fast')
    states = Inbox(ros_node, 'joint_states')
    clock = Inbox(ros_node, 'clock')
    publisher(ros_node, wait_for, 'joint_torque', 'shoulder').publish(Float64(data=1.0))
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.0)
    pause = '/affine_joint_sim/pause'
    result = call(ros_node, wait_for, SetBool, pause, SetBool.Request(data=True))
    assert result.success, result.message
    step = call(ros_node, wait_for, Trigger, '/affine_joint_sim/step', Trigger.Request())
    assert step.success, step.message
    before = int(step.message.split()[1].rstrip(',')) * DT_NS      # 'step N, t = ... s'
    # Fast mode may have left a backlog: wait until the stepped state is the newest.
    assert wait_for(lambda: stamp_ns(states.last) == before)
    for k in range(1, 4):
        assert call(ros_node, wait_for, Trigger, '/affine_joint_sim/step',
                    Trigger.Request()).success
        assert wait_for(lambda: stamp_ns(states.last) == before + k * DT_NS)
        assert wait_for(lambda: (clock.last.clock.sec * 10**9 + clock.last.clock.nanosec) ==
                        before + k * DT_NS)
    reset = call(ros_node, wait_for, Trigger, '/affine_joint_sim/reset', Trigger.Request())
    assert reset.success, reset.message
    assert wait_for(lambda: stamp_ns(states.last) == 0)
    assert states.last.position[0] == 0.0 and states.last.effort[0] == 0.0
    resume = call(ros_node, wait_for, SetBool, pause, SetBool.Request(data=False))
    assert resume.success
    assert wait_for(lambda: stamp_ns(states.last) > 10 * DT_NS)
    refused = call(ros_node, wait_for, Trigger, '/affine_joint_sim/step', Trigger.Request())
    assert not refused.success and 'not paused' in refused.message


def _lockstep_run(sim, ros_node):
    """States of the node in lockstep for 0.5 s under the demo PD controller (this process)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from affine_joint_sim.ros.controller import PDController

    child = sim('--scene', 'double_pendulum', '--mode', 'lockstep', '--duration', '0.5')
    listener = rclpy.create_node('lockstep_listener', context=ros_node.context)
    states = Inbox(listener, 'joint_states')
    executor = SingleThreadedExecutor(context=ros_node.context)
    executor.add_node(listener)
    deadline = time.monotonic() + 30.0
    while not states.messages and time.monotonic() < deadline:    # matched before the loop runs
        executor.spin_once(timeout_sec=0.1)
    controller = PDController({'shoulder': 0.5, 'elbow': -0.3}, kp=40.0, kd=4.0,
                              context=ros_node.context)
    executor.add_node(controller)
    while len({stamp_ns(m) for m in states.messages}) < 51 and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    output = child.stop()
    executor.shutdown()
    controller.destroy_node()
    listener.destroy_node()
    assert 'Traceback' not in output
    by_stamp = {}           # a state the node waited on may have been published again
    for m in states.messages:
        by_stamp.setdefault(stamp_ns(m), (stamp_ns(m), bytes(m.position), bytes(m.velocity),
                                          bytes(m.effort)))
    return [by_stamp[k] for k in sorted(by_stamp)]


def test_lockstep_closed_loop_is_bit_identical(sim, ros_node, wait_for):
    first = _lockstep_run(sim, ros_node)
    second = _lockstep_run(sim, ros_node)
    assert [s[0] for s in first] == [k * DT_NS for k in range(51)]
    assert first == second
    assert first[-1][3] != first[1][3]          # the controller did act


@pytest.mark.parametrize('flags, message', [
    (['--scene', 'no_such_scene'], "parameter 'scene': scene 'no_such_scene' is neither"),
    (['--real-time-factor', '0'], "parameter 'real_time_factor': 0.0 is out of range"),
    (['--command-timeout', 'nan'], "parameter 'command_timeout': nan is out of range"),
    (['--ros-args', '-p', 'mode:=slow'], "parameter 'mode': 'slow' is not one of realtime"),
    (['--device', 'gpu7'], "parameter 'device':"),
    (['--command-joints', 'shoulder,knee'], "parameter 'command_joints': knee is not a moving "
                                            'joint of the scene (valid, once each: shoulder)'),
    (['--lockstep-publishers', '0'], "parameter 'lockstep_publishers': 0 is out of range"),
    (['--viz-rate', '-1'], "parameter 'viz_rate': -1.0 is out of range"),
    (['--frame-id', 'my frame'], "parameter 'frame_id': 'my frame' is not a frame name"),
    (['--scene', 'broken.urdf'], "parameter 'scene': scene 'broken.urdf' is neither"),
    (['--ros-args', '--params-file', '/missing.yaml'], "Couldn't parse params file"),
    (['--ros-args', '--no-such-ros-argument'], 'unknown ROS arguments'),
])
def test_bad_parameter_exits_with_a_clear_error(flags, message):
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', *flags],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert message in done.stderr, done.stderr
    assert 'Traceback' not in done.stderr


def test_an_integer_for_a_float_parameter_is_a_float():
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--mode', 'fast',
                           '--ros-args', '-p', 'duration:=1', '-p', 'real_time_factor:=2'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert '100 steps, 1.000 s simulated' in done.stdout


def test_a_joint_name_too_long_for_a_topic_is_refused_naming_the_joint(tmp_path):
    data = yaml.safe_load(SCENES.joinpath('pendulum.yaml').read_text())
    data['joints'][0]['name'] = 'j' * 250
    scene = tmp_path / 'long.yaml'
    scene.write_text(yaml.safe_dump(data))
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene', scene],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "error: joint 'jjjj" in done.stderr, done.stderr
    assert 'use a shorter joint name' in done.stderr and 'Traceback' not in done.stderr


def test_bad_scene_file_names_the_key_path(tmp_path):
    scene = tmp_path / 'bad.yaml'
    scene.write_text('name: bad\nbodies:\n  - {name: a, shape: {box: [1, 1, 1]}, mass: -1}\n'
                     'joints: []\n')
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene',
                           str(scene)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert 'bodies[0].mass' in done.stderr and 'Traceback' not in done.stderr


def test_params_file_is_read_and_flags_beat_it(tmp_path):
    params = tmp_path / 'params.yaml'
    params.write_text((REPO / 'msg_configs' / 'node_params.yaml').read_text()
                      .replace('mode: realtime', 'mode: fast')
                      .replace('duration: 0.0', 'duration: 0.25')
                      .replace('scene: pendulum', 'scene: double_pendulum'))
    from_file = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run',
                                '--ros-args', '--params-file', str(params)],
                               capture_output=True, text=True, timeout=60)
    assert from_file.returncode == 0, from_file.stderr
    assert '25 steps, 0.250 s simulated' in from_file.stdout and '(fast)' in from_file.stdout
    assert 'elbow' in from_file.stdout
    flagged = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run',
                              '--duration', '0.05', '--scene', 'pendulum',
                              '--ros-args', '--params-file', str(params)],
                             capture_output=True, text=True, timeout=60)
    assert flagged.returncode == 0, flagged.stderr
    assert '5 steps, 0.050 s simulated' in flagged.stdout and 'elbow' not in flagged.stdout


def test_realtime_warns_when_it_cannot_keep_up_and_reports_the_factor():
    # 1000x real time at dt 0.01 s needs 100,000 arm steps/s: far beyond any CPU here; the
    # run lasts several 2 s checking windows.
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene',
                           'arm', '--mode', 'realtime', '--real-time-factor', '1000',
                           '--duration', '600'],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    warning = done.stderr.split('cannot keep up with real_time_factor 1000: achieved ')[1]
    assert float(warning.split()[0]) < 500
    factor = float(done.stdout.split('real-time factor ')[1].split()[0])
    assert 1 < factor < 500


def test_the_summary_counts_rejected_steps_and_the_warning_says_what_to_change(tmp_path):
    """A stiff drive 100 rad from its target: steps do not converge or are rejected (a joint
    would turn over 0.9π). Before, the summary said nothing of them and the warning only
    'reduce dt'."""
    data = yaml.safe_load(SCENES.joinpath('pendulum.yaml').read_text())
    data['joints'][0]['drive'] = {'target': 100.0, 'strength_ratio': 1.0e9}
    scene = tmp_path / 'wild.yaml'
    scene.write_text(yaml.safe_dump(data))
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene', scene,
                           '--mode', 'fast', '--duration', '0.1'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    line = done.stdout.split('steps not converged: ')[1].split('\n')[0]
    unconverged = int(line.split(';')[0])
    rejected = int(line.split('with a joint turning over')[0].split()[-1])
    assert unconverged > 0 and rejected > 0, done.stdout
    assert 'drives far from their targets: shoulder' in done.stderr, done.stderr


def test_node_params_yaml_lists_every_parameter():
    """Before, it lacked viz_rate and frame_id."""
    from affine_joint_sim.ros.parameters import PARAMETERS

    listed = yaml.safe_load((REPO / 'msg_configs' / 'node_params.yaml').read_text())
    assert set(listed['affine_joint_sim']['ros__parameters']) == set(PARAMETERS)


def test_an_unknown_parameter_in_a_params_file_is_warned_about_naming_it(tmp_path):
    """Before, a typo in a params file did nothing, silently. (Warned, not refused: a shared
    params file may hold other nodes' parameters.)"""
    params = tmp_path / 'params.yaml'
    params.write_text('affine_joint_sim:\n  ros__parameters:\n    viz_rat: 5.0\n')
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--duration',
                           '0.05', '--mode', 'fast', '--ros-args', '--params-file', str(params)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "unknown parameter 'viz_rat' (from -p or --params-file) ignored; this node's " \
        'parameters: scene,' in done.stderr, done.stderr


def test_an_integer_set_at_run_time_keeps_a_float_parameter_a_float(sim, ros_node, wait_for):
    """Before, `ros2 param set /affine_joint_sim real_time_factor 2` made it an integer."""
    from rcl_interfaces.msg import Parameter as ParameterMsg
    from rcl_interfaces.msg import ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters

    child = sim('--mode', 'realtime')
    two = ParameterMsg(name='real_time_factor',
                       value=ParameterValue(type=ParameterType.PARAMETER_INTEGER,
                                            integer_value=2))
    done = call(ros_node, wait_for, SetParameters, '/affine_joint_sim/set_parameters',
                SetParameters.Request(parameters=[two]))
    assert done.results[0].successful, done.results[0].reason
    got = call(ros_node, wait_for, GetParameters, '/affine_joint_sim/get_parameters',
               GetParameters.Request(names=['real_time_factor'])).values[0]
    assert got.type == ParameterType.PARAMETER_DOUBLE and got.double_value == 2.0
    child.stop()


def test_the_node_says_how_a_urdf_robot_is_held():
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene', 'arm6',
                           '--mode', 'fast', '--duration', '0.01'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "base: URDF root link 'world' welded to the world (fixed_base: true" in \
        done.stderr, done.stderr


def test_a_warning_is_one_line_and_warp_says_nothing_on_a_cpu(tmp_path):
    """Before, every warning came with the project's file, line and source, and every command
    began with Warp's 'no CUDA driver' line on a CPU machine."""
    robot = (REPO / 'msg_configs' / 'robots' / 'arm6.urdf').read_text().replace(
        '<limit lower="-3.1" upper="3.1"', '<limit lower="0" upper="0"', 1)
    (tmp_path / 'locked.urdf').write_text(robot)
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene',
                           tmp_path / 'locked.urdf', '--mode', 'fast', '--duration', '0.02'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    warning = [line for line in lines if 'joints locked by lower = upper: 1' in line]
    assert len(warning) == 1 and warning[0].startswith('SimulationWarning: locked.urdf: '), \
        done.stderr
    assert not any('.py:' in line or 'warnings.warn' in line or 'Warp' in line
                   for line in lines), done.stderr
