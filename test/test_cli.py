"""The command line's own flags of ``affine-joint-sim run``, run as a user runs them (a child
process): placing a URDF robot (--base, --fixed-base, --floating) and --verbose."""

from pathlib import Path

import pytest

from helpers.cli import cli

REPO = Path(__file__).resolve().parent.parent
QUADRUPED = REPO / 'msg_configs' / 'robots' / 'quadruped.urdf'
SHORT = ('--mode', 'fast', '--duration', 0.3)


@pytest.mark.parametrize('flags, message', [
    (['--base', 0, 0], 'argument --base: expected 3 or 6 finite numbers: X Y Z [m], then '
                       'optionally R P Y [rad], got 2 numbers'),
    (['--base', 0, 0, 1, 0], 'argument --base: expected 3 or 6 finite numbers'),
    (['--base'], 'argument --base: expected 3 or 6 finite numbers: X Y Z [m], then optionally '
                 'R P Y [rad], got 0 numbers'),
    (['--base', 0, 0, 'nan'], "argument --base: expected 3 or 6 finite numbers: X Y Z [m], "
                              "then optionally R P Y [rad], got 'nan'"),
    (['--base', 0, 'up', 1], "got 'up'"),
    (['--base', 0, 0, 1, 0, 0, 'inf'], "got 'inf'"),
    (['--fixed-base', '--floating'], 'argument --floating: not allowed with argument '
                                     '--fixed-base'),
])
def test_run_refuses_a_bad_placement_in_one_line(flags, message):
    done = cli('run', '--scene', QUADRUPED, *flags, *SHORT)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr.splitlines()[-1], done.stderr
    assert 'Traceback' not in done.stderr


@pytest.mark.parametrize('flags, message', [
    (['--scene', 'quadruped', '--base', 0, 0, 1],
     "--base places a URDF robot given with --scene ROBOT.urdf; 'quadruped' is a scene YAML: "
     'write base: {xyz: [x, y, z], rpy: [r, p, y]} beside its urdf: entry instead'),
    (['--scene', 'quadruped', '--fixed-base'], 'write fixed_base: true or false beside'),
    (['--floating'], '--floating places a URDF robot: give the robot with --scene ROBOT.urdf'),
])
def test_placement_flags_need_a_urdf_scene(flags, message):
    """A scene YAML places its robot itself (its base: and fixed_base: keys); the flags never
    override a file, so there is one place that says where the robot is."""
    done = cli('run', *flags, *SHORT)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith('affine-joint-sim: error: ') and done.stderr.count('\n') == 1
    assert message in done.stderr, done.stderr


def _contacts(stdout: str) -> int:
    line = next(s for s in stdout.splitlines() if s.startswith('contact:'))
    return int(line.split('at most ')[1].split()[0])


def test_base_lifts_a_urdf_robot_whose_legs_start_in_the_ground_and_floating_lets_it_land():
    # welded to the world at the origin its feet hang 0.34 m down, inside a ground at 0
    inside = cli('run', '--scene', QUADRUPED, '--ground', 0, *SHORT)
    assert inside.returncode == 2 and 'starts 0.34 m inside ground' in inside.stderr
    # welded 0.4 m up it hangs clear of the ground
    hanging = cli('run', '--scene', QUADRUPED, '--ground', 0, '--base', 0, 0, 0.4, *SHORT)
    assert hanging.returncode == 0, hanging.stderr
    assert 'welded to the world' in hanging.stderr and _contacts(hanging.stdout) == 0
    # floating from 0.4 m (turned 0.3 rad about z) it falls 6 cm onto its feet
    landed = cli('run', '--scene', QUADRUPED, '--ground', 0, '--base', 0, 0, 0.4, 0, 0, 0.3,
                 '--floating', *SHORT)
    assert landed.returncode == 0, landed.stderr
    assert "base: floating (fixed_base: false): root link 'trunk' is free" in landed.stderr
    assert _contacts(landed.stdout) == 4


def test_a_robot_load_says_one_summary_line_and_verbose_says_each_item(tmp_path):
    """Before, each item was a warning of its own (Talos: 55 lines of ~300 characters)."""
    robot = (REPO / 'msg_configs' / 'robots' / 'arm6.urdf').read_text()
    for limits in ('lower="-3.1" upper="3.1"', 'lower="-2.0" upper="2.0"'):
        robot = robot.replace(f'<limit {limits}', '<limit lower="0" upper="0"', 1)
    robot = robot.replace('<limit lower="-2.6" upper="2.6"', '<limit lower="0.5" upper="2.6"', 1)
    (tmp_path / 'locked.urdf').write_text(robot)
    quiet = cli('run', '--scene', tmp_path / 'locked.urdf', '--mode', 'fast', '--duration', 0.02)
    assert quiet.returncode == 0, quiet.stderr
    said = [line for line in quiet.stderr.splitlines() if 'locked.urdf' in line]
    assert said == ['SimulationWarning: locked.urdf: joints starting at a limit (zero outside '
                    "their limits): 1 (worst: 'elbow' 0.5 rad); joints locked by lower = upper: "
                    '2 (each one: run --verbose, or show SimulationDetail warnings)'], \
        quiet.stderr
    verbose = cli('run', '--scene', tmp_path / 'locked.urdf', '--mode', 'fast', '--duration',
                  0.02, '--verbose')
    assert verbose.returncode == 0, verbose.stderr
    details = [line for line in verbose.stderr.splitlines()
               if line.startswith('SimulationDetail: ')]
    assert len(details) == 3, verbose.stderr
    assert "joint 'elbow' starts at its lower limit 0.5 rad" in details[0]
    assert "joint 'shoulder_pan' (revolute) has lower = upper = 0" in details[1]
    assert "joint 'shoulder_lift' (revolute) has lower = upper = 0" in details[2]
    assert said[0] in verbose.stderr
