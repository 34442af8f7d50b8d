"""Gradient and Hessian assembly (physics.stages.assemble) against finite differences of the
incremental potential (physics.stages.potential) evaluated by the same stage functions."""

import numpy as np
import pytest

from affine_joint_sim.physics.host.joint_kinds import PRISMATIC
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


def _prismatic_residuals(host, k, q):
    """The axis residuals δ × t_P and δ × t_C of prismatic joint k (NumPy, independent)."""
    qp, qc = q[host.joint_parent[k]], q[host.joint_child[k]]
    ap, ac = qp[3:].reshape(3, 3), qc[3:].reshape(3, 3)
    delta = ((qc[:3] + ac @ host.joint_child_point0[k])
             - (qp[:3] + ap @ host.joint_parent_point0[k]))
    return np.concatenate([np.cross(delta, ap @ host.joint_parent_axis[k]),
                           np.cross(delta, ac @ host.joint_child_axis[k])])


def _coordinate_slope(host, k, x, x_n, target):
    """φ'(x) of joint k's limit + drive + damping (BDF1), written out from the spec."""
    lower, upper, s = (host.joint_limit_lower[k], host.joint_limit_upper[k],
                       host.joint_limit_strength[k])
    w = upper - lower
    slope = 3 * s * (max(x - upper, 0.0) ** 2 - max(lower - x, 0.0) ** 2) / w ** 3 if s else 0.0
    slope += host.joint_drive_stiffness[k] * (x - target)
    return slope + host.joint_damping[k] * host.dt * (x - x_n)


def test_hessian_of_every_joint_type_is_the_gauss_newton_form_at_random_states():
    # E's true Hessian less what Gauss–Newton drops (K r ∇²r of the prismatic axis residuals
    # and φ'(x) ∇²x of the coordinate terms) is what the assembly must give
    probe = _every_type_probe(11, stretch=True)
    stages, host, h = probe.stages, probe.stages.host, 1e-6
    index = {b: i for i, b in enumerate(probe.free)}
    expected = probe.fd_hessian()
    x = stages.joint_coordinates(probe.q0)[0]
    for k in range(host.joint_count):
        if host.joint_state_terms[k]:
            # the committed coordinate is 0.01: x is its unwrapped continuation
            x_k = 0.01 + (x[k] - 0.01 + np.pi) % (2 * np.pi) - np.pi
            slope = _coordinate_slope(host, k, x_k, 0.01, 0.3)
            for d in range(12 * len(probe.free)):
                plus = stages.joint_coordinates(probe.perturbed(d, h))
                minus = stages.joint_coordinates(probe.perturbed(d, -h))
                for side, g in ((host.joint_parent[k], 1), (host.joint_child[k], 2)):
                    if side in index:
                        cols = slice(12 * index[side], 12 * index[side] + 12)
                        expected[cols, d] -= slope * (plus[g][k] - minus[g][k]) / (2 * h)
        if host.joint_type[k] == PRISMATIC.code:
            r = _prismatic_residuals(host, k, probe.q0)
            hh = 1e-4
            for i in range(12 * len(probe.free)):
                for j in range(12 * len(probe.free)):
                    def at(si, sj):
                        q = probe.perturbed(i, si * hh)
                        q[probe.free[j // 12], j % 12] += sj * hh
                        return _prismatic_residuals(host, k, q)
                    second = (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / (4 * hh * hh)
                    expected[i, j] -= host.joint_stiffness[k] * (r @ second)
    assembled = probe.newton_system(probe.q0)[1]
    np.testing.assert_allclose(assembled, expected, rtol=1e-4, atol=1e-5 * np.abs(expected).max())
