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


def results() -> dict:
    """Trajectories under the names of test/data/regression.npz, and 'bag:<name>' worst
    replay differences [rad | m]."""
    sys.path.insert(0, str(TEST))
    from affine_joint_sim.ros.replay import read_bag, replay
    from test_regression import CASES, trajectory

    out = {f'{scene}_{integrator}': trajectory(scene, integrator) for scene, integrator in CASES}
    for bag in sorted(p for p in BAGS.iterdir() if (p / 'metadata.yaml').exists()):
        out[f'bag:{bag.name}'] = np.array(replay(read_bag(bag)).worst())
    return out


if __name__ == '__main__':
    wp.config.quiet = True
    if sys.argv[2:] == ['generic']:
        wp.config.cpu_compiler_flags = ''
    np.savez(sys.argv[1], **results())
