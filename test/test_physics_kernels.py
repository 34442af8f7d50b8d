"""Energies, gradients, Hessians and the tree solve of the step kernel against independent truth.

Truth here is finite differences of the kernel's own energy, a NumPy eigendecomposition of the
analytic orthogonality Hessian, and a dense NumPy solve of the assembled Newton system.
"""

from pathlib import Path

import numpy as np
import pytest
import warp as wp

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.physics.kernels import step_kernels

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
K = step_kernels(wp.float64)
Model, Scratch, vec12, mat12, mat33 = K.Model, K.Scratch, K.vec12, K.mat12, K.mat33
incremental_potential, assemble, solve_tree = K.incremental_potential, K.assemble, K.solve_tree
ortho_energy, ortho_gradient, ortho_hessian_psd = K.ortho_energy, K.ortho_gradient, \
    K.ortho_hessian_psd


@wp.kernel
def _energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
            out: wp.array(dtype=wp.float64)):
    out[0] = incremental_potential(model, q, scratch, 0, wp.float64(1.0))


@wp.kernel
def _assemble(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch):
    assemble(model, q, scratch, 0, wp.float64(1.0))


@wp.kernel
def _solve(model: Model, scratch: Scratch):
    solve_tree(model, scratch, 0)


@wp.kernel
def _ortho(a: wp.array(dtype=mat33), energy: wp.array(dtype=wp.float64),
           gradient: wp.array(dtype=vec12), hessian: wp.array(dtype=mat12)):
    i = wp.tid()
    energy[i] = ortho_energy(a[i])
    gradient[i] = ortho_gradient(a[i])
    hessian[i] = ortho_hessian_psd(a[i])


def _random_rotation(rng):
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


class Probe:
    """Evaluates E, ∇E and the Newton blocks of a Stepper's model at arbitrary states."""

    def __init__(self, scene_name, rng, stretch):
        self.sim = Stepper(Scene.from_yaml(SCENES / f'{scene_name}.yaml'))
        self.free = [b for b in range(len(self.sim.body_names))
                     if not self.sim.scene.bodies[b].fixed]
        q = self.sim.body_q.copy()
        for b in self.free:
            # non-rigid: A = R1 diag(σ) R2 with σ all above 1 (stretch) or spread around 1
            sigma = rng.uniform(1.05, 1.3, 3) if stretch else rng.uniform(0.7, 1.3, 3)
            a = _random_rotation(rng) @ np.diag(sigma) @ _random_rotation(rng)
            q[b, 3:] = a.reshape(9)
            q[b, :3] += rng.normal(0, 0.01, 3)
        self.q0 = q
        self.q = wp.array(q[None], dtype=vec12)
        q_tilde = q + rng.normal(0, 0.01, q.shape)
        self.sim._scratch.q_tilde.assign(q_tilde[None])
        self.out = wp.zeros(1, dtype=wp.float64)

    def energy(self, q):
        self.q.assign(q[None])
        wp.launch(_energy, dim=1, inputs=[self.sim._model, self.q, self.sim._scratch, self.out])
        return self.out.numpy()[0]

    def gradient_and_hessian(self, q):
        """(∇E over free DOFs, dense Hessian from the kernel's blocks)."""
        self.q.assign(q[None])
        wp.launch(_assemble, dim=1, inputs=[self.sim._model, self.q, self.sim._scratch])
        rhs = self.sim._scratch.rhs.numpy()[0]
        blocks = self.sim._scratch.factor.numpy()[0]
        n = len(self.free)
        index = {b: i for i, b in enumerate(self.free)}
        h = np.zeros((12 * n, 12 * n))
        for b in self.free:
            i = index[b]
            h[12 * i:12 * i + 12, 12 * i:12 * i + 12] = blocks[b]
            p = self.sim._host.elim_parent[b]
            if p >= 0:
                j = index[p]
                off = self.sim._host.elim_offdiag[b]
                h[12 * i:12 * i + 12, 12 * j:12 * j + 12] = off
                h[12 * j:12 * j + 12, 12 * i:12 * i + 12] = off.T
        return -np.concatenate([rhs[b] for b in self.free]), h

    def perturbed(self, dof, step):
        q = self.q0.copy()
        q[self.free[dof // 12], dof % 12] += step
        return q


@pytest.mark.parametrize('scene_name', ['pendulum', 'double_pendulum', 'arm'])
def test_gradient_matches_finite_differences(scene_name):
    probe = Probe(scene_name, np.random.default_rng(1), stretch=False)
    gradient, _ = probe.gradient_and_hessian(probe.q0)
    h = 1e-6
    fd = np.array([(probe.energy(probe.perturbed(d, h)) - probe.energy(probe.perturbed(d, -h)))
                   / (2 * h) for d in range(12 * len(probe.free))])
    np.testing.assert_allclose(gradient, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


@pytest.mark.parametrize('scene_name', ['pendulum', 'double_pendulum', 'arm'])
def test_hessian_matches_finite_differences(scene_name):
    # stretched bodies: every orthogonality eigenvalue is positive, so projection changes nothing
    probe = Probe(scene_name, np.random.default_rng(2), stretch=True)
    _, hessian = probe.gradient_and_hessian(probe.q0)
    h = 1e-6
    columns = []
    for d in range(12 * len(probe.free)):
        g_plus, _ = probe.gradient_and_hessian(probe.perturbed(d, h))
        g_minus, _ = probe.gradient_and_hessian(probe.perturbed(d, -h))
        columns.append((g_plus - g_minus) / (2 * h))
    fd = np.array(columns).T
    np.testing.assert_allclose(hessian, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_tree_solve_matches_dense_solve():
    probe = Probe('arm', np.random.default_rng(3), stretch=False)
    gradient, hessian = probe.gradient_and_hessian(probe.q0)
    wp.launch(_solve, dim=1, inputs=[probe.sim._model, probe.sim._scratch])
    dq = probe.sim._scratch.dq.numpy()[0]
    np.testing.assert_allclose(np.concatenate([dq[b] for b in probe.free]),
                               np.linalg.solve(hessian, -gradient), rtol=1e-9, atol=1e-12)


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
    wp.launch(_ortho, dim=len(mats), inputs=[a, energy, gradient, hessian])
    negative_seen = False
    for i, m in enumerate(mats):
        e_ref, g_ref, h_ref, lam = _ortho_reference(m)
        negative_seen |= lam.min() < -1e-3
        assert energy.numpy()[i] == pytest.approx(e_ref, rel=1e-12, abs=1e-14)
        np.testing.assert_allclose(gradient.numpy()[i][3:], g_ref, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(hessian.numpy()[i][3:, 3:], h_ref, rtol=1e-6, atol=1e-6)
        assert np.all(hessian.numpy()[i][:3] == 0.0)
    assert negative_seen, 'the sample must exercise the projection'
