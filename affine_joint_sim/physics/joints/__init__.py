"""Joint types: one module per type, and the one dispatch point on ``model.joint_type``.

Every joint type provides its constraint energy, its gradients on the parent and the child,
the Gauss–Newton blocks of its non-linear terms, its largest gap, its coordinate x(q) with
gradient, and its explicit command; the functions here pick the type's function per joint,
so the stages (assembly, prediction, commit) never branch on types. Fixed joints have no
coordinate (0) and no command.
"""

import math
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.codes import FIXED, PRISMATIC, REVOLUTE
from affine_joint_sim.physics.joints import fixed, prismatic, revolute

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Dispatching Warp functions over joint types for the types namespace ``t``."""
    vec12, mat12, scalar = t.vec12, t.mat12, t.scalar
    zero, two_pi = t.zero, t.two_pi
    alias_limit = scalar(0.9 * math.pi)   # |Δθ| per step [rad] beyond which angles alias
    Model, Scratch = t.structs.Model, t.structs.Scratch
    rev, pri, fix = revolute.build(t), prismatic.build(t), fixed.build(t)
    rev_energy, pri_energy, fix_energy = rev.energy, pri.energy, fix.energy
    rev_gradients, pri_gradients, fix_gradients = rev.gradients, pri.gradients, fix.gradients
    rev_gap, pri_gap, fix_gap = rev.gap, pri.gap, fix.gap
    rev_angle, pri_distance = rev.angle, pri.distance
    rev_angle_gradients, pri_distance_gradients = rev.angle_gradients, pri.distance_gradients
    pri_state_blocks = pri.state_blocks
    rev_apply_torque, pri_apply_force = rev.apply_torque, pri.apply_force

    @wp.func
    def joint_energy(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Constraint energy of joint k (incremental-potential units, no dt²) [J·s²]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        if kind == REVOLUTE:
            out = rev_energy(model, qp, qc, k)
        elif kind == PRISMATIC:
            out = pri_energy(model, qp, qc, k)
        else:
            out = fix_energy(model, qp, qc, k)
        return out

    @wp.func
    def joint_gradients(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(∇_P, ∇_C) of joint k's constraint energy."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        g_parent = vec12()
        g_child = vec12()
        if kind == REVOLUTE:
            g_parent, g_child = rev_gradients(model, qp, qc, k)
        elif kind == PRISMATIC:
            g_parent, g_child = pri_gradients(model, qp, qc, k)
        else:
            g_parent, g_child = fix_gradients(model, qp, qc, k)
        return g_parent, g_child

    @wp.func
    def joint_state_blocks(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(H_PP, H_PC, H_CC, 1) of joint k's constraint terms that are not linear in q (the
        linear ones are in the model's constant blocks), or zeros and 0 when it has none."""
        h_pp = mat12()
        h_pc = mat12()
        h_cc = mat12()
        has = int(0)
        if model.joint_type[k] == PRISMATIC:
            h_pp, h_pc, h_cc = pri_state_blocks(model, q[env, model.joint_parent[k]],
                                                q[env, model.joint_child[k]], k)
            has = 1
        return h_pp, h_pc, h_cc, has

    @wp.func
    def joint_gap(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Largest constraint gap of joint k [m]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        if kind == REVOLUTE:
            out = rev_gap(model, qp, qc, k)
        elif kind == PRISMATIC:
            out = pri_gap(model, qp, qc, k)
        else:
            out = fix_gap(model, qp, qc, k)
        return out

    @wp.func
    def joint_raw_coordinate(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Coordinate of joint k as the state shows it, from its initial position x₀: x₀ + θ(q)
        with θ ∈ (−π, π] [rad], x₀ + d(q) [m] (θ and d are 0 at t = 0)."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        if kind == REVOLUTE:
            out = rev_angle(model, qp, qc, k)
        elif kind == PRISMATIC:
            out = pri_distance(model, qp, qc, k)
        return out + model.joint_initial_position[k]

    @wp.func
    def joint_coordinate_step(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int,
                              previous: scalar):
        """Δx from the last committed coordinate ``previous`` to the state q; a revolute Δθ is
        taken in (−π, π] (multi-turn unwrap, physics_spec §5.3)."""
        delta = joint_raw_coordinate(model, q, env, k) - previous
        if model.joint_type[k] == REVOLUTE:
            delta = delta - two_pi * wp.round(delta / two_pi)
        return delta

    @wp.func
    def joint_step_aliases(model: Model, k: int, step: scalar):
        """1 if a coordinate increment ``step`` cannot be told from one a turn apart: a
        revolute Δθ beyond 0.9π (physics_spec §5.3)."""
        out = int(0)
        if model.joint_type[k] == REVOLUTE and wp.abs(step) > alias_limit:
            out = 1
        return out

    @wp.func
    def joint_coordinate_gradients(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(∇_P x, ∇_C x) of joint k's coordinate."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        g_parent = vec12()
        g_child = vec12()
        if kind == REVOLUTE:
            g_parent, g_child = rev_angle_gradients(model, qp, qc, k)
        elif kind == PRISMATIC:
            g_parent, g_child = pri_distance_gradients(model, qp, qc, k)
        return g_parent, g_child

    @wp.func
    def joint_takes_command(model: Model, k: int):
        """1 if joint k takes a torque or force command (a fixed joint takes none)."""
        out = int(1)
        if model.joint_type[k] == FIXED:
            out = 0
        return out

    @wp.func
    def joint_apply_command(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                            env: int, k: int, command: scalar, scale: scalar):
        """Add scale·a_ext of joint k's command (torque [N·m] or force [N]) at the
        start-of-step state q to q̃. Returns 1 if a near-singular body dropped it."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        dropped = int(0)
        if kind == REVOLUTE:
            dropped = rev_apply_torque(model, qp, qc, scratch, env, k, command, scale)
        elif kind == PRISMATIC:
            pri_apply_force(model, qp, qc, scratch, env, k, command, scale)
        return dropped

    return SimpleNamespace(joint_energy=joint_energy, joint_gradients=joint_gradients,
                           joint_state_blocks=joint_state_blocks, joint_gap=joint_gap,
                           joint_raw_coordinate=joint_raw_coordinate,
                           joint_coordinate_step=joint_coordinate_step,
                           joint_step_aliases=joint_step_aliases,
                           joint_coordinate_gradients=joint_coordinate_gradients,
                           joint_takes_command=joint_takes_command,
                           joint_apply_command=joint_apply_command,
                           lever_arm_force=rev.lever_arm_force,
                           couple_acceleration=rev.couple_acceleration)
