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


def _every_type_probe(seed, stretch):
    from test_joints import every_joint_type
    probe = Probe(every_joint_type(), np.random.default_rng(seed), stretch=stretch)
    n = len(probe.stages.host.joint_type)
    # committed coordinates and targets away from the state, so every term is active
    probe.stages.set_joint_inputs(coordinate=np.full(n, 0.01), coordinate_prev=np.zeros(n),
                                  target=np.full(n, 0.3), drive_enabled=np.ones(n))
    return probe


def test_gradient_of_every_joint_type_and_term_matches_finite_differences():
    probe = _every_type_probe(5, stretch=False)
    assert probe.stages.host.state_coupling
    gradient = probe.newton_system(probe.q0)[0]
    fd = probe.fd_gradient()
    np.testing.assert_allclose(gradient, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_hessian_of_every_joint_type_is_exact_where_the_joints_hold_and_psd_elsewhere():
    # at the initial state the prismatic axis residuals and the coordinate-term slopes vanish,
    # so the Gauss–Newton blocks are the exact Hessian; elsewhere they must stay PSD
    probe = _every_type_probe(6, stretch=False)
    n = len(probe.stages.host.joint_type)
    probe.q0 = probe.stages.host.body_q0.copy()
    probe.stages.set_joint_inputs(coordinate=np.zeros(n), target=np.zeros(n))
    hessian = probe.newton_system(probe.q0)[1]
    fd = probe.fd_hessian()
    np.testing.assert_allclose(hessian, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    stretched = _every_type_probe(7, stretch=True)
    h = stretched.newton_system(stretched.q0)[1]
    assert np.linalg.eigvalsh(h).min() > -1e-9 * np.abs(h).max()
