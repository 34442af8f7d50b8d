"""Prismatic joint (UID 20) and its scalar force (UID 667): docs/physics.md#prismatic-joint.

With c_k = x_k(c̄_k) the anchor (x0 at t = 0) and t_k = A_k t̄_k, n_k, b_k the joint frame on
each body, δ = c_C − c_P: energy K/2 (|δ × t_P|² + |δ × t_C|² + |n_P − n_C|² + |b_P − b_C|²).
The frame terms are linear in q (constant Hessian blocks from physics.host.model); the axis terms
are not: their Hessian is the Gauss–Newton K Σ ∇C ∇Cᵀ (PSD; exact where the joint holds).
Coordinate d(q) = ½ δ·(t_P + t_C) [m], positive when the child moves along x1 − x0. The force
f [N] acts along the symmetrised axis ê = ½(t̂_P + t̂_C): +f ê on the child, −f ê on the parent,
both at the child's anchor (docs/physics.md#prismatic-force).
"""

from types import SimpleNamespace

import numpy as np
import warp as wp

__all__ = ['build', 'linear_pairs', 'nonlinear_residuals']


def build(t) -> SimpleNamespace:
    """Warp functions of the prismatic joint for the types namespace ``t``."""
    vec3, vec12, mat6x12, scalar = t.vec3, t.vec12, t.mat6x12, t.scalar
    half, one = t.half, t.one
    Model, Scratch = t.structs.Model, t.structs.Scratch
    affine, world_point, jacobian_transpose = t.affine, t.world_point, t.jacobian_transpose
    direction_jacobian_transpose = t.direction_jacobian_transpose
    translation_part, couple_acceleration = t.translation_part, t.couple_acceleration

    @wp.func
    def frame(model: Model, qp: vec12, qc: vec12, k: int):
        """δ = c_C − c_P and the world axes t_P, t_C."""
        delta = world_point(qc, model.joint_child_point0[k]) - world_point(
            qp, model.joint_parent_point0[k])
        t_parent = affine(qp) @ model.joint_parent_axis[k]
        return delta, t_parent, affine(qc) @ model.joint_child_axis[k]

    @wp.func
    def frame_gaps(model: Model, qp: vec12, qc: vec12, k: int):
        """n_P − n_C and b_P − b_C."""
        ap = affine(qp)
        ac = affine(qc)
        dn = ap @ model.joint_parent_normal[k] - ac @ model.joint_child_normal[k]
        db = ap @ model.joint_parent_binormal[k] - ac @ model.joint_child_binormal[k]
        return dn, db

    @wp.func
    def energy(model: Model, qp: vec12, qc: vec12, k: int):
        """K/2 (|δ×t_P|² + |δ×t_C|² + |n_P−n_C|² + |b_P−b_C|²)."""
        delta, tp, tc = frame(model, qp, qc, k)
        dn, db = frame_gaps(model, qp, qc, k)
        c0 = wp.cross(delta, tp)
        c1 = wp.cross(delta, tc)
        return half * model.joint_stiffness[k] * (
            wp.dot(c0, c0) + wp.dot(c1, c1) + wp.dot(dn, dn) + wp.dot(db, db))

    @wp.func
    def axis_rows(model: Model, delta: vec3, tp: vec3, tc: vec3, k: int, r: int):
        """∇ of component r of C0 = δ × t_P and of C1 = −δ × t_C: (C0_P, C0_C, C1_P, C1_C)."""
        e = vec3()
        e[r] = scalar(1.0)
        cp = model.joint_parent_point0[k]
        cc = model.joint_child_point0[k]
        e_delta = wp.cross(e, delta)
        g0p = -jacobian_transpose(cp, wp.cross(tp, e)) + direction_jacobian_transpose(
            model.joint_parent_axis[k], e_delta)
        g0c = jacobian_transpose(cc, wp.cross(tp, e))
        g1p = jacobian_transpose(cp, wp.cross(tc, e))
        g1c = -jacobian_transpose(cc, wp.cross(tc, e)) - direction_jacobian_transpose(
            model.joint_child_axis[k], e_delta)
        return g0p, g0c, g1p, g1c

    @wp.func
    def gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """(∇_P E, ∇_C E)."""
        delta, tp, tc = frame(model, qp, qc, k)
        dn, db = frame_gaps(model, qp, qc, k)
        stiffness = model.joint_stiffness[k]
        c0 = wp.cross(delta, tp)
        c1 = -wp.cross(delta, tc)
        g_parent = stiffness * (direction_jacobian_transpose(model.joint_parent_normal[k], dn)
                                + direction_jacobian_transpose(model.joint_parent_binormal[k], db))
        g_child = -stiffness * (direction_jacobian_transpose(model.joint_child_normal[k], dn)
                                + direction_jacobian_transpose(model.joint_child_binormal[k], db))
        for r in range(3):
            g0p, g0c, g1p, g1c = axis_rows(model, delta, tp, tc, k, r)
            g_parent += stiffness * (c0[r] * g0p + c1[r] * g1p)
            g_child += stiffness * (c0[r] * g0c + c1[r] * g1c)
        return g_parent, g_child

    @wp.func
    def state_blocks(model: Model, qp: vec12, qc: vec12, k: int):
        """Gauss–Newton blocks (H_PP, H_PC, H_CC, 1) of the axis terms."""
        delta, tp, tc = frame(model, qp, qc, k)
        stiffness = model.joint_stiffness[k]
        rows_p = mat6x12()      # ∇_P of C0's three components, then of C1's
        rows_c = mat6x12()
        for r in range(3):
            g0p, g0c, g1p, g1c = axis_rows(model, delta, tp, tc, k, r)
            rows_p[r] = g0p
            rows_p[3 + r] = g1p
            rows_c[r] = g0c
            rows_c[3 + r] = g1c
        stiff_p = wp.transpose(stiffness * rows_p)
        return (stiff_p @ rows_p, stiff_p @ rows_c,
                wp.transpose(stiffness * rows_c) @ rows_c, int(1))

    @wp.func
    def gap(model: Model, qp: vec12, qc: vec12, k: int):
        """Distance of the child anchor from the parent's axis line [m]."""
        delta, tp, tc = frame(model, qp, qc, k)
        return wp.length(wp.cross(delta, wp.normalize(tp)))

    @wp.func
    def coordinate(model: Model, qp: vec12, qc: vec12, k: int):
        """d(q) = ½ δ·(t_P + t_C) [m]."""
        delta, tp, tc = frame(model, qp, qc, k)
        return half * wp.dot(delta, tp + tc)

    @wp.func
    def coordinate_gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """(∇_P d, ∇_C d)."""
        delta, tp, tc = frame(model, qp, qc, k)
        axis_sum = half * (tp + tc)
        g_parent = -jacobian_transpose(model.joint_parent_point0[k], axis_sum) + half * (
            direction_jacobian_transpose(model.joint_parent_axis[k], delta))
        g_child = jacobian_transpose(model.joint_child_point0[k], axis_sum) + half * (
            direction_jacobian_transpose(model.joint_child_axis[k], delta))
        return g_parent, g_child

    @wp.func
    def apply_command(model: Model, qp: vec12, qc: vec12, scratch: Scratch, env: int, k: int,
                      force: scalar, scale: scalar):
        """Add scale·a_ext of the axial force f [N] at the start-of-step state to q̃: +f ê on
        the child and −f ê on the parent, both at the child's anchor (each body: the force at
        its centre of mass and its moment about it as a couple), so that the pair has no net
        moment. Returns 1 if a near-singular body dropped its couple."""
        e_child = half * (wp.normalize(affine(qp) @ model.joint_parent_axis[k])
                          + wp.normalize(affine(qc) @ model.joint_child_axis[k]))
        f_child = force * e_child
        point = world_point(qc, model.joint_child_point0[k])
        bp = model.joint_parent[k]
        bc = model.joint_child[k]
        dropped = int(0)
        if model.body_fixed[bp] == 0:
            moment = wp.cross(point - vec3(qp[0], qp[1], qp[2]), -f_child)
            acc, ok = couple_acceleration(affine(qp), moment, one, model.body_second_moment[bp])
            scratch.q_tilde[env, bp] += translation_part(
                -f_child * (scale / model.body_mass[bp])) + scale * acc
            dropped = dropped | (1 - ok)
        if model.body_fixed[bc] == 0:
            moment = wp.cross(point - vec3(qc[0], qc[1], qc[2]), f_child)
            acc, ok = couple_acceleration(affine(qc), moment, one, model.body_second_moment[bc])
            scratch.q_tilde[env, bc] += translation_part(
                f_child * (scale / model.body_mass[bc])) + scale * acc
            dropped = dropped | (1 - ok)
        return dropped

    return SimpleNamespace(energy=energy, gradients=gradients, state_blocks=state_blocks,
                           gap=gap, coordinate=coordinate,
                           coordinate_gradients=coordinate_gradients, apply_command=apply_command)


def linear_pairs(point, direction) -> list:
    """The (J_P, J_C) of its linear residuals: the normal and binormal differences."""
    return [direction('normal'), direction('binormal')]


def nonlinear_residuals(point, direction, qp, qc) -> list:
    """The axis residuals δ × t_P and δ × t_C at states qp, qc [(..., 12)] (host NumPy)."""
    (jp, jc), (ap, ac) = point(0), direction('axis')
    delta = qc @ jc.T - qp @ jp.T
    return [np.cross(delta, qp @ ap.T), np.cross(delta, qc @ ac.T)]
