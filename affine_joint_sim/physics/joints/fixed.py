"""Fixed joint (UID 25): welds two bodies at the midpoint c of their centres, world axes.

Energy K/2 (|c_P − c_C|² + |t_P − t_C|² + |n_P − n_C|² + |b_P − b_C|²) with c_k = x_k(c̄_k) and
t_k, n_k, b_k = A_k times the rest copies of the world axes: linear in q, so its Hessian blocks
are the constants of physics.host.model. It has no coordinate (0) and takes no command: its
functions for those are explicit no-ops.
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build', 'linear_pairs', 'nonlinear_residuals']


def build(t) -> SimpleNamespace:
    """Warp functions of the fixed joint for the types namespace ``t``."""
    vec12, mat12, scalar, zero, half = t.vec12, t.mat12, t.scalar, t.zero, t.half
    Model, Scratch = t.structs.Model, t.structs.Scratch
    affine, world_point, jacobian_transpose = t.affine, t.world_point, t.jacobian_transpose
    direction_jacobian_transpose = t.direction_jacobian_transpose

    @wp.func
    def gaps(model: Model, qp: vec12, qc: vec12, k: int):
        """c_P − c_C [m] and the axis differences t_P − t_C, n_P − n_C, b_P − b_C."""
        ap = affine(qp)
        ac = affine(qc)
        dc = world_point(qp, model.joint_parent_point0[k]) - world_point(
            qc, model.joint_child_point0[k])
        dt = ap @ model.joint_parent_axis[k] - ac @ model.joint_child_axis[k]
        dn = ap @ model.joint_parent_normal[k] - ac @ model.joint_child_normal[k]
        db = ap @ model.joint_parent_binormal[k] - ac @ model.joint_child_binormal[k]
        return dc, dt, dn, db

    @wp.func
    def energy(model: Model, qp: vec12, qc: vec12, k: int):
        """K/2 (|c_P − c_C|² + |t_P − t_C|² + |n_P − n_C|² + |b_P − b_C|²)."""
        dc, dt, dn, db = gaps(model, qp, qc, k)
        return half * model.joint_stiffness[k] * (
            wp.dot(dc, dc) + wp.dot(dt, dt) + wp.dot(dn, dn) + wp.dot(db, db))

    @wp.func
    def gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """(∇_P E, ∇_C E)."""
        dc, dt, dn, db = gaps(model, qp, qc, k)
        stiffness = model.joint_stiffness[k]
        g_parent = stiffness * (jacobian_transpose(model.joint_parent_point0[k], dc)
                                + direction_jacobian_transpose(model.joint_parent_axis[k], dt)
                                + direction_jacobian_transpose(model.joint_parent_normal[k], dn)
                                + direction_jacobian_transpose(model.joint_parent_binormal[k], db))
        g_child = -stiffness * (jacobian_transpose(model.joint_child_point0[k], dc)
                                + direction_jacobian_transpose(model.joint_child_axis[k], dt)
                                + direction_jacobian_transpose(model.joint_child_normal[k], dn)
                                + direction_jacobian_transpose(model.joint_child_binormal[k], db))
        return g_parent, g_child

    @wp.func
    def gap(model: Model, qp: vec12, qc: vec12, k: int):
        """Distance between the two copies of the weld centre [m]."""
        dc, dt, dn, db = gaps(model, qp, qc, k)
        return wp.length(dc)

    @wp.func
    def state_blocks(model: Model, qp: vec12, qc: vec12, k: int):
        """None: the energy is quadratic in q, its blocks are constants (zeros, 0)."""
        return mat12(), mat12(), mat12(), int(0)

    @wp.func
    def coordinate(model: Model, qp: vec12, qc: vec12, k: int):
        """None: a weld has no coordinate (0)."""
        return zero

    @wp.func
    def coordinate_gradients(model: Model, qp: vec12, qc: vec12, k: int):
        """None (zeros)."""
        return vec12(), vec12()

    @wp.func
    def apply_command(model: Model, qp: vec12, qc: vec12, scratch: Scratch, env: int, k: int,
                      command: scalar, scale: scalar):
        """None: a weld takes no command (returns 0, nothing dropped)."""
        return int(0)

    return SimpleNamespace(energy=energy, gradients=gradients, state_blocks=state_blocks,
                           gap=gap, coordinate=coordinate,
                           coordinate_gradients=coordinate_gradients, apply_command=apply_command)


def linear_pairs(point, direction) -> list:
    """The (J_P, J_C) of its residuals, all linear in q: the weld centre and the three axes."""
    return [point(0), direction('axis'), direction('normal'), direction('binormal')]


def nonlinear_residuals(point, direction, qp, qc) -> list:
    """None: every residual is linear (``linear_pairs``)."""
    return []
