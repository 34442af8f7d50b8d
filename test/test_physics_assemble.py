"""Gradient and Hessian assembly (physics.assemble) against finite differences of the
incremental potential (physics.potential) evaluated by the same stage functions."""

import numpy as np
import pytest

from helpers.physics import Probe


@pytest.mark.parametrize('scene_name', ['pendulum', 'double_pendulum', 'arm'])
def test_gradient_matches_finite_differences(scene_name):
    probe = Probe(scene_name, np.random.default_rng(1), stretch=False)
    gradient = probe.newton_system(probe.q0)[0]
    fd = probe.fd_gradient()
    np.testing.assert_allclose(gradient, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


@pytest.mark.parametrize('scene_name', ['pendulum', 'double_pendulum', 'arm'])
def test_hessian_matches_finite_differences(scene_name):
    # stretched bodies: every orthogonality eigenvalue is positive, so projection changes nothing
    probe = Probe(scene_name, np.random.default_rng(2), stretch=True)
    hessian = probe.newton_system(probe.q0)[1]
    fd = probe.fd_hessian()
    np.testing.assert_allclose(hessian, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
