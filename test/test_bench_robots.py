"""``bench robots``: a URDF robot beside MuJoCo (when the compare extra is installed), its
pose and torques, and the one-line error for a robot it cannot find. No assertion on
wall-clock figures."""

import csv

import numpy as np

from affine_joint_sim.bench import mujoco_urdf, zoo
from affine_joint_sim.bench.references import RigidTree
from affine_joint_sim.resources import config_dir
from helpers.cli import cli

GRIPPER = config_dir() / 'robots' / 'arm6_gripper.urdf'


def test_the_pose_is_inside_every_limit_and_the_torques_hold_it_but_for_the_push():
    scenes, torques = zoo.load(str(GRIPPER), (1e-3,))
    scene = scenes[1e-3]
    for joint in scene.joints:
        if joint.limit is not None:
            margin = zoo.MARGIN * (joint.limit.upper - joint.limit.lower)
            assert joint.limit.lower + margin <= joint.initial_position
            assert joint.initial_position <= joint.limit.upper - margin
    start = np.array([j.initial_position for j in scene.joints])
    # the rigid reference starting at rest accelerates by the push alone
    np.testing.assert_allclose(
        RigidTree(scene).acceleration(start, np.zeros_like(start), torques), zoo.PUSH,
        atol=1e-9)


def test_a_quick_run_writes_one_row_per_dt_with_every_step_converged(tmp_path):
    done = cli('bench', '--results', tmp_path, 'robots', '--quick', GRIPPER)
    assert done.returncode == 0, done.stdout + done.stderr
    with (tmp_path / 'robots.csv').open() as stream:
        rows = list(csv.DictReader(stream))
    assert [float(r['dt']) for r in rows] == [1e-3, 1e-2]
    for row in rows:
        assert row['robot'] == 'arm6_gripper' and row['joints'] == '8'
        assert (row['unconverged'], row['rejected'], row['line_search_failures'],
                row['limit_exits'], row['friction_problems']) == ('0', '0', '0', '0', '0')
        if mujoco_urdf.available():     # ours: 1.8e-7 at dt 1e-3; MuJoCo Euler: 6.5e-6
            assert float(row['error']) < float(row['euler_error'])
    text = (tmp_path / 'robots.md').read_text()
    assert ('MuJoCo is not installed' in text) != mujoco_urdf.available()


def test_an_unknown_robot_is_one_line_and_exit_2(tmp_path):
    done = cli('bench', '--results', tmp_path, 'robots', 'no_such_robot')
    assert done.returncode == 2 and 'Traceback' not in done.stderr
    assert done.stderr.strip().splitlines()[-1] == (   # (after Warp's own notes, if any)
        "error: bench robots: 'no_such_robot' is neither a zoo robot (ur5, kinova, panda, "
        'solo12, g1, talos) nor a URDF file')
