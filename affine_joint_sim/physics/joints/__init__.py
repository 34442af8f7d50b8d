"""Joint types: one module per type, and the one dispatch point on ``model.joint_type``.

Every joint type provides its constraint energy, its gradients on the parent and the child,
its largest anchor gap, its coordinate and its explicit command; the functions here pick the
type's function per joint, so the stages (assembly, prediction, commit) never branch on types.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.codes import REVOLUTE
from affine_joint_sim.physics.joints import revolute

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Dispatching Warp functions over joint types for the types namespace ``t``."""
    vec12, scalar = t.vec12, t.scalar
    zero, two_pi = t.zero, t.two_pi
    Model, Scratch = t.structs.Model, t.structs.Scratch
    rev = revolute.build(t)
    rev_energy, rev_gradients, rev_gap, rev_angle = (rev.energy, rev.gradients, rev.gap,
                                                     rev.angle)
    rev_apply_torque = rev.apply_torque

    @wp.func
    def joint_energy(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Constraint energy of joint k (incremental-potential units, no dt²) [J·s²]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        out = zero
        if model.joint_type[k] == REVOLUTE:
            out = rev_energy(model, qp, qc, k)
        return out

    @wp.func
    def joint_gradients(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(∇_P, ∇_C) of joint k's constraint energy."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        g_parent = vec12()
        g_child = vec12()
        if model.joint_type[k] == REVOLUTE:
            g_parent, g_child = rev_gradients(model, qp, qc, k)
        return g_parent, g_child

    @wp.func
    def joint_gap(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Largest constraint gap of joint k [m]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        out = zero
        if model.joint_type[k] == REVOLUTE:
            out = rev_gap(model, qp, qc, k)
        return out

    @wp.func
    def joint_raw_coordinate(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Coordinate of joint k as the state shows it: θ(q) ∈ (−π, π] [rad]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        out = zero
        if model.joint_type[k] == REVOLUTE:
            out = rev_angle(model, qp, qc, k)
        return out

    @wp.func
    def joint_coordinate_step(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int,
                              previous: scalar):
        """Δx from the last committed coordinate ``previous`` to the state q; a revolute Δθ is
        taken in (−π, π] (multi-turn unwrap, physics_spec §5.3)."""
        delta = joint_raw_coordinate(model, q, env, k) - previous
        return delta - two_pi * wp.round(delta / two_pi)

    @wp.func
    def joint_apply_command(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                            env: int, k: int, command: scalar, scale: scalar):
        """Add scale·a_ext of joint k's command at the start-of-step state q to q̃.

        Returns 1 if a near-singular body dropped it."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        dropped = int(0)
        if model.joint_type[k] == REVOLUTE:
            dropped = rev_apply_torque(model, qp, qc, scratch, env, k, command, scale)
        return dropped

    return SimpleNamespace(joint_energy=joint_energy, joint_gradients=joint_gradients,
                           joint_gap=joint_gap, joint_raw_coordinate=joint_raw_coordinate,
                           joint_coordinate_step=joint_coordinate_step,
                           joint_apply_command=joint_apply_command,
                           lever_arm_force=rev.lever_arm_force,
                           couple_acceleration=rev.couple_acceleration)
