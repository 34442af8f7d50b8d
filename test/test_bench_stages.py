"""``bench stages``: the quick run through the command line writes a row per scene with every
stage timed, the contact stages only where the scene has contact. No assertion on wall-clock
figures beyond their being measured (finite, positive)."""

import csv
import math

import pytest

from affine_joint_sim.bench import stages
from affine_joint_sim.physics.evaluate import STAGE_NAMES
from helpers.cli import cli


def test_a_quick_run_times_every_stage_of_each_scene(tmp_path):
    done = cli('bench', '--results', tmp_path, 'stages', '--quick')
    assert done.returncode == 0, done.stdout + done.stderr
    with (tmp_path / 'stages.csv').open(newline='') as stream:
        rows = {row['scene']: row for row in csv.DictReader(stream)}
    assert list(rows) == list(stages.QUICK.scenes) == ['ramp', 'arm6']
    for name, row in rows.items():
        contact = name == 'ramp'
        assert row['contact'] == str(contact) and float(row['newton']) >= 1.0
        for stage in STAGE_NAMES:
            timed = stage not in ('step bound', 'near list', 'distances') or contact
            assert (row[stage] != '') == timed, (name, stage)
            if timed:
                assert 0.0 < float(row[stage]) < math.inf, (name, stage)
    assert '| ramp |' in (tmp_path / 'stages.md').read_text()
    for name, row in rows.items():
        # each counted stage's share: its calls per step times its µs per call
        calls = float(row['hessians per step'])
        assert calls >= 1.0
        assert float(row['hessians µs/step']) == pytest.approx(
            calls * (float(row['assembly']) + float(row['factor and solve'])))
        assert float(row['energies µs/step']) == pytest.approx(
            float(row['energies per step']) * float(row['energy']))
        shares = sum(float(row[f'{stage} µs/step']) for stage in (
            'hessians', 'gradient_tries', 'energies', 'near_gathers', 'distances', 'rest'))
        assert shares == pytest.approx(float(row['us_per_step']))
        assert (float(row['near_gathers per step']) > 0.0) <= (name == 'ramp')
