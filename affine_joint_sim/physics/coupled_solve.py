"""Newton system solve where bodies touch each other (docs/physics.md#coupled-solve).

Contact between two free bodies couples their blocks off the kinematic tree
(scratch.contact_block), so the tree factorization is no longer exact. It becomes the
preconditioner of a conjugate-gradient solve of the whole system (diagonal blocks, tree
couplings and contact couplings): exact in one step for a scene whose bodies touch nothing
but static things, which never pays for more than the direct tree solve. The solve stops when
the preconditioned residual rᵀM⁻¹r falls below CG_GOAL (relative to the right-hand side's),
or after CG_MAX_ITER iterations (a stall, counted): every iterate of preconditioned conjugate
gradients from the tree solve lowers the quadratic model, so a stalled direction still
descends and the line search takes it.
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['CG_MAX_ITER', 'build']

CG_MAX_ITER = 100


def build(t) -> SimpleNamespace:
    """Warp functions of the coupled solve for the types namespace ``t``."""
    vec12, zero = t.vec12, t.zero
    Model, Scratch = t.structs.Model, t.structs.Scratch
    solve_tree, solve_factored_into = t.solve_tree, t.solve_factored_into
    goal = t.cg_goal

    @wp.func
    def coupled(model: Model, scratch: Scratch, env: int):
        """Whether a contact couples two bodies' blocks this iterate."""
        found = int(0)
        for j in range(model.touch_a.shape[0]):
            if scratch.block_used[env, j] != 0:
                found = 1
        return found != 0

    @wp.func
    def hessian_times(model: Model, scratch: Scratch, env: int, x: wp.array2d(dtype=vec12),
                      out: wp.array2d(dtype=vec12)):
        """out = H x over the free bodies: diagonal blocks, the tree's couplings and the
        contact couplings of this iterate."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            out[env, b] = scratch.hessian[env, b] @ x[env, b]
        for k in range(n_free):
            b = model.elim_order[k]
            p = model.elim_parent[b]
            if p >= 0:
                off = model.elim_offdiag[b]
                if model.state_coupling != 0 and scratch.offdiag_set[env, b] != 0:
                    off = scratch.offdiag[env, b]
                out[env, b] += off @ x[env, p]
                out[env, p] += wp.transpose(off) @ x[env, b]
        for j in range(model.touch_a.shape[0]):
            if scratch.block_used[env, j] != 0:
                a = model.touch_a[j]
                c = model.touch_b[j]
                block = scratch.contact_block[env, j]
                out[env, a] += block @ x[env, c]
                out[env, c] += wp.transpose(block) @ x[env, a]

    @wp.func
    def dot_free(model: Model, env: int, x: wp.array2d(dtype=vec12),
                 y: wp.array2d(dtype=vec12)):
        """Σ xᵀy over the free bodies."""
        total = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            total += wp.dot(x[env, b], y[env, b])
        return total

    @wp.func
    def solve(model: Model, scratch: Scratch, env: int):
        """H dq = rhs into scratch.dq: the tree solve, then, where contact couples bodies,
        preconditioned conjugate gradients from it. Returns (CG iterations, 1 if they
        stalled)."""
        solve_tree(model, scratch, env)
        iterations = int(0)
        stalled = int(0)
        if wp.static(t.bodies):
            if coupled(model, scratch, env):
                n_free = model.elim_order.shape[0]
                reference = dot_free(model, env, scratch.rhs, scratch.dq)
                hessian_times(model, scratch, env, scratch.dq, scratch.cg_product)
                for k in range(n_free):
                    b = model.elim_order[k]
                    scratch.cg_residual[env, b] = scratch.rhs[env, b] - scratch.cg_product[env, b]
                solve_factored_into(model, scratch, env, scratch.cg_residual,
                                    scratch.cg_preconditioned)
                for k in range(n_free):
                    b = model.elim_order[k]
                    scratch.cg_direction[env, b] = scratch.cg_preconditioned[env, b]
                rz = dot_free(model, env, scratch.cg_residual, scratch.cg_preconditioned)
                stalled = int(1)
                for it in range(CG_MAX_ITER):
                    if rz <= goal * reference:
                        stalled = 0
                        break
                    hessian_times(model, scratch, env, scratch.cg_direction, scratch.cg_product)
                    curvature = dot_free(model, env, scratch.cg_direction, scratch.cg_product)
                    if curvature <= zero:
                        break
                    iterations += 1
                    step = rz / curvature
                    for k in range(n_free):
                        b = model.elim_order[k]
                        scratch.dq[env, b] += step * scratch.cg_direction[env, b]
                        scratch.cg_residual[env, b] -= step * scratch.cg_product[env, b]
                    solve_factored_into(model, scratch, env, scratch.cg_residual,
                                        scratch.cg_preconditioned)
                    rz_next = dot_free(model, env, scratch.cg_residual,
                                       scratch.cg_preconditioned)
                    for k in range(n_free):
                        b = model.elim_order[k]
                        scratch.cg_direction[env, b] = (scratch.cg_preconditioned[env, b]
                                                        + (rz_next / rz)
                                                        * scratch.cg_direction[env, b])
                    rz = rz_next
        return iterations, stalled

    return SimpleNamespace(hessian_times=hessian_times, solve=solve)
