"""The block-tree Cholesky solve (physics.solve.tree_solve) against a dense NumPy solve."""

import numpy as np

from helpers.physics import Probe


def test_tree_solve_matches_dense_solve():
    probe = Probe('arm', np.random.default_rng(3), stretch=False)
    gradient, hessian, dq = probe.newton_system(probe.q0)
    np.testing.assert_allclose(dq, np.linalg.solve(hessian, -gradient), rtol=1e-9, atol=1e-12)
