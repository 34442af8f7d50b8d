"""``bench bodies``: the quick run through the command line writes every scene with the
expected columns, and nothing of ours ever interpenetrates; MuJoCo's columns are filled
exactly when it is installed (never for the grasp); the growth fit. No assertion on
wall-clock figures."""

import csv

import pytest

from affine_joint_sim.bench import bodies, mujoco_urdf
from helpers.cli import cli


def test_a_quick_run_writes_every_scene_and_nothing_interpenetrates(tmp_path):
    done = cli('bench', '--results', tmp_path, 'bodies', '--quick')
    assert done.returncode == 0, done.stdout + done.stderr
    with (tmp_path / 'bodies.csv').open(newline='') as stream:
        rows = list(csv.DictReader(stream))
    assert [r['scene'] for r in rows] == (['collision', 'stack of 3']
                                          + [f'pile of {n}' for n in bodies.QUICK.piles]
                                          + ['gripper', 'arm6_gripper grasp'])
    assert {'us_per_step', 'realtime', 'newton', 'inner', 'contacts', 'min_distance',
            'error', 'mujoco_us', 'mujoco_min_distance', 'mujoco_error'} <= set(rows[0])
    for row in rows:
        assert float(row['min_distance']) > 0.0, row['scene']
        assert float(row['newton']) >= 1.0
        assert row['vs_mujoco'] == ('' if row['mujoco_us'] == '' else
                                    f"{float(row['us_per_step']) / float(row['mujoco_us'])!r}")
        assert (row['mujoco_us'] != '') == (mujoco_urdf.available()
                                            and row['scene'] != 'gripper')
    errors = {r['scene']: float(r['error']) for r in rows if r['error']}
    assert errors['collision'] < 1e-9                   # momentum, kg·m/s
    assert errors['gripper'] < 3e-3                     # the box rose 5 cm with the hand
    assert abs(errors['arm6_gripper grasp']) < 2e-3     # the cube's slip in the arm's hand
    text = (tmp_path / 'bodies.md').read_text()
    assert 'Cost growth' not in text                    # one pile: no fit
    profile = text.split('### Where a step goes')[1]    # the largest pile's and the grasp's
    assert f'| pile of {max(bodies.QUICK.piles)} |' in profile
    assert '| arm6_gripper grasp |' in profile


def test_the_growth_exponent_fits_a_power_law():
    rows = [{'scene': 'pile of 8', 'contacts': 10, 'us_per_step': 100.0, 'newton': 1.0},
            {'scene': 'pile of 27', 'contacts': 100, 'us_per_step': 3162.2776601683795,
             'newton': 10 ** 0.5},
            {'scene': 'gripper', 'contacts': 8, 'us_per_step': 1.0, 'newton': 2.0}]
    assert bodies.growth(rows) == pytest.approx(1.5)
    assert bodies.growth(rows, per_iteration=True) == pytest.approx(1.0)
    assert bodies.growth(rows[:1]) is None
