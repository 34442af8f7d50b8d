"""Trajectories of every packaged scene against the ones recorded in test/data/regression.npz.

A guard for restructures of the physics core: the same settings must give the same motion,
bit for bit, on any x86-64 machine (test_portability checks that on a masked CPU; see
docs/physics.md#reproducibility). A change that is meant to move trajectories re-records the
file with `.venv/bin/python test/test_regression.py` and says why in its commit.
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper

DATA = Path(__file__).resolve().parent / 'data' / 'regression.npz'
SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
CASES = [(p.stem, integrator) for p in sorted(SCENES.glob('*.yaml'))
         for integrator in ('bdf1', 'bdf2')]


def trajectory(scene_name, integrator):
    """Every 10th step of 200 under a fixed schedule of commands: angles and body states."""
    data = Scene.from_yaml(SCENES / f'{scene_name}.yaml').model_dump(exclude_none=True)
    data['solver'] = dict(data.get('solver', {}), integrator=integrator)
    sim = Stepper(Scene.from_dict(data))
    rng = np.random.default_rng(0)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        for step in range(200):
            if step % 25 == 0:
                for name in sim.command_joint_names:
                    sim.set_torque(name, float(rng.uniform(-0.5, 0.5)))
            sim.step()
            if step % 10 == 9:
                rows.append(np.concatenate([sim.angles, sim.body_q.ravel()]))
    return np.array(rows)


@pytest.mark.parametrize('scene_name, integrator', CASES)
def test_trajectory_is_unchanged(scene_name, integrator):
    recorded = np.load(DATA)
    key = f'{scene_name}_{integrator}'
    assert key in recorded.files, f'{key} not recorded: re-record (see the module docstring)'
    np.testing.assert_array_equal(trajectory(scene_name, integrator), recorded[key])


if __name__ == '__main__':
    np.savez_compressed(DATA, **{f'{s}_{i}': trajectory(s, i) for s, i in CASES})
    sys.stdout.write(f'recorded {len(CASES)} trajectories into {DATA}\n')
