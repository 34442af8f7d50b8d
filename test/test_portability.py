"""Results are the same bits on every x86-64 machine (docs/physics.md#reproducibility).

Another machine differs from this one in what its CPU offers, and the libraries choose their
code by that: glibc its sin, atan2, ... (FMA and AVX2 variants), NumPy its SIMD loops,
OpenBLAS its kernels, and Warp compiles the step kernel for the host's instruction set. A
child process here is made to look like an old x86-64 on all four counts (glibc's hardware
capabilities masked, NumPy's and OpenBLAS's dispatch pinned to their baseline, the kernels
compiled for plain x86-64 without AVX or FMA) and must reproduce every packaged scene's
regression trajectory, a scene that takes the model build's other paths, and replay every
sample bag bit for bit.
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from numpy._core import _multiarray_umath

from helpers.machine_results import odd_scene_trajectory

TEST = Path(__file__).resolve().parent
DATA = TEST / 'data' / 'regression.npz'

# glibc 2.26+: the CPU features its ifunc resolvers may use, removed
GLIBC_MASK = 'glibc.cpu.hwcaps=' + ','.join(
    f'-{f}' for f in ('AVX', 'AVX2', 'FMA', 'FMA4', 'AVX512F', 'AVX512VL', 'AVX512DQ',
                      'AVX512BW', 'AVX512CD', 'AVX512ER', 'AVX512PF'))


def old_machine_env() -> dict:
    """The environment of a child that computes as a baseline x86-64 CPU would."""
    env = dict(os.environ)
    env.update(GLIBC_TUNABLES=GLIBC_MASK,
               NPY_DISABLE_CPU_FEATURES=' '.join(_multiarray_umath.__cpu_dispatch__),
               OPENBLAS_CORETYPE='Prescott')
    return env


def test_an_old_x86_64_reproduces_every_trajectory_and_sample_bag_bit_for_bit(tmp_path):
    out = tmp_path / 'old_machine.npz'
    child = subprocess.run([sys.executable, 'helpers/machine_results.py', str(out), 'generic'],
                           cwd=TEST, env=old_machine_env(), capture_output=True, text=True,
                           timeout=600)
    assert child.returncode == 0, child.stdout[-2000:] + child.stderr[-4000:]
    old = np.load(out)
    recorded = np.load(DATA)
    differing = {key: float(np.abs(old[key] - recorded[key]).max()) for key in recorded.files
                 if not np.array_equal(old[key], recorded[key])}
    assert not differing, f'largest differences on the old machine: {differing}'
    np.testing.assert_array_equal(old['odd'], odd_scene_trajectory())
    bags = {key: float(old[key]) for key in old.files if key.startswith('bag:')}
    assert len(bags) >= 2
    assert all(worst == 0.0 for worst in bags.values()), bags
