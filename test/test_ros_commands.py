"""CommandBuffer: latest wins, non-finite and unknown commands rejected, command timeout."""

import math

import pytest

from affine_joint_sim.ros.commands import CommandBuffer


class FakeStepper:
    """Records what the buffer writes (the Stepper's set_torque/set_enabled signatures)."""

    def __init__(self):
        self.torque, self.enabled, self.target, self.speed = {}, {}, {}, {}

    def set_target(self, name, value):
        self.target[name] = value

    def set_velocity_target(self, name, value):
        self.speed[name] = value

    def set_torque(self, name, value):
        self.torque[name] = value

    def set_enabled(self, name, flag):
        self.enabled[name] = flag


def test_latest_command_wins_and_applies_once():
    buffer, sim = CommandBuffer(['a', 'b']), FakeStepper()
    assert buffer.torque('a', 1.0) is None
    assert buffer.torque('a', 2.0) is None
    buffer.enable('b', False)
    buffer.apply(sim, 0.0)
    assert sim.torque == {'a': 2.0} and sim.enabled == {'b': False}
    sim.torque.clear()
    buffer.apply(sim, 0.01)
    assert sim.torque == {}


@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
def test_non_finite_torque_is_rejected_and_the_last_good_one_kept(value):
    buffer, sim = CommandBuffer(['a']), FakeStepper()
    buffer.torque('a', 0.5)
    assert 'not finite' in buffer.torque('a', value)
    buffer.apply(sim, 0.0)
    assert sim.torque == {'a': 0.5}


def test_joint_commands_apply_the_valid_entries_and_name_the_bad_ones():
    buffer, sim = CommandBuffer(['a', 'b']), FakeStepper()
    problems = buffer.joint_commands(['b', 'zz', 'a'], [1.0, 2.0, math.inf])
    assert len(problems) == 2
    assert "unknown joint 'zz' (joints: a, b)" in problems[0] and 'not finite' in problems[1]
    buffer.apply(sim, 0.0)
    assert sim.torque == {'b': 1.0}
    message = Msg(name=['a'], effort=[1.0, 2.0], position=[], velocity=[])
    assert buffer.malformed('joint_commands', message) == '1 names but 2 efforts: message dropped'
    assert buffer.take('joint_commands', None, message) == [buffer.malformed('joint_commands',
                                                                             message)]


def test_joint_commands_carry_positions_and_efforts_as_the_topic_hardware_interface_sends():
    # ros2_control's JointStateTopicSystem: every joint named, one array per command interface
    # the joints declare, the others empty; NaN leaves a command as it is
    buffer = CommandBuffer(['a', 'b', 'c'], drive_joints=['a', 'b'])
    sim = FakeStepper()
    message = Msg(name=['a', 'b', 'c'], position=[0.3, math.nan, 0.1], velocity=[], effort=[])
    assert buffer.take('joint_commands', None, message) == [
        "joint 'c' has no drive: its position commands are ignored (said once)"]
    buffer.apply(sim, 0.0)
    assert sim.target == {'a': 0.3} and sim.torque == {}
    mixed = Msg(name=['b', 'a'], position=[0.2, math.nan], velocity=[],
                effort=[math.nan, 1.5])
    assert buffer.take('joint_commands', None, mixed) == []
    buffer.apply(sim, 0.01)
    assert sim.target == {'a': 0.3, 'b': 0.2} and sim.torque == {'a': 1.5}
    assert buffer.malformed('joint_commands', Msg(name=['a', 'b'], position=[0.1], velocity=[],
                                                  effort=[])) == (
        '2 names but 1 positions: message dropped')



def test_joint_commands_velocities_go_to_the_joints_with_damping():
    buffer = CommandBuffer(['a', 'b'], damped_joints=['b'])
    sim = FakeStepper()
    speeds = Msg(name=['a', 'b'], position=[], velocity=[0.5, -1.0], effort=[])
    said = ["joint 'a' has no damping: its velocity commands are ignored (said once; its "
            "damping is the velocity drive's gain)"]
    assert buffer.take('joint_commands', None, speeds) == said
    assert buffer.take('joint_commands', None, speeds) == []          # said once
    assert 'not finite' in buffer.velocity('b', math.inf)
    buffer.apply(sim, 0.0)
    assert sim.speed == {'b': -1.0}


def test_timeout_drops_a_held_torque_once_and_a_new_command_rearms_it():
    buffer, sim = CommandBuffer(['a', 'b'], command_timeout=0.2), FakeStepper()
    buffer.reset([0.0, 3.0])            # b starts with a non-zero scene torque
    buffer.torque('a', 1.0)
    buffer.apply(sim, 0.0)
    assert buffer.apply(sim, 0.2) == []                       # not yet: 0.2 s is not > 0.2 s
    notices = buffer.apply(sim, 0.21)
    assert len(notices) == 2 and sim.torque == {'a': 0.0, 'b': 0.0}
    assert buffer.apply(sim, 0.5) == []                       # said once per silence
    buffer.torque('a', -1.0)
    buffer.apply(sim, 0.6)
    assert buffer.apply(sim, 0.8) == [] and len(buffer.apply(sim, 0.81)) == 1


def test_zero_timeout_holds_forever():
    buffer, sim = CommandBuffer(['a']), FakeStepper()
    buffer.torque('a', 1.0)
    buffer.apply(sim, 0.0)
    assert buffer.apply(sim, 1e6) == [] and sim.torque == {'a': 1.0}


class Msg:
    """Duck-typed Float64/Bool/JointState: take() reads only these fields."""

    def __init__(self, **fields):
        self.__dict__.update(fields)


def test_take_dispatches_by_topic_and_names_unknown_joints():
    buffer, sim = CommandBuffer(['a', 'b']), FakeStepper()
    assert buffer.take('joint_torque', 'a', Msg(data=1.0)) == []
    assert buffer.take('joint_enable', 'b', Msg(data=False)) == []
    assert 'is disabled' in buffer.take('joint_commands', None, Msg(
        name=['b'], effort=[2.0], position=[], velocity=[]))[0]
    assert 'unknown joint' in buffer.take('joint_enable', 'zz', Msg(data=True))[0]
    assert 'not finite' in buffer.take('joint_torque', 'a', Msg(data=math.nan))[0]
    buffer.apply(sim, 0.0)
    assert sim.torque == {'a': 1.0, 'b': 2.0} and sim.enabled == {'b': False}


def test_effort_and_position_arrays_follow_command_joints():
    buffer = CommandBuffer(['a', 'b', 'c'], array_joints=['c', 'a'], drive_joints=['a'])
    sim = FakeStepper()
    assert buffer.effort_array([1.0, 2.0]) == []
    assert buffer.position_array([0.3, 0.4]) == ["joint 'c' has no drive: its position "
                                                 'commands are ignored (said once)']
    assert buffer.position_array([0.3, 0.5]) == []            # said once only
    buffer.apply(sim, 0.0)
    assert sim.torque == {'c': 1.0, 'a': 2.0} and sim.target == {'a': 0.5}


def test_arrays_of_the_wrong_length_or_non_finite_entries_are_dropped():
    buffer = CommandBuffer(['a', 'b'], drive_joints=['a', 'b'])
    sim = FakeStepper()
    short = Msg(data=[1.0])
    assert buffer.take('effort_commands', None, short) == [
        '1 efforts but command_joints has 2 (a, b): message dropped']
    assert buffer.malformed('position_commands', short) == (
        '1 positions but command_joints has 2 (a, b): message dropped')
    assert buffer.malformed('effort_commands', Msg(data=[1.0, 2.0])) is None
    assert 'not finite' in buffer.position_array([math.nan, 0.2])[0]
    buffer.apply(sim, 0.0)
    assert sim.torque == {} and sim.target == {'b': 0.2}


def test_commands_beyond_what_a_step_can_represent_are_clamped_to_it():
    """As an effort limit clamps (ros2_control, Gazebo); before, the command was dropped and
    the previous torque kept acting."""
    buffer, sim = CommandBuffer(['a'], effort_bounds=[100.0]), FakeStepper()
    assert 'beyond what one step can represent (|value| <= 100' in buffer.torque('a', 1e308)
    assert 'clamped to it' in buffer.torque('a', -1e3)
    buffer.apply(sim, 0.0)
    assert sim.torque == {'a': -100.0}
    assert buffer.torque('a', -100.0) is None


def test_a_torque_for_a_disabled_joint_is_said_once_per_disabling():
    """Before, torques sent after `enable JOINT off` were taken without a word and did
    nothing (a PD controller ended 2 rad off its target)."""
    buffer, sim = CommandBuffer(['a', 'b'], enabled=[False, True]), FakeStepper()
    assert 'is disabled' in buffer.torque('a', 1.0)
    assert buffer.torque('a', 2.0) is None and buffer.torque('b', 1.0) is None
    buffer.enable('a', True)
    assert buffer.torque('a', 3.0) is None               # enabled in the same step: no notice
    buffer.apply(sim, 0.0)
    buffer.enable('a', False)
    buffer.apply(sim, 0.01)
    assert 'is disabled' in buffer.torque('a', 1.0)      # said again after a new disabling
    assert sim.enabled == {'a': False} and sim.torque == {'a': 3.0, 'b': 1.0}


def test_a_joint_with_an_effort_limit_clamps_instead_of_dropping():
    """URDF arm6: shoulder_pan's effort limit (60 N·m) is below what a step represents, so a
    controller's 150 N·m is clamped to 60 by the stepper, not dropped; a joint without a limit
    keeps its bound."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(Scene.load('msg_configs/scenes/arm6.yaml'))
    buffer = CommandBuffer.for_stepper(sim)
    assert buffer.torque('shoulder_pan', 150.0) is None
    with pytest.warns(UserWarning, match='effort_limit'):
        buffer.apply(sim, 0.0)
    sim.step()
    assert sim.efforts[0] == 60.0
    free = Stepper(Scene.load('msg_configs/scenes/arm.yaml'))
    assert 'beyond what one step' in CommandBuffer.for_stepper(free).torque('yaw', 1e9)
