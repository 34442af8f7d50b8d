"""Newton system solve: block-tree Cholesky, leaves first, O(bodies) (docs/physics.md#tree-solve).

The free bodies joined by joints form a forest; eliminating them in ``model.elim_order``
(every body before its tree parent) factors H without fill-in: 12×12 blocks only. The factors
stay in scratch, so a later right-hand side is solved without factoring again. A mimic
coupling's Hessian K g gᵀ reaches bodies off the tree (two fingers on one hand): it stays out
of the blocks and enters every solve by the Sherman–Morrison–Woodbury formula, one more solve
per coupling at each factorization (``factor_mimics``, ``correct_mimics``). Where bodies may
touch each other (``t.bodies``) the forest is the joints' grown by contacts between bodies
each iterate (``coupled_solve.grow_forest``: scratch.forest_order, forest_parent,
forest_block), read through the same three accessors.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the tree solve for the types namespace ``t``."""
    vec12, mat12 = t.vec12, t.mat12
    Model, Scratch = t.structs.Model, t.structs.Scratch
    pivot_floor, zero, one = t.pivot_floor, t.zero, t.one
    bodies = t.bodies

    @wp.func(inline=True)
    def eliminated(model: Model, scratch: Scratch, env: int, k: int):
        """The k-th free body of the elimination order."""
        if wp.static(bodies):
            return scratch.forest_order[env, k]
        return model.elim_order[k]

    @wp.func(inline=True)
    def parent_of(model: Model, scratch: Scratch, env: int, b: int):
        """Body b's parent in the elimination forest, -1 for a root."""
        if wp.static(bodies):
            return scratch.forest_parent[env, b]
        return model.elim_parent[b]

    @wp.func(inline=True)
    def joint_block(model: Model, scratch: Scratch, env: int, b: int):
        """H[b, elim_parent[b]] of the joints: model.elim_offdiag or, where
        scratch.offdiag_set says so, scratch.offdiag (a joint's state term)."""
        off = model.elim_offdiag[b]
        if model.state_coupling != 0 and scratch.offdiag_set[env, b] != 0:
            off = scratch.offdiag[env, b]
        return off

    @wp.func(inline=True)
    def parent_block(model: Model, scratch: Scratch, env: int, b: int):
        """H[b, parent of b]: the joints' (``joint_block``), or with contact between bodies
        the forest's."""
        if wp.static(bodies):
            return scratch.forest_block[env, b]
        return joint_block(model, scratch, env, b)

    @wp.func
    def cholesky(a: mat12):
        """(L, 1/diag(L)): the lower factor of a symmetric positive (semi)definite 12×12 matrix
        (a = L Lᵀ) and its inverse pivots, which the solves multiply by (a division's latency
        sits on their critical path). A pivot below pivot_floor × the largest diagonal entry
        (a direction singular to rounding, or made so by a Schur complement's cancellation) is
        raised to it."""
        low = mat12()
        inverse = vec12()
        floor = zero
        for j in range(12):
            floor = wp.max(floor, wp.abs(a[j, j]))
        floor = floor * pivot_floor
        for j in range(12):
            s = a[j, j]
            for k in range(j):
                s -= low[j, k] * low[j, k]
            d = wp.sqrt(wp.max(s, floor))
            low[j, j] = d
            inverse[j] = one / d
            for i in range(j + 1, 12):
                r = a[i, j]
                for k in range(j):
                    r -= low[i, k] * low[j, k]
                low[i, j] = r * inverse[j]
        return low, inverse

    @wp.func
    def forward_solve(low: mat12, inverse: vec12, b: vec12):
        """y = L⁻¹ b (``inverse``: 1/diag(L))."""
        y = vec12()
        for i in range(12):
            r = b[i]
            for k in range(i):
                r -= low[i, k] * y[k]
            y[i] = r * inverse[i]
        return y

    @wp.func
    def backward_solve(low: mat12, inverse: vec12, y: vec12):
        """x = L⁻ᵀ y (``inverse``: 1/diag(L)), a row of L at a time from the last: y_i less
        L[k, i] x_k in the order the x_k become known, so the newest enters last and each
        row waits on one subtraction, not on a dot product."""
        x = vec12()
        r = y
        for kk in range(12):
            k = 11 - kk
            x[k] = r[k] * inverse[k]
            r = r - x[k] * low[k]
        return x

    @wp.func
    def forward_solve_matrix(low: mat12, inverse: vec12, b: mat12):
        """W = L⁻¹ B, row by row (each row of W a vector operation)."""
        w = mat12()
        for i in range(12):
            r = b[i]
            for k in range(i):
                r -= low[i, k] * w[k]
            w[i] = r * inverse[i]
        return w

    @wp.func
    def subtract_gram(a: mat12, w: mat12):
        """a − WᵀW on the lower triangle, the part ``cholesky`` reads (the upper keeps a's)."""
        out = a
        for i in range(12):
            for j in range(i + 1):
                r = out[i, j]
                for k in range(12):
                    r -= w[k, i] * w[k, j]
                out[i, j] = r
        return out

    @wp.func
    def subtract_transposed(b: vec12, w: mat12, y: vec12):
        """b − Wᵀy."""
        out = b
        for i in range(12):
            r = out[i]
            for k in range(12):
                r -= w[k, i] * y[k]
            out[i] = r
        return out

    @wp.func
    def factor_tree(model: Model, scratch: Scratch, env: int):
        """Factor H from the blocks scratch.hessian (diagonal) and the couplings to the
        elimination parents (``parent_block``): each body's lower factor into scratch.factor
        (its inverse pivots into scratch.pivot_inverse), its L⁻¹·coupling into
        scratch.coupling."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = eliminated(model, scratch, env, k)
            scratch.factor[env, b] = scratch.hessian[env, b]
        for k in range(n_free):
            b = eliminated(model, scratch, env, k)
            low, inverse = cholesky(scratch.factor[env, b])
            scratch.factor[env, b] = low
            scratch.pivot_inverse[env, b] = inverse
            p = parent_of(model, scratch, env, b)
            if p >= 0:
                w = forward_solve_matrix(low, inverse, parent_block(model, scratch, env, b))
                scratch.coupling[env, b] = w
                scratch.factor[env, p] = subtract_gram(scratch.factor[env, p], w)

    @wp.func
    def solve_factored_into(model: Model, scratch: Scratch, env: int,
                            source: wp.array2d(dtype=vec12), target: wp.array2d(dtype=vec12),
                            at: int):
        """Solve H x = source into target with the factors of the last ``factor_tree`` (body
        b's row of either at column at + b)."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = eliminated(model, scratch, env, k)
            scratch.forward[env, b] = source[env, at + b]
        for k in range(n_free):
            b = eliminated(model, scratch, env, k)
            y = forward_solve(scratch.factor[env, b], scratch.pivot_inverse[env, b],
                              scratch.forward[env, b])
            scratch.forward[env, b] = y
            p = parent_of(model, scratch, env, b)
            if p >= 0:
                scratch.forward[env, p] = subtract_transposed(scratch.forward[env, p],
                                                              scratch.coupling[env, b], y)
        for kk in range(n_free):
            b = eliminated(model, scratch, env, n_free - 1 - kk)
            r = scratch.forward[env, b]
            p = parent_of(model, scratch, env, b)
            if p >= 0:
                r = r - scratch.coupling[env, b] @ target[env, at + p]
            target[env, at + b] = backward_solve(scratch.factor[env, b],
                                                 scratch.pivot_inverse[env, b], r)

    # three call sites with pairs of bodies: out of line (physics.stages.out_of_line)
    solve_factored_into = apart(t, solve_factored_into)

    @wp.func
    def factor_mimics(model: Model, scratch: Scratch, env: int):
        """With the blocks H just factored, the mimic couplings' part of the
        Sherman–Morrison–Woodbury formula for H + G K Gᵀ (G's columns g, K their stiffnesses:
        scratch.mimic_gradient): Z = H⁻¹ G into scratch.mimic_solved and the Cholesky factor
        of 1/K + Gᵀ Z into scratch.mimic_matrix. Nothing without mimics."""
        count = model.mimic_follower.shape[0]
        rows = model.body_fixed.shape[0]
        n_free = model.elim_order.shape[0]
        for i in range(count):
            solve_factored_into(model, scratch, env, scratch.mimic_gradient,
                                scratch.mimic_solved, i * rows)
        for i in range(count):
            for j in range(i + 1):
                s = zero
                for k in range(n_free):
                    b = model.elim_order[k]
                    s += wp.dot(scratch.mimic_gradient[env, i * rows + b],
                                scratch.mimic_solved[env, j * rows + b])
                if i == j:
                    s += one / model.mimic_stiffness[i]
                for k in range(j):
                    s -= (scratch.mimic_matrix[env, i * count + k]
                          * scratch.mimic_matrix[env, j * count + k])
                if i == j:
                    scratch.mimic_matrix[env, i * count + i] = wp.sqrt(s)
                else:
                    scratch.mimic_matrix[env, i * count + j] = (
                        s / scratch.mimic_matrix[env, j * count + j])

    @wp.func
    def correct_mimics(model: Model, scratch: Scratch, env: int,
                       target: wp.array2d(dtype=vec12)):
        """target = H⁻¹ r (the blocks' solve) turned into (H + G K Gᵀ)⁻¹ r: less Z (1/K +
        Gᵀ Z)⁻¹ Gᵀ target (``factor_mimics``; the weights in scratch.mimic_weight)."""
        count = model.mimic_follower.shape[0]
        rows = model.body_fixed.shape[0]
        n_free = model.elim_order.shape[0]
        for i in range(count):
            w = zero
            for k in range(n_free):
                b = model.elim_order[k]
                w += wp.dot(scratch.mimic_gradient[env, i * rows + b], target[env, b])
            for j in range(i):
                w -= scratch.mimic_matrix[env, i * count + j] * scratch.mimic_weight[env, j]
            scratch.mimic_weight[env, i] = w / scratch.mimic_matrix[env, i * count + i]
        for ii in range(count):
            i = count - 1 - ii
            w = scratch.mimic_weight[env, i]
            for j in range(i + 1, count):
                w -= scratch.mimic_matrix[env, j * count + i] * scratch.mimic_weight[env, j]
            scratch.mimic_weight[env, i] = w / scratch.mimic_matrix[env, i * count + i]
        if count > 0:
            for k in range(n_free):
                b = model.elim_order[k]
                x = target[env, b]
                for i in range(count):
                    x -= scratch.mimic_weight[env, i] * scratch.mimic_solved[env, i * rows + b]
                target[env, b] = x

    @wp.func
    def solve_factored(model: Model, scratch: Scratch, env: int):
        """Solve H dq = rhs into scratch.dq with the factors of the last ``factor_tree`` (and
        of its ``factor_mimics``)."""
        solve_factored_into(model, scratch, env, scratch.rhs, scratch.dq, 0)
        correct_mimics(model, scratch, env, scratch.dq)

    @wp.func
    def solve_tree(model: Model, scratch: Scratch, env: int):
        """Factor H (``factor_tree``, ``factor_mimics``) and solve H dq = rhs into
        scratch.dq."""
        factor_tree(model, scratch, env)
        factor_mimics(model, scratch, env)
        solve_factored(model, scratch, env)

    return SimpleNamespace(cholesky=cholesky, forward_solve=forward_solve,
                           backward_solve=backward_solve, factor_tree=factor_tree,
                           solve_factored_into=solve_factored_into, joint_block=joint_block,
                           solve_factored=solve_factored, solve_tree=solve_tree)
