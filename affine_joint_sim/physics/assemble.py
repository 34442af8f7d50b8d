"""Newton system of one environment: −∇E into scratch.rhs, diagonal blocks into scratch.hessian.

The diagonal blocks are kinetic_scale·M + dt² κ v̄ ∇²‖AAᵀ−I‖² (PSD-projected) + the joints'
constant blocks; the coupling blocks of the tree are constant (model.elim_offdiag).
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the assembly for the types namespace ``t``."""
    vec12, scalar = t.vec12, t.scalar
    Model, Scratch = t.structs.Model, t.structs.Scratch
    affine, mass_times, add_mass = t.affine, t.mass_times, t.add_mass
    ortho_gradient, ortho_hessian_psd = t.ortho_gradient, t.ortho_hessian_psd
    joint_gradients = t.joint_gradients

    @wp.func
    def assemble(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 kinetic_scale: scalar):
        """rhs = −∇E(q) and hessian = the diagonal blocks of ∇²E(q) of the free bodies."""
        dt2 = model.dt * model.dt
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            qb = q[env, b]
            a = affine(qb)
            m = model.body_mass[b]
            s = model.body_second_moment[b]
            ortho = dt2 * model.body_ortho_coeff[b]
            scratch.rhs[env, b] = -(kinetic_scale * mass_times(m, s, qb - scratch.q_tilde[env, b])
                                    + ortho * ortho_gradient(a))
            scratch.hessian[env, b] = add_mass(
                model.body_joint_hessian[b] + ortho * ortho_hessian_psd(a), m, s, kinetic_scale)
        for k in range(model.joint_parent.shape[0]):
            if model.joint_has_free[k] == 0:
                continue
            g_parent, g_child = joint_gradients(model, q, env, k)
            bp = model.joint_parent[k]
            bc = model.joint_child[k]
            if model.body_fixed[bp] == 0:
                scratch.rhs[env, bp] -= g_parent
            if model.body_fixed[bc] == 0:
                scratch.rhs[env, bc] -= g_child

    return SimpleNamespace(assemble=assemble)
