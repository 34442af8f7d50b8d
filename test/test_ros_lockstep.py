"""Lockstep with controllers written the usual way (README.md#the-ros-2-node): late, restarted
and several controllers. The gate is tested on its own against a fake clock, the node over real
DDS with controllers in other processes; waits are on conditions (states seen, log lines
written), never fixed sleeps."""

import subprocess
import sys
from pathlib import Path

import pytest

from affine_joint_sim.ros.lockstep import LockstepGate
from helpers.logged_node import LoggedNode
from helpers.ros_client import DT_NS, Inbox, call, publisher, stamp_ns
from helpers.clock import FakeClock

CONTROLLER = Path(__file__).resolve().parent / 'helpers' / 'plain_controller.py'


def test_gate_counts_answers_to_the_waiting_state_and_drops_stale_ones():
    gate = LockstepGate(publishers=2, clock=FakeClock(10.0))
    gate.expect(30 * DT_NS)
    shoulder, elbow, arrays = ('cmd', frozenset({'shoulder'})), ('cmd', frozenset({'elbow'})), \
        ('efforts', None)
    assert not gate.released
    assert gate.answer(30 * DT_NS, shoulder) == 'counted' and not gate.released
    assert gate.answer(29 * DT_NS, elbow) == 'stale' and gate.stale == 1   # a state that is gone
    assert gate.answer(30 * DT_NS, shoulder) == 'repeat' and not gate.released  # counts once
    assert gate.answer(0, elbow) == 'counted' and gate.released   # unstamped: the current state
    assert (gate.surplus, gate.repeats) == (0, 1)
    assert gate.answer(30 * DT_NS, arrays) == 'surplus' and gate.surplus == 1   # a third source
    gate.expect(31 * DT_NS)
    assert not gate.released and gate.answers == 0 and gate.surplus == 1
    assert gate.answer(0, shoulder) == 'counted'      # a new state: every source counts again


def test_gate_republishes_and_reports_while_it_waits():
    clock = FakeClock(10.0)
    gate = LockstepGate(publishers=1, republish_every=1.0, report_every=2.0, clock=clock)
    gate.expect(0, (1, 0))          # published with a viewer subscribed, no controller
    assert not gate.republish_due((1, 0)) and gate.report_due() is None
    clock.now += 1.05               # no answer for a while: perhaps lost, once again
    assert gate.republish_due((1, 0)) and not gate.republish_due((1, 0))
    clock.now += 2.0
    assert gate.report_due() == pytest.approx(3.05) and gate.report_due() is None
    gate.answer(0, 'source')
    clock.now += 5.0
    assert not gate.republish_due((1, 0)) and gate.report_due() is None


def test_gate_republishes_at_once_to_a_controller_that_joins_but_not_for_a_viewer():
    clock = FakeClock(10.0)
    gate = LockstepGate(publishers=1, republish_every=1.0, clock=clock)
    gate.expect(0, (1, 1))          # a controller has it: its answer is on its way
    clock.now += 0.5
    assert not gate.republish_due((2, 1))       # a viewer subscribed alone: no copy
    assert gate.republish_due((3, 2))           # a controller joined (both its endpoints)
    assert not gate.republish_due((3, 2))
    assert not gate.republish_due((2, 1))       # it left ...
    assert gate.republish_due((3, 2))           # ... and came back (restarted)
    gate.expect(DT_NS)              # counts not known (another mode when it went out)
    assert not gate.republish_due((3, 2)) and not gate.republish_due((3, 2))
    assert gate.republish_due((4, 3))


def test_the_demo_controller_answers_a_state_once_but_again_once_the_node_republishes(ros_node):
    from sensor_msgs.msg import JointState

    from affine_joint_sim.ros.controller import DUPLICATE_WINDOW, PDController

    clock = FakeClock(10.0)
    controller = PDController({'shoulder': 1.0}, clock=clock, context=ros_node.context)
    state = JointState(name=['shoulder'], position=[0.0], velocity=[0.0])
    state.header.stamp.nanosec = 10_000_000
    controller._on_state(state)
    controller._on_state(state)            # a copy queued behind the original: not answered
    assert (controller.states_received, controller.copies_skipped) == (1, 1)
    republish = LockstepGate().republish_every
    assert republish > DUPLICATE_WINDOW
    clock.now += republish                 # the node still waits: its republished copy is
    controller._on_state(state)            # answered (a lost answer, or a reset to it)
    state.header.stamp.nanosec = 20_000_000
    controller._on_state(state)            # the next state, at once
    assert (controller.states_received, controller.copies_skipped) == (3, 1)
    controller.destroy_node()


@pytest.fixture
def controllers():
    """Return `start(joint, target, *flags) -> Popen` of plain controllers, all stopped at the
    end."""
    started = []

    def start(*args):
        process = subprocess.Popen([sys.executable, str(CONTROLLER), *map(str, args)],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        started.append(process)
        return process

    yield start
    for process in started:
        if process.poll() is None:
            process.kill()
            process.wait()


def _latest_stamp(states):
    return max((stamp_ns(m) for m in states.messages), default=-1)


def test_a_late_then_restarted_volatile_controller_drives_the_loop(
        tmp_path, ros_node, wait_for, controllers):
    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    states = Inbox(ros_node, 'joint_states')
    # nobody answers: the node says it waits, and publishes its state again meanwhile
    assert wait_for(lambda: node.said('lockstep: waiting'), timeout=15.0)
    assert node.said('no publisher is matched')
    assert len(states.messages) >= 2 and _latest_stamp(states) == 0
    first = controllers('shoulder', 0.5, '--name', 'late_controller')
    assert wait_for(lambda: _latest_stamp(states) >= 20 * DT_NS, timeout=20.0)
    first.kill()
    first.wait()
    stalled = _latest_stamp(states)
    controllers('shoulder', 0.5, '--unstamped', '--name', 'restarted_controller')
    assert wait_for(lambda: _latest_stamp(states) >= stalled + 20 * DT_NS, timeout=20.0)
    assert 'Traceback' not in node.stop()


def _lockstep_run(tmp_path, ros_node, wait_for, controllers, flags, *controller_args):
    """One lockstep run of 30 steps (``flags``: the node's) closed by the controllers started
    with ``controller_args`` (each a tuple of plain_controller.py arguments); the states at
    t = 0 … 0.3 s (position, velocity, effort) and the node's output."""
    node = LoggedNode(tmp_path, ros_node, wait_for, *flags, '--mode', 'lockstep',
                      '--duration', '0.3')
    states = Inbox(ros_node, 'joint_states', depth=100)     # the run's 31 states, all kept
    # the state at t = 0 first (published again when this subscription matches): a
    # controller that answered it before this subscription matched would leave it unseen
    assert wait_for(lambda: states.last is not None, timeout=30.0)
    started = [controllers(*args) for args in controller_args]
    ended = wait_for(lambda: node.process.poll() is not None, timeout=60.0)
    output = node.stop()
    codes = [p.poll() for p in started]
    for process in started:             # else they answer the next run's first states
        process.kill()
        process.wait()
    assert ended, (f'the node did not end within 60 s (controllers\' exit codes: '
                   f'{codes}); its output:\n{output[-4000:]}')
    assert 'Traceback' not in output and '30 steps' in output, output
    by_stamp = {}
    for m in states.messages:
        by_stamp.setdefault(stamp_ns(m), (tuple(m.position), tuple(m.velocity),
                                          tuple(m.effort)))
    return [by_stamp[k * DT_NS] for k in range(31)], output


def _two_controller_run(tmp_path, ros_node, wait_for, controllers, publishers):
    return _lockstep_run(tmp_path, ros_node, wait_for, controllers,
                         ('--scene', 'double_pendulum', '--lockstep-publishers', publishers),
                         ('shoulder', 0.6, '--name', 'shoulder_controller'),
                         ('elbow', -0.4, '--name', 'elbow_controller'))


def test_two_controllers_give_the_same_run_every_time(tmp_path, ros_node, wait_for,
                                                      controllers):
    first, output = _two_controller_run(tmp_path, ros_node, wait_for, controllers, 2)
    second, _ = _two_controller_run(tmp_path, ros_node, wait_for, controllers, 2)
    assert first == second
    assert first[-1][2][0] != 0.0 and first[-1][2][1] != 0.0      # both controllers acted
    assert 'publishers on' not in output


def test_more_controllers_than_lockstep_publishers_is_said(
        tmp_path, ros_node, wait_for, controllers):
    node = LoggedNode(tmp_path, ros_node, wait_for, '--scene', 'double_pendulum', '--mode',
                      'lockstep')
    controllers('shoulder', 0.6, '--name', 'shoulder_controller')
    controllers('elbow', -0.4, '--name', 'elbow_controller')
    assert wait_for(lambda: node.said('2 publishers on /joint_commands'), timeout=30.0)
    output = node.stop()
    assert 'elbow_controller' in output and 'shoulder_controller' in output


def test_answers_beyond_lockstep_publishers_and_repeats_are_counted_and_said(
        tmp_path, ros_node, wait_for):
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    from std_srvs.srv import SetBool

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    pause = '/affine_joint_sim/pause'
    assert call(ros_node, wait_for, SetBool, pause, SetBool.Request(data=True)).success
    efforts = publisher(ros_node, wait_for, 'effort_commands')
    commands = publisher(ros_node, wait_for, 'joint_commands')
    for torque in (0.1, 0.2):                  # one source twice: a repeat, counted once
        efforts.publish(Float64MultiArray(data=[torque]))
    assert wait_for(lambda: node.said('a second answer for the same joints to the state at '
                                      't = 0.000000 s'), timeout=30.0)
    commands.publish(JointState(name=['shoulder'], effort=[0.3]))    # a second source
    assert wait_for(lambda: node.said('answer 2 to the state at t = 0.000000 s'), timeout=30.0)
    output = node.stop()
    assert '0 steps' in output and 'commands taken: 3' in output, output
    assert '1 lockstep answers beyond lockstep_publishers' in output, output
    assert '1 lockstep answers repeated for the same joints' in output, output


def test_a_malformed_answer_is_dropped_and_releases_no_step(tmp_path, ros_node, wait_for):
    """Arrays of the wrong length command nothing, so they answer nothing: before, each was
    counted as taken and released a lockstep step."""
    from std_msgs.msg import Float64MultiArray

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    states = Inbox(ros_node, 'joint_states')
    efforts = publisher(ros_node, wait_for, 'effort_commands')
    for _ in range(20):
        efforts.publish(Float64MultiArray(data=[0.1, 0.2, 0.3]))     # the pendulum has 1 joint
    efforts.publish(Float64MultiArray(data=[0.1]))     # one good answer, after them (reliable)
    assert wait_for(lambda: any(stamp_ns(m) == DT_NS for m in states.messages), timeout=30.0)
    output = node.stop()
    assert '\n1 steps, ' in output, output
    assert 'commands taken: 1; dropped: 20 malformed' in output, output
    assert '3 efforts but command_joints has 1 (shoulder): message dropped (1 so far)' in output


def test_a_best_effort_controller_is_named_as_never_matched(tmp_path, ros_node, wait_for):
    """Before, a QoS-incompatible controller was reported '1 publisher(s) matched' while the
    node hung at t = 0."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    ros_node.create_publisher(JointState, '/joint_commands', best_effort)
    assert wait_for(lambda: node.said('QoS-incompatible publishers, never matched: '
                                      f'{ros_node.get_name()} on /joint_commands (best_effort)'),
                    timeout=30.0)
    output = node.stop()
    waiting = [line for line in output.splitlines() if 'never matched' in line][0]
    assert 'no publisher is matched' in waiting and 'published reliable' in waiting, waiting


def test_fewer_controllers_than_lockstep_publishers_are_warned_about(
        tmp_path, ros_node, wait_for, controllers):
    """Two answers expected, one controller: each step went on only at the 0.2 s republish
    (5 steps/s) and nothing said why."""
    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep',
                      '--ros-args', '-p', 'lockstep_publishers:=2')
    controllers('shoulder', 0.5, '--name', 'lonely_controller')
    assert wait_for(lambda: node.said('lockstep_publishers is 2 but 1 publisher(s) are matched'),
                    timeout=30.0)
    assert 'lonely_controller' in node.stop()


def test_steps_requested_through_the_standard_wait_for_the_controller(
        tmp_path, ros_node, wait_for, controllers):
    """StepSimulation while paused in lockstep: every step applies the controller's answer to
    the state before it (before, the steps ran at once and the answers came too late)."""
    pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import SetSimulationState, StepSimulation

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: states.last is not None)     # t = 0, published while it waits
    paused = call(ros_node, wait_for, SetSimulationState, '/affine_joint_sim/set_simulation_state',
                  SetSimulationState.Request(state=SimulationState(
                      state=SimulationState.STATE_PAUSED)))
    assert paused.result.result == Result.RESULT_OK
    controllers('shoulder', 0.5)
    before = _latest_stamp(states)
    stepped = call(ros_node, wait_for, StepSimulation, '/affine_joint_sim/step_simulation',
                   StepSimulation.Request(steps=10))
    assert stepped.result.result == Result.RESULT_OK, stepped.result.error_message
    assert wait_for(lambda: _latest_stamp(states) == before + 10 * DT_NS)
    by_stamp = {stamp_ns(m): m for m in states.messages}
    for k in range(10):
        state, after = by_stamp[before + k * DT_NS], by_stamp[before + (k + 1) * DT_NS]
        pd = 20.0 * (0.5 - state.position[0]) - 2.0 * state.velocity[0]
        assert after.effort[0] == pytest.approx(pd, rel=1e-12), k
    assert 'Traceback' not in node.stop()


def test_a_waiting_standard_step_ends_on_resume_and_on_cancel(tmp_path, ros_node, wait_for):
    """Lockstep without a controller: granted steps wait for answers that never come; playing
    again ends a waiting StepSimulation (it says so), and canceling SimulateSteps ends the
    step it waits for."""
    pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')
    from rclpy.action import ActionClient
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import SetSimulationState, StepSimulation

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    prefix = '/affine_joint_sim/'

    def set_state(state):
        return call(ros_node, wait_for, SetSimulationState, prefix + 'set_simulation_state',
                    SetSimulationState.Request(state=SimulationState(state=state)))

    set_state(SimulationState.STATE_PAUSED)
    client = ros_node.create_client(StepSimulation, prefix + 'step_simulation')
    assert client.wait_for_service(timeout_sec=10.0)
    stepping = client.call_async(StepSimulation.Request(steps=3))
    assert not wait_for(stepping.done, timeout=1.0)         # waits for lockstep answers
    set_state(SimulationState.STATE_PLAYING)
    assert wait_for(stepping.done)
    ended = stepping.result().result
    assert ended.result == Result.RESULT_OPERATION_FAILED and 'resumed' in ended.error_message

    set_state(SimulationState.STATE_PAUSED)
    actions = ActionClient(ros_node, SimulateSteps, prefix + 'simulate_steps')
    assert actions.wait_for_server(timeout_sec=10.0)
    sent = actions.send_goal_async(SimulateSteps.Goal(steps=5))
    assert wait_for(sent.done)
    goal = sent.result()
    outcome = goal.get_result_async()
    assert not wait_for(outcome.done, timeout=1.0)
    goal.cancel_goal_async()
    assert wait_for(outcome.done)
    assert 'canceled after 0 steps' in outcome.result().result.result.error_message
    assert 'Traceback' not in node.stop()


def test_a_node_stopping_answers_a_waiting_standard_step(tmp_path, ros_node, wait_for):
    """Stopped (SIGINT) while a StepSimulation waits for lockstep answers, the node answers
    it (the node stopping) before it goes."""
    pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')
    from simulation_interfaces.msg import Result, SimulationState
    from simulation_interfaces.srv import SetSimulationState, StepSimulation

    node = LoggedNode(tmp_path, ros_node, wait_for, '--mode', 'lockstep')
    prefix = '/affine_joint_sim/'
    call(ros_node, wait_for, SetSimulationState, prefix + 'set_simulation_state',
         SetSimulationState.Request(state=SimulationState(state=SimulationState.STATE_PAUSED)))
    client = ros_node.create_client(StepSimulation, prefix + 'step_simulation')
    assert client.wait_for_service(timeout_sec=10.0)
    stepping = client.call_async(StepSimulation.Request(steps=2))
    assert not wait_for(stepping.done, timeout=1.0)         # waits for lockstep answers
    assert 'Traceback' not in node.stop()
    assert wait_for(stepping.done)
    ended = stepping.result().result
    assert ended.result == Result.RESULT_OPERATION_FAILED
    assert ended.error_message == 'node stopping'


@pytest.fixture
def busy_core():
    """Return `start()`, which starts a process spinning on one core until the test ends: the
    node and the controller share what is left, as on a loaded machine."""
    started = []

    def start():
        started.append(subprocess.Popen([sys.executable, '-c', 'while True: pass']))

    yield start
    for process in started:
        process.kill()
        process.wait()


def test_a_controller_answering_every_state_unstamped_gives_the_same_run_every_time(
        tmp_path, ros_node, wait_for, controllers, busy_core):
    """The plainest controller: it answers every joint_states message it receives, unstamped,
    its first answer 0.25 s late (warming up). Before, the node published a waiting state
    again every 0.2 s; the controller answered the copy too, and that second answer counted
    for the next state (runs differed about one time in three, from step 1 on). Ten runs, the
    last nine under load: each step applies the answer to the state before it, and the runs
    are equal bit for bit."""
    runs = []
    for k in range(10):
        states, output = _lockstep_run(
            tmp_path, ros_node, wait_for, controllers, (),
            ('shoulder', 0.5, '--unstamped', '--every', '--first-answer-after', 0.25))
        for step, (before, after) in enumerate(zip(states, states[1:]), 1):
            (angle,), (rate,), _ = before
            pd = 20.0 * (0.5 - angle) - 2.0 * rate
            assert after[2][0] == pytest.approx(pd, rel=1e-12), (k, step, output)
        assert 'repeated' not in output and 'beyond' not in output, output
        runs.append(states)
        if k == 0:      # the kernels are loaded (compiled, with a cold cache) by now
            busy_core()
    for k, states in enumerate(runs[1:], 2):
        differs = next((i for i, (a, b) in enumerate(zip(runs[0], states)) if a != b), None)
        assert differs is None, f'run {k} differs from run 1 from the state at step {differs}'
