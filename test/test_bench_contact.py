"""``bench contact``: the quick run through the command line writes every scene and speed
ratio with the expected columns, and nothing of ours ever reaches the ground; without MuJoCo
its columns stay empty. No assertion on wall-clock figures."""

import csv
import sys

from affine_joint_sim.bench import contact, mujoco_urdf
from helpers.cli import cli


def _rows(path):
    with path.open(newline='') as stream:
        return list(csv.DictReader(stream))


def test_a_quick_run_writes_every_scene_and_ratio_and_never_touches_the_ground(tmp_path):
    done = cli('bench', '--results', tmp_path, 'contact', '--quick')
    assert done.returncode == 0, done.stdout + done.stderr
    rows = _rows(tmp_path / 'contact.csv')
    quick = contact.QUICK
    assert [(r['scene'], float(r['dt'])) for r in rows] == [
        (case.name, dt) for case in contact.CASES
        for dt in (quick.robot_dts if case.robot else quick.dts)]
    assert {'us_per_step', 'mujoco_us', 'newton_iterations', 'unconverged', 'rejected',
            'quantity', 'exact', 'ours', 'mujoco', 'error', 'mujoco_error', 'spin',
            'min_distance', 'mujoco_min_distance', 'spread', 'realtime'} <= set(rows[0])
    for row in rows:
        assert float(row['min_distance']) > 0.0, row['scene']
        assert (row['unconverged'], row['rejected']) == ('0', '0'), row['scene']
        assert float(row['newton_iterations']) >= 1.0
        assert (row['mujoco'] != '') == mujoco_urdf.available()
    ratios = _rows(tmp_path / 'contact_ratios.csv')
    assert [(r['case'][:3], float(r['dt'])) for r in ratios] == [
        (case, dt) for dt in quick.dts for case in ('(a)', '(b)')]
    assert {'us_with', 'us_without', 'ratio', 'target', 'verdict'} <= set(ratios[0])
    text = (tmp_path / 'contact.md').read_text()
    assert '## Speed ratios' in text and '(c) quadruped standing at dt 1e-3' in text
    assert 'never penetrates' in text and (tmp_path / 'contact.png').stat().st_size > 0
    assert '| quadruped |' in text.split('## Where a step goes')[1]


def test_without_mujoco_its_columns_are_empty(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, 'mujoco', None)      # import mujoco raises ImportError
    settings = contact.Settings(dts=(1e-2,), robot_dts=(), duration=0.1, repeats=1,
                                profile_steps=5, profile_calls=5)
    contact.run(tmp_path, ['cpu'], settings)
    rows = _rows(tmp_path / 'contact.csv')
    assert len(rows) == len(contact.CASES) - 1            # no quadruped at no dt
    for row in rows:
        assert row['mujoco_us'] == row['mujoco'] == row['mujoco_min_distance'] == ''
        assert row['vs_mujoco'] == ''
        assert float(row['min_distance']) > 0.0
    assert 'MuJoCo is not installed' in (tmp_path / 'contact.md').read_text()
