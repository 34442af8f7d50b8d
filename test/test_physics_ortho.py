"""Orthogonality energy, gradient and PSD Hessian (physics.ortho) against a NumPy
eigendecomposition of the analytic Hessian."""

import numpy as np
import pytest
import warp as wp

from affine_joint_sim.physics.kernels import step_kernels
from helpers.physics import random_rotation as _random_rotation

K = step_kernels(wp.float64)
vec12, mat12, mat33 = K.vec12, K.mat12, K.mat33
ortho_energy, ortho_gradient, add_ortho_hessian = (K.ortho_energy, K.ortho_gradient,
                                                   K.add_ortho_hessian)


SCALE = 2.5


@wp.kernel(module='unique')
def _ortho(a: wp.array(dtype=mat33), base: wp.array(dtype=mat12),
           energy: wp.array(dtype=wp.float64), gradient: wp.array(dtype=vec12),
           hessian: wp.array(dtype=mat12)):
    i = wp.tid()
    energy[i] = ortho_energy(a[i])
    gradient[i] = ortho_gradient(a[i])
    hessian[i] = add_ortho_hessian(base[i], wp.float64(SCALE), a[i])


def _ortho_reference(a):
    """Energy, gradient 4CA and the PSD-clamped Hessian (FD of the analytic gradient)."""
    def grad(x):
        m = x.reshape(3, 3)
        return (4 * (m @ m.T - np.eye(3)) @ m).reshape(9)

    c = a @ a.T - np.eye(3)
    h = np.array([(grad(a.reshape(9) + 1e-7 * e) - grad(a.reshape(9) - 1e-7 * e)) / 2e-7
                  for e in np.eye(9)]).T
    lam, vec = np.linalg.eigh(0.5 * (h + h.T))
    return np.sum(c * c), grad(a), vec @ np.diag(np.maximum(lam, 0)) @ vec.T, lam


def test_orthogonality_terms_and_psd_projection():
    rng = np.random.default_rng(4)
    mats = [_random_rotation(rng) @ np.diag(rng.uniform(0.5, 1.5, 3)) @ _random_rotation(rng)
            for _ in range(20)]
    mats.append(np.eye(3))                                   # rigid: repeated σ
    mats.append(np.diag([0.6, 0.6, 1.4]))                    # repeated σ below 1
    a = wp.array(np.array(mats), dtype=mat33)
    energy, gradient = wp.zeros(len(mats), dtype=wp.float64), wp.zeros(len(mats), dtype=vec12)
    hessian = wp.zeros(len(mats), dtype=mat12)
    base = rng.normal(size=(len(mats), 12, 12))             # the block it is added into
    wp.launch(_ortho, dim=len(mats), inputs=[a, wp.array(base, dtype=mat12), energy, gradient,
                                             hessian])
    added = (hessian.numpy() - base) / SCALE
    negative_seen = False
    for i, m in enumerate(mats):
        e_ref, g_ref, h_ref, lam = _ortho_reference(m)
        negative_seen |= lam.min() < -1e-3
        assert energy.numpy()[i] == pytest.approx(e_ref, rel=1e-12, abs=1e-14)
        np.testing.assert_allclose(gradient.numpy()[i][3:], g_ref, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(added[i][3:, 3:], h_ref, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(added[i][:3], 0.0, atol=1e-14)
    assert negative_seen, 'the sample must exercise the projection'
