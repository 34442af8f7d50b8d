"""Everything the portability test compares, computed in this process: every packaged scene's
regression trajectory and the largest replay difference of every sample bag.

Run as ``python helpers/machine_results.py OUT.npz [generic]`` from test/; ``generic``
compiles the kernels for a plain x86-64 (SSE2, no AVX) instead of this CPU.
"""

import sys
from pathlib import Path

import numpy as np
import warp as wp

TEST = Path(__file__).resolve().parents[1]
BAGS = TEST.parent / 'bags'


def odd_scene_trajectory() -> np.ndarray:
    """A scene whose model build takes the paths the packaged scenes do not: a dt whose square
    is not exact, a sphere's volume from a density, and a body whose equivalent box is too
    dense and is rescaled by a cube root."""
    from affine_joint_sim import Scene, Stepper

    sim = Stepper(Scene.from_dict({
        'name': 'odd', 'dt': 0.0037,
        'bodies': [{'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0,
                    'fixed': True},
                   {'name': 'ball', 'shape': {'sphere': {'radius': 0.07}}, 'density': 1234.5,
                    'position': [0.0, 0.0, -0.4]},
                   {'name': 'dense', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 0.9,
                    'inertia': [3.1e-7, 2.7e-7, 4.3e-7], 'position': [0.0, 0.0, -0.8]}],
        'joints': [{'name': 'a', 'parent': 'base', 'child': 'ball', 'x0': [-0.05, 0, 0],
                    'x1': [0.05, 0, 0], 'torque': 0.3},
                   {'name': 'b', 'parent': 'ball', 'child': 'dense', 'x0': [0, -0.05, -0.6],
                    'x1': [0, 0.05, -0.6], 'torque': -0.2}]}))
    rows = []
    for _ in range(60):
        sim.step()
        rows.append(np.concatenate([sim.angles, sim.body_q.ravel(), sim.step_effort_bounds]))
    return np.array(rows)


def results() -> dict:
    """Trajectories under the names of test/data/regression.npz, 'odd' (odd_scene_trajectory),
    and 'bag:<name>' worst replay differences [rad | m]."""
    sys.path.insert(0, str(TEST))
    from affine_joint_sim.ros.replay import read_bag, replay
    from test_regression import CASES, trajectory

    out = {f'{scene}_{integrator}': trajectory(scene, integrator) for scene, integrator in CASES}
    out['odd'] = odd_scene_trajectory()
    for bag in sorted(p for p in BAGS.iterdir() if (p / 'metadata.yaml').exists()):
        out[f'bag:{bag.name}'] = np.array(replay(read_bag(bag)).worst())
    return out


if __name__ == '__main__':
    wp.config.quiet = True
    if sys.argv[2:] == ['generic']:
        wp.config.cpu_compiler_flags = ''
    np.savez(sys.argv[1], **results())
