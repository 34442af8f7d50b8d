"""Newton system solve where bodies touch each other (docs/physics.md#coupled-solve).

Contact between two free bodies couples their blocks off the kinematic tree
(scratch.contact_block). Each iterate the joints' forest grows by the contacts between bodies
that join two of its trees (``grow_forest``: a contact closing a cycle is left out), and the
factorization of that forest becomes the preconditioner of a conjugate-gradient solve of the
whole system (diagonal blocks, joint couplings and every contact coupling): exact at once
where the contacts form no cycle (a stack), and a scene whose bodies touch nothing but static
things never pays for more than the direct tree solve. The solve stops when
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
    joint_block = t.joint_block
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
    def root_of(scratch: Scratch, env: int, b: int):
        """The representative of body b's tree in the forest being grown (forest_root)."""
        r = b
        while scratch.forest_root[env, r] != r:
            r = scratch.forest_root[env, r]
        return r

    @wp.func
    def grow_forest(model: Model, scratch: Scratch, env: int):
        """The elimination forest of this iterate into scratch.forest_parent, forest_block
        (H[b, parent]) and forest_order (every body before its parent): the joints' trees,
        then each contact between bodies of two different trees (touch pairs in order): the
        first body's tree is re-rooted at it and hung below the other body."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            p = model.elim_parent[b]
            scratch.forest_parent[env, b] = p
            scratch.forest_root[env, b] = b
            if p >= 0:
                scratch.forest_block[env, b] = joint_block(model, scratch, env, b)
                scratch.forest_root[env, b] = p
        for j in range(model.touch_a.shape[0]):
            if scratch.block_used[env, j] != 0:
                a = model.touch_a[j]
                c = model.touch_b[j]
                top_a = root_of(scratch, env, a)
                top_c = root_of(scratch, env, c)
                if top_a != top_c:
                    above = c
                    block = scratch.contact_block[env, j]       # H[a, c]
                    cur = a
                    while cur >= 0:
                        up = scratch.forest_parent[env, cur]
                        old = scratch.forest_block[env, cur]    # H[cur, up]
                        scratch.forest_parent[env, cur] = above
                        scratch.forest_block[env, cur] = block
                        above = cur
                        block = wp.transpose(old)
                        cur = up
                    scratch.forest_root[env, top_a] = top_c
        deepest = int(0)
        for k in range(n_free):
            b = model.elim_order[k]
            depth = int(0)
            x = scratch.forest_parent[env, b]
            while x >= 0:
                depth += 1
                x = scratch.forest_parent[env, x]
            scratch.forest_depth[env, b] = depth
            deepest = wp.max(deepest, depth)
        at = int(0)
        for level in range(deepest + 1):
            for k in range(n_free):
                b = model.elim_order[k]
                if scratch.forest_depth[env, b] == deepest - level:
                    scratch.forest_order[env, at] = b
                    at += 1

    @wp.func
    def hessian_times(model: Model, scratch: Scratch, env: int, x: wp.array2d(dtype=vec12),
                      out: wp.array2d(dtype=vec12)):
        """out = H x over the free bodies: diagonal blocks, the tree's couplings, the
        contact couplings of this iterate and the mimic couplings."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            out[env, b] = scratch.hessian[env, b] @ x[env, b]
        for k in range(n_free):
            b = model.elim_order[k]
            p = model.elim_parent[b]
            if p >= 0:
                off = joint_block(model, scratch, env, b)
                out[env, b] += off @ x[env, p]
                out[env, p] += wp.transpose(off) @ x[env, b]
        for j in range(model.touch_a.shape[0]):
            if scratch.block_used[env, j] != 0:
                a = model.touch_a[j]
                c = model.touch_b[j]
                block = scratch.contact_block[env, j]
                out[env, a] += block @ x[env, c]
                out[env, c] += wp.transpose(block) @ x[env, a]
        rows = model.body_fixed.shape[0]
        for i in range(model.mimic_follower.shape[0]):     # K g gᵀ x of each mimic
            along = zero
            for k in range(n_free):
                b = model.elim_order[k]
                along += wp.dot(scratch.mimic_gradient[env, i * rows + b], x[env, b])
            along *= model.mimic_stiffness[i]
            for k in range(n_free):
                b = model.elim_order[k]
                out[env, b] += along * scratch.mimic_gradient[env, i * rows + b]

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
        """H dq = rhs into scratch.dq: the forest's solve (``grow_forest``; the joints' tree
        without contact between bodies), then, where contact couples bodies, conjugate
        gradients preconditioned by it. Returns (CG iterations, 1 if they stalled)."""
        if wp.static(t.bodies):
            grow_forest(model, scratch, env)
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
                                    scratch.cg_preconditioned, 0)
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
                                        scratch.cg_preconditioned, 0)
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
