"""Warp kernels: one launch advances every environment by one time step.

One thread per environment runs the whole step of physics_spec (preface and §3): prediction
with gravity and the explicit joint torques, the Newton loop (gradient, PSD-projected Hessian,
block-tree Cholesky solve, convergence test, backtracking line search), then velocities and
joint angles. A step whose state is non-finite, or in which a joint turns more than 0.9π (its
multi-turn angle would alias), is rejected: that environment keeps its start-of-step state and
flags the step in its statistics. No host sync happens inside a step (design.md §8).

The kernels are built per scalar type (float64 or float32) by ``step_kernels``; every array of
state, control and scratch has a leading environment axis.

Frames and units: world frame, SI. q = [p, a1, a2, a3] per body (rows a_r of A).
"""

import math
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.model import BDF2, CONTINUOUS, LEVER_ARM

__all__ = ['step_kernels', 'STAT_INT_NAMES', 'STAT_FLOAT_NAMES']

STAT_INT_NAMES = ('newton_iterations', 'line_search_halvings', 'converged',
                  'line_search_failures', 'angle_aliased', 'torque_dropped', 'non_finite',
                  'step_rejected')
STAT_FLOAT_NAMES = ('residual', 'joint_gap')

_BUILT = {}


def step_kernels(scalar):
    """Structs, functions and the step kernel for ``scalar`` (wp.float64 or wp.float32)."""
    if scalar not in _BUILT:
        _BUILT[scalar] = _build(scalar)
    return _BUILT[scalar]


def _build(scalar):  # noqa: C901 - one closure so that every function shares the scalar type
    vec3 = wp.types.vector(length=3, dtype=scalar)
    mat33 = wp.types.matrix(shape=(3, 3), dtype=scalar)
    vec12 = wp.types.vector(length=12, dtype=scalar)
    mat12 = wp.types.matrix(shape=(12, 12), dtype=scalar)
    zero, half, one, two = scalar(0.0), scalar(0.5), scalar(1.0), scalar(2.0)
    four = scalar(4.0)
    # Constants are computed here, in Python: a quotient written inside a kernel is evaluated in
    # float32 even when cast to float64 (Warp 1.19), which made BDF2's 4/3 − 1/3 = 1 + 3e-8.
    pi, two_pi = scalar(math.pi), scalar(2.0 * math.pi)
    alias_limit = scalar(0.9 * math.pi)   # |Δθ| per step [rad] beyond which angles alias
    inv_sqrt2 = scalar(1.0 / math.sqrt(2.0))
    # BDF2 (physics_spec §3.7): q̃ = 4/3 q_n − 1/3 q_{n−1} + 2dt/9 (4 v_n − v_{n−1}) + 4/9 dt² a,
    # kinetic term scaled by 9/4
    bdf2_q_n, bdf2_q_prev, bdf2_v = scalar(4.0 / 3.0), scalar(1.0 / 3.0), scalar(2.0 / 9.0)
    bdf2_kinetic, bdf2_force = scalar(9.0 / 4.0), scalar(4.0 / 9.0)

    @wp.struct
    class Model:
        """Constant scene data (shared by all environments); see physics.model.HostModel."""

        dt: scalar
        gravity: vec3
        has_gravity: wp.int32
        integrator: wp.int32
        newton_tol: scalar
        newton_max_iter: wp.int32
        line_search: wp.int32
        body_fixed: wp.array(dtype=wp.int32)
        body_mass: wp.array(dtype=scalar)
        body_second_moment: wp.array(dtype=vec3)
        body_ortho_coeff: wp.array(dtype=scalar)
        body_half_extent: wp.array(dtype=vec3)
        body_joint_hessian: wp.array(dtype=mat12)
        elim_order: wp.array(dtype=wp.int32)
        elim_parent: wp.array(dtype=wp.int32)
        elim_offdiag: wp.array(dtype=mat12)
        joint_parent: wp.array(dtype=wp.int32)
        joint_child: wp.array(dtype=wp.int32)
        joint_stiffness: wp.array(dtype=scalar)
        joint_anchors: wp.array2d(dtype=vec3)
        joint_frames: wp.array2d(dtype=vec3)
        joint_torque_model: wp.array(dtype=wp.int32)
        joint_angle_mode: wp.array(dtype=wp.int32)
        joint_has_free: wp.array(dtype=wp.int32)

    @wp.struct
    class State:
        """Per-environment state [env, body] / [env, joint] and the last step's statistics."""

        q: wp.array2d(dtype=vec12)
        v: wp.array2d(dtype=vec12)
        q_prev: wp.array2d(dtype=vec12)          # bdf2 history q_{n-1}
        v_prev: wp.array2d(dtype=vec12)          # bdf2 history v_{n-1}
        history_ready: wp.array(dtype=wp.int32)  # 0: next step is a BDF1 start step
        joint_angle_continuous: wp.array2d(dtype=scalar)
        joint_angle: wp.array2d(dtype=scalar)
        joint_velocity: wp.array2d(dtype=scalar)
        joint_effort: wp.array2d(dtype=scalar)
        stats_int: wp.array2d(dtype=wp.int32)
        stats_float: wp.array2d(dtype=scalar)

    @wp.struct
    class Control:
        """Joint commands [env, joint]: torque τ [N·m] and enable flag (is_constrained)."""

        joint_torque: wp.array2d(dtype=scalar)
        joint_enabled: wp.array2d(dtype=wp.int32)

    @wp.struct
    class Scratch:
        """Work arrays of one step [env, body]."""

        q_n: wp.array2d(dtype=vec12)
        q_tilde: wp.array2d(dtype=vec12)
        q_start: wp.array2d(dtype=vec12)
        dq: wp.array2d(dtype=vec12)
        rhs: wp.array2d(dtype=vec12)
        factor: wp.array2d(dtype=mat12)
        coupling: wp.array2d(dtype=mat12)

    # ---- affine kinematics (physics_spec §1) --------------------------------------------

    @wp.func
    def affine(q: vec12):
        return mat33(q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11])

    @wp.func
    def world_point(q: vec12, x_bar: vec3):
        return vec3(q[0], q[1], q[2]) + affine(q) @ x_bar

    @wp.func
    def jacobian_transpose(x_bar: vec3, f: vec3):
        """J(x̄)ᵀ f = [f; f_1 x̄; f_2 x̄; f_3 x̄]."""
        return vec12(f[0], f[1], f[2],
                     f[0] * x_bar[0], f[0] * x_bar[1], f[0] * x_bar[2],
                     f[1] * x_bar[0], f[1] * x_bar[1], f[1] * x_bar[2],
                     f[2] * x_bar[0], f[2] * x_bar[1], f[2] * x_bar[2])

    @wp.func
    def translation_part(f: vec3):
        """A 3-vector as the translation of a 12-vector, affine part zero."""
        return vec12(f[0], f[1], f[2], zero, zero, zero, zero, zero, zero, zero, zero, zero)

    @wp.func
    def affine_part(g: mat33):
        """A 3×3 matrix as the affine 9 of a 12-vector (row-major), translation zero."""
        return vec12(zero, zero, zero, g[0, 0], g[0, 1], g[0, 2], g[1, 0], g[1, 1], g[1, 2],
                     g[2, 0], g[2, 1], g[2, 2])

    @wp.func
    def mass_times(m: scalar, s: vec3, x: vec12):
        """M x with M = blockdiag(m I3, S, S, S), S = diag(s) (COM-centred rest frame)."""
        return vec12(m * x[0], m * x[1], m * x[2], s[0] * x[3], s[1] * x[4], s[2] * x[5],
                     s[0] * x[6], s[1] * x[7], s[2] * x[8], s[0] * x[9], s[1] * x[10],
                     s[2] * x[11])

    @wp.func
    def add_mass(h: mat12, m: scalar, s: vec3, scale: scalar):
        out = h
        for r in range(3):
            out[r, r] += scale * m
            for c in range(3):
                out[3 + 3 * r + c, 3 + 3 * r + c] += scale * s[c]
        return out

    # ---- orthogonality potential ‖AAᵀ − I‖² (physics_spec §2) --------------------------

    @wp.func
    def ortho_energy(a: mat33):
        c = a @ wp.transpose(a) - wp.identity(n=3, dtype=scalar)
        return wp.ddot(c, c)

    @wp.func
    def ortho_gradient(a: mat33):
        c = a @ wp.transpose(a) - wp.identity(n=3, dtype=scalar)
        return affine_part(four * (c @ a))

    @wp.func
    def add_mode(h: mat12, lam: scalar, mode: mat33):
        """h += λ vec(mode) vec(mode)ᵀ on the affine block, if λ > 0 (PSD projection)."""
        out = h
        if lam > zero:
            w = affine_part(mode)
            for i in range(3, 12):
                for j in range(3, 12):
                    out[i, j] += lam * w[i] * w[j]
        return out

    @wp.func
    def add_pair_modes(h: mat12, u: mat33, sigma: vec3, v: mat33, i: int, j: int):
        """Twist and flip eigenpairs of the (i, j) singular-value pair (design.md §8)."""
        si, sj = sigma[i], sigma[j]
        ui = vec3(u[0, i], u[1, i], u[2, i])
        uj = vec3(u[0, j], u[1, j], u[2, j])
        vi = vec3(v[0, i], v[1, i], v[2, i])
        vj = vec3(v[0, j], v[1, j], v[2, j])
        twist = inv_sqrt2 * (wp.outer(ui, vj) - wp.outer(uj, vi))
        flip = inv_sqrt2 * (wp.outer(ui, vj) + wp.outer(uj, vi))
        out = add_mode(h, four * (si * si - si * sj + sj * sj) - four, twist)
        return add_mode(out, four * (si * si + si * sj + sj * sj) - four, flip)

    @wp.func
    def ortho_hessian_psd(a: mat33):
        """PSD projection of ∇²‖AAᵀ−I‖² from the closed-form eigensystem of one 3×3 SVD."""
        u = mat33()
        sigma = vec3()
        v = mat33()
        wp.svd3(a, u, sigma, v)
        h = mat12()
        for i in range(3):
            ui = vec3(u[0, i], u[1, i], u[2, i])
            vi = vec3(v[0, i], v[1, i], v[2, i])
            h = add_mode(h, scalar(12.0) * sigma[i] * sigma[i] - four, wp.outer(ui, vi))
        h = add_pair_modes(h, u, sigma, v, 0, 1)
        h = add_pair_modes(h, u, sigma, v, 0, 2)
        return add_pair_modes(h, u, sigma, v, 1, 2)

    # ---- revolute joint (physics_spec §4) --------------------------------------------------

    @wp.func
    def joint_gaps(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Anchor gaps d0 = x_P(u0) − x_C(w0), d1 = x_P(u1) − x_C(w1) [m]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        d0 = world_point(qp, model.joint_anchors[k, 0]) - world_point(qc, model.joint_anchors[k, 2])
        d1 = world_point(qp, model.joint_anchors[k, 1]) - world_point(qc, model.joint_anchors[k, 3])
        return d0, d1

    @wp.func
    def joint_angle_raw(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """θ(q) ∈ (−π, π]: right-hand rotation of child vs parent about x1 − x0 (§5.1)."""
        ap = affine(q[env, model.joint_parent[k]])
        ac = affine(q[env, model.joint_child[k]])
        n_p = ap @ model.joint_frames[k, 0]
        b_p = ap @ model.joint_frames[k, 1]
        n_c = ac @ model.joint_frames[k, 2]
        b_c = ac @ model.joint_frames[k, 3]
        c = half * (wp.dot(n_p, n_c) + wp.dot(b_p, b_c))
        s = half * (wp.dot(b_p, n_c) - wp.dot(n_p, b_c))
        return wp.atan2(s, c)

    # ---- joint torque (UID 668, physics_spec §6) --------------------------------------------

    @wp.func
    def lever_arm_force(q: vec12, anchor0: vec3, anchor1: vec3, tau: scalar):
        """Seed formula §6a: a force at the COM whose moment about the axis is τ ê [N]."""
        a = affine(q)
        e = wp.normalize(a @ (anchor1 - anchor0))
        d = -(a @ anchor0)
        r = d - wp.dot(d, e) * e
        r2 = wp.dot(r, r)
        if r2 > scalar(1.0e-12):
            return tau * wp.cross(e, r) / r2
        return vec3()

    @wp.func
    def couple_acceleration(a: mat33, e: vec3, tau: scalar, s: vec3):
        """#448 generalized force (τ/2)[ê]× A⁻ᵀ mapped by S⁻¹ to an affine acceleration.

        Returns (acceleration 12-vector, 1) or (zero, 0) when A is near-singular (§6c guard).
        """
        rows = wp.length(vec3(a[0, 0], a[0, 1], a[0, 2])) * wp.length(
            vec3(a[1, 0], a[1, 1], a[1, 2])) * wp.length(vec3(a[2, 0], a[2, 1], a[2, 2]))
        if rows <= zero or wp.abs(wp.determinant(a)) < scalar(1.0e-6) * rows:
            return vec12(), 0
        f = half * tau * (wp.skew(e) @ wp.transpose(wp.inverse(a)))
        acc = mat33()
        for r in range(3):
            for c in range(3):
                acc[r, c] = f[r, c] / s[c]
        return affine_part(acc), 1

    @wp.func
    def apply_torques(model: Model, state: State, control: Control, scratch: Scratch,
                      env: int, scale: scalar):
        """Add scale·a_ext of every enabled joint's torque to q̃; write efforts [N·m].

        Explicit: evaluated once at the start-of-step state q_n (physics_spec §3.1).
        Returns 1 if a near-singular body dropped a torque.
        """
        dropped = int(0)
        for k in range(model.joint_parent.shape[0]):
            tau = control.joint_torque[env, k]
            if control.joint_enabled[env, k] == 0:
                state.joint_effort[env, k] = zero
                continue
            state.joint_effort[env, k] = tau
            if tau == zero:
                continue
            bp = model.joint_parent[k]
            bc = model.joint_child[k]
            qp = state.q[env, bp]   # still q_n for every body, fixed ones included
            qc = state.q[env, bc]
            u0 = model.joint_anchors[k, 0]
            u1 = model.joint_anchors[k, 1]
            w0 = model.joint_anchors[k, 2]
            w1 = model.joint_anchors[k, 3]
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

    # ---- incremental potential and its Newton direction (physics_spec §3.3–3.4) -------------

    @wp.func
    def incremental_potential(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                              env: int, kinetic_scale: scalar):
        """E(q) = Σ kinetic_scale/2 ‖q − q̃‖²_M + dt² κ v̄ ‖AAᵀ−I‖² + Σ K/2 (|d0|² + |d1|²)."""
        energy = zero
        dt2 = model.dt * model.dt
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            x = q[env, b] - scratch.q_tilde[env, b]
            energy += half * kinetic_scale * wp.dot(
                x, mass_times(model.body_mass[b], model.body_second_moment[b], x))
            energy += dt2 * model.body_ortho_coeff[b] * ortho_energy(affine(q[env, b]))
        for k in range(model.joint_parent.shape[0]):
            if model.joint_has_free[k] != 0:
                d0, d1 = joint_gaps(model, q, env, k)
                energy += half * model.joint_stiffness[k] * (wp.dot(d0, d0) + wp.dot(d1, d1))
        return energy

    @wp.func
    def cholesky(a: mat12):
        """Lower factor L of a symmetric positive definite 12×12 matrix (a = L Lᵀ)."""
        low = mat12()
        for j in range(12):
            s = a[j, j]
            for k in range(j):
                s -= low[j, k] * low[j, k]
            d = wp.sqrt(wp.max(s, a[j, j] * scalar(1.0e-14)))
            low[j, j] = d
            for i in range(j + 1, 12):
                t = a[i, j]
                for k in range(j):
                    t -= low[i, k] * low[j, k]
                low[i, j] = t / d
        return low

    @wp.func
    def forward_solve(low: mat12, b: vec12):
        """y = L⁻¹ b."""
        y = vec12()
        for i in range(12):
            t = b[i]
            for k in range(i):
                t -= low[i, k] * y[k]
            y[i] = t / low[i, i]
        return y

    @wp.func
    def backward_solve(low: mat12, y: vec12):
        """x = L⁻ᵀ y."""
        x = vec12()
        for ii in range(12):
            i = 11 - ii
            t = y[i]
            for k in range(i + 1, 12):
                t -= low[k, i] * x[k]
            x[i] = t / low[i, i]
        return x

    @wp.func
    def forward_solve_matrix(low: mat12, b: mat12):
        """W = L⁻¹ B."""
        w = mat12()
        for c in range(12):
            for i in range(12):
                t = b[i, c]
                for k in range(i):
                    t -= low[i, k] * w[k, c]
                w[i, c] = t / low[i, i]
        return w

    @wp.func
    def assemble(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 kinetic_scale: scalar):
        """rhs = −∇E and factor = diagonal Hessian blocks (off-diagonal ones are constant)."""
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
            scratch.factor[env, b] = add_mass(
                model.body_joint_hessian[b] + ortho * ortho_hessian_psd(a), m, s, kinetic_scale)
        for k in range(model.joint_parent.shape[0]):
            if model.joint_has_free[k] == 0:
                continue
            d0, d1 = joint_gaps(model, q, env, k)
            stiffness = model.joint_stiffness[k]
            bp = model.joint_parent[k]
            bc = model.joint_child[k]
            if model.body_fixed[bp] == 0:
                scratch.rhs[env, bp] -= stiffness * (
                    jacobian_transpose(model.joint_anchors[k, 0], d0)
                    + jacobian_transpose(model.joint_anchors[k, 1], d1))
            if model.body_fixed[bc] == 0:
                scratch.rhs[env, bc] += stiffness * (
                    jacobian_transpose(model.joint_anchors[k, 2], d0)
                    + jacobian_transpose(model.joint_anchors[k, 3], d1))

    @wp.func
    def solve_tree(model: Model, scratch: Scratch, env: int):
        """Solve H dq = rhs into scratch.dq: block-tree Cholesky, leaves first, O(bodies)."""
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            low = cholesky(scratch.factor[env, b])
            scratch.factor[env, b] = low
            y = forward_solve(low, scratch.rhs[env, b])
            scratch.rhs[env, b] = y
            p = model.elim_parent[b]
            if p >= 0:
                w = forward_solve_matrix(low, model.elim_offdiag[b])
                scratch.coupling[env, b] = w
                scratch.factor[env, p] = scratch.factor[env, p] - wp.transpose(w) @ w
                scratch.rhs[env, p] = scratch.rhs[env, p] - wp.transpose(w) @ y
        for kk in range(n_free):
            b = model.elim_order[n_free - 1 - kk]
            r = scratch.rhs[env, b]
            p = model.elim_parent[b]
            if p >= 0:
                r = r - scratch.coupling[env, b] @ scratch.dq[env, p]
            scratch.dq[env, b] = backward_solve(scratch.factor[env, b], r)

    @wp.func
    def update_size(model: Model, scratch: Scratch, env: int):
        """Largest vertex displacement over box corners [m] and largest affine entry of dq."""
        disp = zero
        affine_max = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            dq = scratch.dq[env, b]
            h = model.body_half_extent[b]
            for r in range(3):
                corner = wp.abs(dq[r])
                for c in range(3):
                    corner += wp.abs(dq[3 + 3 * r + c]) * h[c]
                    affine_max = wp.max(affine_max, wp.abs(dq[3 + 3 * r + c]))
                disp = wp.max(disp, corner)
        return disp, affine_max

    @wp.func
    def move(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, alpha: scalar):
        """q = q_start + α dq on the free bodies."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            q[env, b] = scratch.q_start[env, b] + alpha * scratch.dq[env, b]

    @wp.func
    def wrap_angle(x: scalar):
        """x wrapped once into (−π, π]."""
        out = x
        if out > pi:
            out -= two_pi
        elif out <= -pi:
            out += two_pi
        return out

    @wp.func
    def angle_step(model: Model, state: State, env: int, k: int):
        """Δθ of joint k from the last accepted angle to θ(q), taken in (−π, π] [rad]."""
        delta = joint_angle_raw(model, state.q, env, k) - state.joint_angle_continuous[env, k]
        return delta - two_pi * wp.round(delta / two_pi)

    @wp.func
    def commit_step(model: Model, state: State, scratch: Scratch, env: int):
        """Accept the step: velocities (held in scratch.rhs) and history (§3.6, §3.7), angles."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            state.q_prev[env, b] = scratch.q_n[env, b]
            state.v_prev[env, b] = state.v[env, b]
            state.v[env, b] = scratch.rhs[env, b]
        if model.integrator == BDF2:
            state.history_ready[env] = 1
        for k in range(model.joint_parent.shape[0]):
            previous = state.joint_angle_continuous[env, k]
            delta = angle_step(model, state, env, k)
            state.joint_angle_continuous[env, k] = previous + delta
            state.joint_velocity[env, k] = delta / model.dt
            if model.joint_angle_mode[k] == CONTINUOUS:
                state.joint_angle[env, k] = previous + delta
            else:
                state.joint_angle[env, k] = wrap_angle(joint_angle_raw(model, state.q, env, k))

    # ---- the step ---------------------------------------------------------------------------

    @wp.kernel
    def step(model: Model, state: State, control: Control, scratch: Scratch):
        env = wp.tid()
        dt = model.dt
        dt2 = dt * dt
        n_free = model.elim_order.shape[0]
        bdf2 = int(0)
        if model.integrator == BDF2 and state.history_ready[env] != 0:
            bdf2 = 1
        kinetic_scale = one
        force_scale = dt2
        if bdf2 != 0:
            kinetic_scale = bdf2_kinetic
            force_scale = bdf2_force * dt2
        gravity = vec12()
        if model.has_gravity != 0:
            gravity = translation_part(model.gravity)

        # prediction (physics_spec §3.2, §3.7 with a_ext, preface §2)
        for k in range(n_free):
            b = model.elim_order[k]
            qn = state.q[env, b]
            scratch.q_n[env, b] = qn
            if bdf2 != 0:
                scratch.q_tilde[env, b] = (bdf2_q_n * qn
                                           - bdf2_q_prev * state.q_prev[env, b]
                                           + bdf2_v * dt * (four * state.v[env, b]
                                                            - state.v_prev[env, b])
                                           + force_scale * gravity)
            else:
                scratch.q_tilde[env, b] = qn + dt * state.v[env, b] + force_scale * gravity
        dropped = apply_torques(model, state, control, scratch, env, force_scale)

        # Newton from q̃ (§3.4–3.5, preface §7)
        for k in range(n_free):
            b = model.elim_order[k]
            state.q[env, b] = scratch.q_tilde[env, b]
        tol = model.newton_tol * dt
        energy = zero
        if model.line_search != 0:
            energy = incremental_potential(model, state.q, scratch, env, kinetic_scale)
        iterations = int(0)
        halvings = int(0)
        failures = int(0)
        converged = int(0)
        residual = zero
        for it in range(model.newton_max_iter):
            assemble(model, state.q, scratch, env, kinetic_scale)
            solve_tree(model, scratch, env)
            disp, affine_max = update_size(model, scratch, env)
            residual = wp.max(disp, affine_max) / dt
            iterations = it + 1
            for k in range(n_free):
                b = model.elim_order[k]
                scratch.q_start[env, b] = state.q[env, b]
            if disp <= tol and affine_max <= tol:
                move(model, state.q, scratch, env, one)
                converged = 1
                break
            if model.line_search == 0:
                move(model, state.q, scratch, env, one)
                continue
            alpha = one
            accepted = int(0)
            trial = zero
            for ls in range(9):
                move(model, state.q, scratch, env, alpha)
                trial = incremental_potential(model, state.q, scratch, env, kinetic_scale)
                if trial <= energy:
                    accepted = 1
                    break
                if ls < 8:
                    alpha = alpha * half
                    halvings += 1
            if accepted == 0:
                failures += 1
            energy = trial

        # accept the step unless its state is non-finite or a joint turned so far that its
        # angle would alias; a rejected step keeps the start-of-step state (the last good one)
        finite = int(1)
        for k in range(n_free):
            b = model.elim_order[k]
            qn = scratch.q_n[env, b]
            v_new = (state.q[env, b] - qn) / dt
            if bdf2 != 0:
                v_new = (scalar(3.0) * state.q[env, b] - four * qn
                         + state.q_prev[env, b]) / (two * dt)
            scratch.rhs[env, b] = v_new
            if not (wp.isfinite(state.q[env, b]) and wp.isfinite(v_new)):
                finite = 0
        aliased = int(0)
        for k in range(model.joint_parent.shape[0]):
            if wp.abs(angle_step(model, state, env, k)) > alias_limit:
                aliased = 1
        if finite == 0:
            converged = 0
        rejected = int(0)
        if finite == 0 or aliased != 0:
            rejected = 1
            for k in range(n_free):
                b = model.elim_order[k]
                state.q[env, b] = scratch.q_n[env, b]
        else:
            commit_step(model, state, scratch, env)

        gap = zero
        for k in range(model.joint_parent.shape[0]):
            d0, d1 = joint_gaps(model, state.q, env, k)
            gap = wp.max(gap, wp.max(wp.length(d0), wp.length(d1)))

        state.stats_int[env, 0] = iterations
        state.stats_int[env, 1] = halvings
        state.stats_int[env, 2] = converged
        state.stats_int[env, 3] = failures
        state.stats_int[env, 4] = aliased
        state.stats_int[env, 5] = dropped
        state.stats_int[env, 6] = 1 - finite
        state.stats_int[env, 7] = rejected
        state.stats_float[env, 0] = residual
        state.stats_float[env, 1] = gap

    return SimpleNamespace(
        scalar=scalar, vec3=vec3, mat33=mat33, vec12=vec12, mat12=mat12,
        Model=Model, State=State, Control=Control, Scratch=Scratch, step=step,
        affine=affine, ortho_energy=ortho_energy, ortho_gradient=ortho_gradient,
        ortho_hessian_psd=ortho_hessian_psd, cholesky=cholesky, forward_solve=forward_solve,
        backward_solve=backward_solve, incremental_potential=incremental_potential,
        assemble=assemble, solve_tree=solve_tree, joint_angle_raw=joint_angle_raw,
        lever_arm_force=lever_arm_force, couple_acceleration=couple_acceleration)
