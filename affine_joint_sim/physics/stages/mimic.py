"""Mimic couplings: a joint whose coordinate follows another's (URDF ``<mimic>``).

Coupling i holds x_f = m x_l + o (follower f, leader l, multiplier m, offset o) by the spring
K/2 r², r = x_f − m x_l − o [rad | m], inside the incremental potential (docs/physics.md#mimic
-joints); like a drive it carries no dt² (physical stiffness K/dt²). Its gradient K r g, with
g = ∇x_f − m ∇x_l on the up to four bodies of the two joints, enters the right-hand side;
its Gauss–Newton Hessian K g gᵀ couples bodies off the kinematic tree (two fingers of one
hand), so it stays out of the blocks: g is kept for the solves (scratch.mimic_gradient),
which add it by the Sherman–Morrison–Woodbury formula (physics.solve.tree_solve). A scene
without mimics runs none of this.
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the mimic couplings for the types namespace ``t``."""
    vec12, scalar, zero, half, one = t.vec12, t.scalar, t.zero, t.half, t.one
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    joint_coordinate, joint_coordinate_gradients = (t.joint_coordinate,
                                                    t.joint_coordinate_gradients)

    @wp.func(inline=True)
    def mimic_joint(model: Model, i: int, side: int):
        """(joint, its factor in r) of coupling i: the follower (side 0, 1) or the leader
        (side 1, −m)."""
        joint = model.mimic_follower[i]
        factor = one
        if side != 0:
            joint = model.mimic_leader[i]
            factor = -model.mimic_multiplier[i]
        return joint, factor

    @wp.func
    def mimic_residual(model: Model, state: State, q: wp.array2d(dtype=vec12), env: int,
                       i: int):
        """r = x_f − m x_l − o of coupling i at q [rad | m] (one call site of the coordinate:
        a GPU compile inlines it at every one)."""
        r = -model.mimic_offset[i]
        for side in range(2):
            joint, factor = mimic_joint(model, i, side)
            r += factor * joint_coordinate(model, q, state, env, joint)
        return r

    @wp.func
    def mimic_energy(model: Model, state: State, q: wp.array2d(dtype=vec12), env: int):
        """Σ K/2 r² over the couplings [J·s²]."""
        energy = zero
        for i in range(model.mimic_follower.shape[0]):
            r = mimic_residual(model, state, q, env, i)
            energy += half * model.mimic_stiffness[i] * r * r
        return energy

    @wp.func
    def add_side(model: Model, scratch: Scratch, env: int, body: int, g: vec12, force: scalar,
                 column: int, hessian: int):
        """One body's part g of a coupling's gradient: −force g into its rhs and, with
        ``hessian``, g into the coupling's column of scratch.mimic_gradient."""
        if model.body_fixed[body] == 0:
            scratch.rhs[env, body] -= force * g
            if hessian != 0:
                scratch.mimic_gradient[env, column + body] += g

    @wp.func
    def add_mimics(model: Model, state: State, q: wp.array2d(dtype=vec12), scratch: Scratch,
                   env: int, hessian: int):
        """Each coupling's gradient K r g into scratch.rhs (−) and, with ``hessian``, its g
        into scratch.mimic_gradient for the solves."""
        rows = model.body_fixed.shape[0]
        for i in range(model.mimic_follower.shape[0]):
            column = i * rows
            if hessian != 0:
                for b in range(rows):
                    scratch.mimic_gradient[env, column + b] = vec12()
            force = model.mimic_stiffness[i] * mimic_residual(model, state, q, env, i)
            for side in range(2):
                joint, factor = mimic_joint(model, i, side)
                g_parent, g_child = joint_coordinate_gradients(model, q, env, joint)
                add_side(model, scratch, env, model.joint_parent[joint], factor * g_parent,
                         force, column, hessian)
                add_side(model, scratch, env, model.joint_child[joint], factor * g_child,
                         force, column, hessian)

    return SimpleNamespace(mimic_energy=mimic_energy, add_mimics=add_mimics)
