"""Mechanical energy of an ABD state: the quantity a passive system must not gain.

The incremental potential of physics_spec §3.3 is ½‖q − q̃‖²_M + dt²·V(q), so the physical
potential V is the orthogonality energy κ v̄ ‖AAᵀ − I‖² plus each joint's spring
K/(2 dt²)·(|d0|² + |d1|²) (the joint term carries no dt² there). With gravity's potential and
the affine kinetic energy ½ q̇ᵀ M q̇ this is the energy that implicit BDF steps dissipate.
NumPy, host side, world frame, SI units.
"""

import numpy as np

from affine_joint_sim.physics.model import HostModel, jacobian

__all__ = ['mechanical_energy']


def mechanical_energy(model: HostModel, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """Kinetic + gravity + orthogonality + joint-spring energy of the free bodies [J].

    Args:
        model: the scene's host model.
        q, qdot: ABD states and velocities, shape (..., n_bodies, 12) (leading env axes allowed).

    Returns:
        Energy per leading index, shape (...). Fixed bodies and joints between two fixed bodies
        add constants and are left out.
    """
    free = model.body_fixed == 0
    s = model.body_second_moment[:, None, :]                     # S = diag(s): (nb, 1, 3)
    adot = qdot[..., 3:].reshape(*qdot.shape[:-1], 3, 3)
    kinetic = 0.5 * (model.body_mass * np.sum(qdot[..., :3] ** 2, axis=-1)
                     + np.sum(s * adot ** 2, axis=(-2, -1)))
    gravity = -model.body_mass * (q[..., :3] @ model.gravity)
    a = q[..., 3:].reshape(*q.shape[:-1], 3, 3)
    strain = a @ np.swapaxes(a, -1, -2) - np.eye(3)
    ortho = model.body_ortho_coeff * np.sum(strain ** 2, axis=(-2, -1))
    bodies = np.sum(np.where(free, kinetic + gravity + ortho, 0.0), axis=-1)

    joints = np.zeros(bodies.shape)
    for k in np.flatnonzero(model.joint_has_free):
        u0, u1 = model.joint_parent_point0[k], model.joint_parent_point1[k]
        w0, w1 = model.joint_child_point0[k], model.joint_child_point1[k]
        qp, qc = q[..., model.joint_parent[k], :], q[..., model.joint_child[k], :]
        d0 = qp @ jacobian(u0).T - qc @ jacobian(w0).T          # x_P(u0) − x_C(w0)
        d1 = qp @ jacobian(u1).T - qc @ jacobian(w1).T
        joints += (0.5 * model.joint_stiffness[k] / model.dt ** 2
                   * (np.sum(d0 ** 2, axis=-1) + np.sum(d1 ** 2, axis=-1)))
    return bodies + joints

