"""Mechanical energy of an ABD state: the quantity a passive system must not gain.

The incremental potential (docs/physics.md#incremental-potential) is ½‖q − q̃‖²_M + dt²·V(q),
so the physical potential V is the orthogonality energy κ v̄ ‖AAᵀ − I‖² plus each joint's
constraint spring and limit penalty and each mimic coupling's spring divided by dt² (those
terms carry no dt² there). With
gravity's potential, the affine kinetic energy ½ q̇ᵀ M q̇ and, with contact, the barrier's
energy b(d) of every pair closer than d̂ this is the energy that implicit BDF steps dissipate
(docs/physics.md#mechanical-energy). NumPy, host side, world frame, SI units.
"""

import math

import numpy as np

from affine_joint_sim.physics.contact.pairs import near_pairs, pair_gap, pair_weight
from affine_joint_sim.physics.joints import host_functions
from affine_joint_sim.physics.host.model import HostModel, residual_jacobians

__all__ = ['barrier_energy', 'mechanical_energy']


def barrier_energy(d: float, d_hat: float, kappa: float) -> float:
    """b [J] of the barrier b(D) = −κ (D − D̂)² ln(D/D̂), D = d², at 0 < d < d̂."""
    big, big_hat = d * d, d_hat * d_hat
    return -kappa * (big - big_hat) ** 2 * math.log(big / big_hat)


def mechanical_energy(model: HostModel, q: np.ndarray, qdot: np.ndarray,
                      coordinates: np.ndarray) -> np.ndarray:
    """Kinetic + gravity + orthogonality + joint-spring + limit + mimic-spring (+ contact
    barrier) energy of the free bodies [J].

    Args:
        model: the scene's host model.
        q, qdot: ABD states and velocities, shape (..., n_bodies, 12) (leading env axes allowed).
        coordinates: the joints' multi-turn coordinates x [rad | m], shape (..., n_joints).

    Returns:
        Energy per leading index, shape (...). Fixed bodies and joints between two fixed bodies
        add constants and are left out; drives (which do work) and damping are not included.
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
        qp, qc = q[..., model.joint_parent[k], :], q[..., model.joint_child[k], :]
        functions = host_functions(model.joint_type[k])
        point, direction = residual_jacobians(vars(model), k)
        residuals = [qp @ jp.T - qc @ jc.T for jp, jc in functions.linear_pairs(point, direction)]
        residuals += functions.nonlinear_residuals(point, direction, qp, qc)
        spring = 0.5 * model.joint_stiffness[k] * sum(np.sum(r ** 2, axis=-1) for r in residuals)
        joints += (spring + _limit_energy(model, k, coordinates[..., k])) / model.dt ** 2
    for i, follower in enumerate(model.mimic_follower):
        r = (coordinates[..., follower] - model.mimic_multiplier[i]
             * coordinates[..., model.mimic_leader[i]] - model.mimic_offset[i])
        joints += 0.5 * model.mimic_stiffness[i] * r ** 2 / model.dt ** 2
    return bodies + joints + _contact_energy(model, q)


def _contact_energy(model: HostModel, q: np.ndarray) -> np.ndarray:
    """Σ m b(d) [J] over the contact pairs closer than d̂ (m: an edge pair's mollifier at the
    same state), per leading index of q."""
    if not model.has_contact:
        return np.zeros(q.shape[:-2])
    states = q.reshape(-1, *q.shape[-2:])
    out = np.zeros(len(states))
    for e, state in enumerate(states):
        near = near_pairs(vars(model), state, model.contact_d_hat)
        distances = [pair_gap(vars(model), state, int(p)).distance for p in near]
        out[e] = sum(pair_weight(vars(model), state, p)
                     * barrier_energy(d, model.contact_d_hat, model.contact_kappa)
                     for p, d in zip(near, distances) if 0.0 < d < model.contact_d_hat)
    return out.reshape(q.shape[:-2])


def _limit_energy(model: HostModel, k: int, x: np.ndarray) -> np.ndarray:
    """The cubic limit penalty of joint k at coordinates x (physics.stages.joint_terms) [J·s²]."""
    s, lower, upper = (model.joint_limit_strength[k], model.joint_limit_lower[k],
                       model.joint_limit_upper[k])
    if s == 0.0:
        return np.zeros(np.shape(x))
    if upper == lower:
        return s * np.abs(x - lower) ** 3
    width = upper - lower
    return s * (np.maximum(x - upper, 0.0) ** 3 + np.maximum(lower - x, 0.0) ** 3) / width ** 3
