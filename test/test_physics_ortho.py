"""Orthogonality energy, gradient and Newton's PSD Hessian (physics.stages.ortho) against finite
differences of the analytic gradient and of AAᵀ − I: the Gauss–Newton Hessian where the term
it drops is small against the body's inertia, else the projection of the exact Hessian."""

import numpy as np
import pytest
import warp as wp

from affine_joint_sim.physics.kernels import step_kernels
from affine_joint_sim.physics.stages.ortho import GAUSS_NEWTON_SHARE
from helpers.physics import random_rotation as _random_rotation

K = step_kernels(wp.float64)
vec12, mat12, mat33 = K.vec12, K.mat12, K.mat33
ortho_energy, ortho_gradient, add_ortho_hessian = (K.ortho_energy, K.ortho_gradient,
                                                   K.add_ortho_hessian)


SCALE = 2.5


@wp.kernel(module='unique')
def _ortho(a: wp.array(dtype=mat33), base: wp.array(dtype=mat12),
           inertia: wp.array(dtype=wp.float64), energy: wp.array(dtype=wp.float64),
           gradient: wp.array(dtype=vec12), hessian: wp.array(dtype=mat12)):
    i = wp.tid()
    energy[i] = ortho_energy(a[i])
    gradient[i] = ortho_gradient(a[i])
    hessian[i] = add_ortho_hessian(base[i], wp.float64(SCALE), a[i], inertia[i])


def _ortho_reference(a):
    """Energy, gradient 4CA, the exact Hessian (FD of the analytic gradient) and the
    Gauss–Newton Hessian 2 JᵀJ (J: FD of C = AAᵀ − I)."""
    def grad(x):
        m = x.reshape(3, 3)
        return (4 * (m @ m.T - np.eye(3)) @ m).reshape(9)

    def strain(x):
        m = x.reshape(3, 3)
        return (m @ m.T - np.eye(3)).reshape(9)

    def derivative(f, x):
        return np.array([(f(x + 1e-7 * e) - f(x - 1e-7 * e)) / 2e-7 for e in np.eye(9)]).T

    c = a @ a.T - np.eye(3)
    exact = derivative(grad, a.reshape(9))
    jac = derivative(strain, a.reshape(9))
    return np.sum(c * c), grad(a), 0.5 * (exact + exact.T), 2 * jac.T @ jac


def _run(mats, inertia):
    """(energy, gradient, Hessian added per unit SCALE) of each matrix."""
    rng = np.random.default_rng(5)
    a = wp.array(np.array(mats), dtype=mat33)
    energy, gradient = wp.zeros(len(mats), dtype=wp.float64), wp.zeros(len(mats), dtype=vec12)
    hessian = wp.zeros(len(mats), dtype=mat12)
    base = rng.normal(size=(len(mats), 12, 12))             # the block it is added into
    wp.launch(_ortho, dim=len(mats), inputs=[a, wp.array(base, dtype=mat12),
                                             wp.array(inertia, dtype=wp.float64), energy,
                                             gradient, hessian])
    return energy.numpy(), gradient.numpy(), (hessian.numpy() - base) / SCALE


def _states():
    rng = np.random.default_rng(4)
    mats = [_random_rotation(rng) @ np.diag(rng.uniform(0.5, 1.5, 3)) @ _random_rotation(rng)
            for _ in range(20)]
    mats += [_random_rotation(rng) @ (np.eye(3) + 1e-4 * rng.normal(size=(3, 3)))
             for _ in range(4)]                              # near-rigid
    mats.append(np.diag([0.6, 0.6, 1.4]))                    # repeated σ below 1
    return mats


def _dropped(m):
    """Largest size of the dropped term 4 (AAᵀ − I) dA per unit SCALE."""
    return 4 * np.linalg.norm(m @ m.T - np.eye(3))


def test_gauss_newton_hessian_where_the_dropped_term_is_small_against_the_inertia():
    mats = _states()
    inertia = [_dropped(m) * SCALE / GAUSS_NEWTON_SHARE * 1.01 for m in mats]
    energy, gradient, added = _run(mats, inertia)
    indefinite_seen = False
    for i, m in enumerate(mats):
        e_ref, g_ref, exact, gauss_newton = _ortho_reference(m)
        indefinite_seen |= np.linalg.eigvalsh(exact).min() < -1e-3
        assert energy[i] == pytest.approx(e_ref, rel=1e-12, abs=1e-14)
        np.testing.assert_allclose(gradient[i][3:], g_ref, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(added[i][3:, 3:], gauss_newton, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(added[i][:3], 0.0, atol=1e-14)
        np.testing.assert_allclose(added[i][:, :3], 0.0, atol=1e-14)
        # it differs from the exact Hessian by the dropped term only
        assert np.abs(added[i][3:, 3:] - exact).max() <= _dropped(m) + 1e-6
    assert indefinite_seen, 'the sample must have states whose exact Hessian is indefinite'
    # at a rotation the dropped term is zero: Gauss–Newton is the exact Hessian
    rotation = _random_rotation(np.random.default_rng(6))
    _, _, added = _run([rotation], [1.0])
    np.testing.assert_allclose(added[0][3:, 3:], _ortho_reference(rotation)[2], atol=1e-6)


def test_psd_projection_of_the_exact_hessian_where_the_dropped_term_is_not_small():
    mats = _states()
    inertia = [_dropped(m) * SCALE / GAUSS_NEWTON_SHARE * 0.99 for m in mats]
    _, _, added = _run(mats, inertia)
    for i, m in enumerate(mats):
        _, _, exact, _ = _ortho_reference(m)
        lam, vec = np.linalg.eigh(exact)
        projected = vec @ np.diag(np.maximum(lam, 0)) @ vec.T
        np.testing.assert_allclose(added[i][3:, 3:], projected, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(added[i][:3], 0.0, atol=1e-14)
