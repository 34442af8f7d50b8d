"""Revolute joint (UID 18) and its scalar torque (UID 668): docs/physics.md#revolute-joint.

Energy K/2 (|d0|² + |d1|²) with anchor gaps d_m = x_P(u_m) − x_C(w_m) (linear in q, so its
Hessian is the constant of physics.host.model's joint blocks); coordinate θ(q), the right-hand
rotation of the child against the parent about x1 − x0, and its gradient; the torque
enters q̃ explicitly,
by libuipc's lever-arm force or its generalized couple (docs/physics.md#revolute-torque).
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.host.codes import LEVER_ARM

__all__ = ['build', 'linear_pairs', 'nonlinear_residuals']


def build(t) -> SimpleNamespace:
    """Warp functions of the revolute joint for the types namespace ``t``."""
    vec3, vec12, mat12, scalar = t.vec3, t.vec12, t.mat12, t.scalar
    half = t.half
    Model, Scratch = t.structs.Model, t.structs.Scratch
    affine, world_point, jacobian_transpose = t.affine, t.world_point, t.jacobian_transpose
    translation_part, couple_acceleration = t.translation_part, t.couple_acceleration
    direction_jacobian_transpose = t.direction_jacobian_transpose
    atan2 = t.atan2

    @wp.func
    def gaps(model: Model, qp: vec12, qc: vec12, k: int):
        """Anchor gaps d0 = x_P(u0) − x_C(w0), d1 = x_P(u1) − x_C(w1) [m]."""
        d0 = world_point(qp, model.joint_parent_point0[k]) - world_point(
            qc, model.joint_child_point0[k])
        d1 = world_point(qp, model.joint_parent_point1[k]) - world_point(
            qc, model.joint_child_point1[k])
        return d0, d1

    @wp.func
    def energy(model: Model, qp: vec12, qc: vec12, k: int):
        """K/2 (|d0|² + |d1|²) (no dt²: docs/physics.md#physical-stiffness-of-joint-terms)."""
        d0, d1 = gaps(model, qp, qc, k)
        return half * model.joint_stiffness[k] * (wp.dot(d0, d0) + wp.dot(d1, d1))

    @wp.func
    def gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """(∇_P E, ∇_C E) of the energy."""
        d0, d1 = gaps(model, qp, qc, k)
        stiffness = model.joint_stiffness[k]
        g_parent = stiffness * (jacobian_transpose(model.joint_parent_point0[k], d0)
                                + jacobian_transpose(model.joint_parent_point1[k], d1))
        g_child = -stiffness * (jacobian_transpose(model.joint_child_point0[k], d0)
                                + jacobian_transpose(model.joint_child_point1[k], d1))
        return g_parent, g_child

    @wp.func
    def gap(model: Model, qp: vec12, qc: vec12, k: int):
        """Largest anchor gap [m]."""
        d0, d1 = gaps(model, qp, qc, k)
        return wp.max(wp.length(d0), wp.length(d1))

    @wp.func
    def state_blocks(model: Model, qp: vec12, qc: vec12, k: int):
        """None: the energy is quadratic in q, its blocks are constants (zeros, 0)."""
        return mat12(), mat12(), mat12(), int(0)

    @wp.func
    def alignment(model: Model, qp: vec12, qc: vec12, k: int):
        """(c, s): the child's normal frame in the parent's, as cos and sin of θ times the
        frames' alignment (1 for rotations about a common axis)."""
        ap = affine(qp)
        ac = affine(qc)
        n_p = ap @ model.joint_parent_normal[k]
        b_p = ap @ model.joint_parent_binormal[k]
        n_c = ac @ model.joint_child_normal[k]
        b_c = ac @ model.joint_child_binormal[k]
        c = half * (wp.dot(n_p, n_c) + wp.dot(b_p, b_c))
        s = half * (wp.dot(b_p, n_c) - wp.dot(n_p, b_c))
        return c, s

    @wp.func
    def coordinate(model: Model, qp: vec12, qc: vec12, k: int):
        """θ(q) ∈ (−π, π]: right-hand rotation of child vs parent about x1 − x0."""
        c, s = alignment(model, qp, qc, k)
        return atan2(s, c)

    @wp.func
    def coordinate_gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """(∇_P θ, ∇_C θ) of θ = atan2(s, c): (c ∇s − s ∇c) / (c² + s²)."""
        ap = affine(qp)
        ac = affine(qc)
        nbp = model.joint_parent_normal[k]
        bbp = model.joint_parent_binormal[k]
        nbc = model.joint_child_normal[k]
        bbc = model.joint_child_binormal[k]
        n_p = ap @ nbp
        b_p = ap @ bbp
        n_c = ac @ nbc
        b_c = ac @ bbc
        c = half * (wp.dot(n_p, n_c) + wp.dot(b_p, b_c))
        s = half * (wp.dot(b_p, n_c) - wp.dot(n_p, b_c))
        dc_p = half * (direction_jacobian_transpose(nbp, n_c)
                       + direction_jacobian_transpose(bbp, b_c))
        dc_c = half * (direction_jacobian_transpose(nbc, n_p)
                       + direction_jacobian_transpose(bbc, b_p))
        ds_p = half * (direction_jacobian_transpose(bbp, n_c)
                       - direction_jacobian_transpose(nbp, b_c))
        ds_c = half * (direction_jacobian_transpose(nbc, b_p)
                       - direction_jacobian_transpose(bbc, n_p))
        inv = scalar(1.0) / (c * c + s * s)
        return inv * (c * ds_p - s * dc_p), inv * (c * ds_c - s * dc_c)

    @wp.func
    def lever_arm_force(q: vec12, anchor0: vec3, anchor1: vec3, tau: scalar):
        """The lever-arm formula: a force at the COM whose moment about the axis is τ ê [N]."""
        a = affine(q)
        e = wp.normalize(a @ (anchor1 - anchor0))
        d = -(a @ anchor0)
        r = d - wp.dot(d, e) * e
        r2 = wp.dot(r, r)
        if r2 > scalar(1.0e-12):
            return tau * wp.cross(e, r) / r2
        return vec3()

    @wp.func
    def apply_command(model: Model, qp: vec12, qc: vec12, scratch: Scratch, env: int, k: int,
                      tau: scalar, scale: scalar):
        """Add scale·a_ext of torque τ [N·m] at the start-of-step state to q̃ of both bodies.

        Returns 1 if a near-singular body dropped the torque (generalized model)."""
        dropped = int(0)
        bp = model.joint_parent[k]
        bc = model.joint_child[k]
        u0 = model.joint_parent_point0[k]
        u1 = model.joint_parent_point1[k]
        w0 = model.joint_child_point0[k]
        w1 = model.joint_child_point1[k]
        if model.joint_torque_model[k] == LEVER_ARM:
            if model.body_fixed[bp] == 0:
                f = lever_arm_force(qp, u0, u1, -tau) * (scale / model.body_mass[bp])
                scratch.q_tilde[env, bp] += translation_part(f)
            if model.body_fixed[bc] == 0:
                f = lever_arm_force(qc, w0, w1, tau) * (scale / model.body_mass[bc])
                scratch.q_tilde[env, bc] += translation_part(f)
        else:
            ap = affine(qp)
            ac = affine(qc)
            e_child = half * (wp.normalize(ap @ (u1 - u0)) + wp.normalize(ac @ (w1 - w0)))
            if model.body_fixed[bp] == 0:
                acc, ok = couple_acceleration(ap, -e_child, tau, model.body_second_moment[bp])
                scratch.q_tilde[env, bp] += scale * acc
                dropped = dropped | (1 - ok)
            if model.body_fixed[bc] == 0:
                acc, ok = couple_acceleration(ac, e_child, tau, model.body_second_moment[bc])
                scratch.q_tilde[env, bc] += scale * acc
                dropped = dropped | (1 - ok)
        return dropped

    return SimpleNamespace(energy=energy, gradients=gradients, state_blocks=state_blocks,
                           gap=gap, coordinate=coordinate, alignment=alignment,
                           coordinate_gradients=coordinate_gradients,
                           apply_command=apply_command, lever_arm_force=lever_arm_force)


def linear_pairs(point, direction) -> list:
    """The (J_P, J_C) of its residuals, all linear in q: the two anchor gaps."""
    return [point(0), point(1)]


def nonlinear_residuals(point, direction, qp, qc) -> list:
    """None: every residual is linear (``linear_pairs``)."""
    return []
