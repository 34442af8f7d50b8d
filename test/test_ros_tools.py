"""The CLI tools (torque, enable, echo) and the demo, as a user runs them, against a live node."""

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from helpers.cli import cli
from helpers.ros_client import Inbox


def test_torque_enable_and_echo(sim, ros_node, wait_for):
    sim('--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    sent = cli('torque', 'shoulder', 1.5)
    assert sent.returncode == 0, sent.stderr
    assert '/joints/shoulder/external_torque: 1.5' in sent.stdout
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == 1.5)
    off = cli('enable', 'shoulder', 'off')
    assert off.returncode == 0, off.stderr
    assert wait_for(lambda: states.last.effort[0] == 0.0)
    echoed = cli('echo', '--once', '--timeout', 10)
    assert echoed.returncode == 0, echoed.stderr
    header, row = echoed.stdout.splitlines()[1:3]
    assert header.split()[:2] == ['joint', 'position'] and row.split()[0] == 'shoulder'
    assert float(row.split()[3]) in (0.0, 1.5)


def test_torque_tool_sends_a_force_to_a_prismatic_joint(sim, ros_node, wait_for):
    sim('--scene', 'gantry', '--mode', 'realtime', '--real-time-factor', '2.0')
    states = Inbox(ros_node, 'joint_states')
    sent = cli('torque', 'rail', -2.5)
    assert sent.returncode == 0, sent.stderr
    assert '/joints/rail/external_force: -2.5' in sent.stdout
    assert wait_for(lambda: states.last is not None and states.last.effort[0] == -2.5)
    off = cli('enable', 'rail', 'off')
    assert off.returncode == 0 and '/joints/rail/external_force/is_constrained' in off.stdout
    assert wait_for(lambda: states.last.effort[0] == 0.0)


def test_echo_into_a_pipe_that_closes_ends_quietly(sim):
    sim('--mode', 'realtime')
    done = subprocess.run(f'{sys.executable} -m affine_joint_sim.cli echo --rate 100 --timeout 30'
                          ' | head -n 3', shell=True, capture_output=True, text=True, timeout=60)
    assert len(done.stdout.splitlines()) == 3 and 'joint' in done.stdout
    assert 'Traceback' not in done.stderr and 'BrokenPipe' not in done.stderr, done.stderr


def test_torque_to_an_unknown_joint_names_the_known_ones(sim):
    sim()
    sent = cli('torque', 'elbow', 1.0, '--timeout', 2)
    assert sent.returncode == 1
    assert 'nothing subscribes to /joints/elbow/external_torque' in sent.stderr
    assert '/joints/shoulder/external_torque' in sent.stderr


def test_tools_reject_bad_values_without_a_node():
    assert cli('torque', 'shoulder', 'nan').returncode == 2
    enable = cli('enable', 'shoulder', 'maybe')
    assert enable.returncode == 2 and 'expected on or off' in enable.stderr
    echo = cli('echo', '--timeout', 1)
    assert echo.returncode == 1 and 'no message on /joint_states' in echo.stderr


@pytest.mark.parametrize('interface', ['joint_commands', 'effort_commands'])
def test_demo_closes_the_loop_and_reports(tmp_path, interface):
    done = cli('demo', '--duration', 2.0, '--target', 'shoulder=0.8', '--interface', interface,
               timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert '200 steps, 2.000 s simulated' in out and 'real-time factor' in out, out
    row = next(line for line in out.splitlines() if line.startswith('shoulder '))
    target, final, error = map(float, row.split()[1:])
    # PD against gravity settles m g l/2 sin(θ*)/kp = 4.905 sin(0.8)/100 = 0.035 rad short.
    assert target == 0.8 and abs(error + 0.035) < 0.01, out


def test_demo_runs_the_grasp_script_of_the_grasp_scene():
    """``demo --scene grasp`` runs the packaged grasp script: at 0.2 s the arm still holds its
    start pose (the descent starts at 0.3 s) with the script's targets and gains."""
    done = cli('demo', '--scene', 'grasp', '--duration', 0.2, timeout=180)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert 'PD controller (script grasp)' in out and '200 steps, 0.200 s simulated' in out, out
    assert 'PD controller (scripted targets and gains)' in out, out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines()
            if line.startswith(('shoulder_lift ', 'left_finger_joint '))}
    assert float(rows['shoulder_lift'][0]) == 0.3878 and float(rows['left_finger_joint'][0]) == 0.03
    assert abs(float(rows['shoulder_lift'][2])) < 0.01, out    # PD sag against gravity


def _children(pid):
    return [int(c) for c in Path(f'/proc/{pid}/task/{pid}/children').read_text().split()]


def test_demo_sigterm_stops_node_and_controller_and_prints_the_summary(ros_node, wait_for):
    states = Inbox(ros_node, 'joint_states')
    demo = subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', 'demo', '--duration',
                             '1000'], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert demo.stdout.readline().startswith('demo: node')
    assert wait_for(lambda: states.last is not None and states.last.effort[0] != 0.0,
                    timeout=30.0)          # node and controller both run: the loop is closed
    children = _children(demo.pid)
    assert len(children) == 2
    demo.send_signal(signal.SIGTERM)
    output, _ = demo.communicate(timeout=60)
    assert demo.returncode == 0 and 'Traceback' not in output, output
    assert 'interrupted' in output and 'steps/s' in output and 'PD controller' in output
    assert not any(Path(f'/proc/{c}').exists() for c in children), 'orphans left running'


@pytest.mark.parametrize('flags, message', [
    (['--target', 'knee=1.0'], "--target knee: not a moving joint of scene 'pendulum' "
                               '(joints: shoulder)'),
    (['--duration', '0'], 'argument --duration: expected a finite number > 0'),
])
def test_demo_refuses_bad_flags_at_start(flags, message):
    done = cli('demo', *flags)
    assert done.returncode == 2 and message in done.stderr, done.stderr
    assert 'Traceback' not in done.stderr


def test_the_controller_report_keeps_its_columns_for_long_joint_names(ros_node):
    """Before, a joint name over 12 characters pushed its row out of the table."""
    from sensor_msgs.msg import JointState

    from affine_joint_sim.ros.controller import PDController

    names = ['shoulder', 'left_hip_pitch_joint_with_a_long_name']
    controller = PDController({name: 0.5 for name in names}, context=ros_node.context)
    try:
        controller.last_state = JointState(name=names, position=[0.4, 0.7])
        table = controller.report().splitlines()[1:]
    finally:
        controller.destroy_node()
    assert len(table) == 3 and len({len(line) for line in table}) == 1, table   # aligned
    assert [line.split()[0] for line in table] == ['joint', *names], table
