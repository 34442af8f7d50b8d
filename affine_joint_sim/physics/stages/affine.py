"""Affine kinematics and the mass matrix: world points, Jacobians, M x, a couple's acceleration.

q = [p, a1, a2, a3] (rows a_r of A), world frame; the rest frame of a body is centred at its
centre of mass, so M = blockdiag(m I3, S, S, S) with S = diag(s) [kg, kg·m^2]
(docs/physics.md#state-and-kinematics, docs/physics.md#mass).
"""

import math
from types import SimpleNamespace

import warp as wp

from affine_joint_sim import portable_math as pm

__all__ = ['POLAR_ITERATIONS', 'build']

POLAR_ITERATIONS = 12    # Newton iterations of ``polar`` at most (it stops when converged)


def build(t) -> SimpleNamespace:
    """Warp functions of affine kinematics for the types namespace ``t``."""
    vec3, mat33, vec12, mat12, scalar = t.vec3, t.mat33, t.vec12, t.mat12, t.scalar
    zero, half = t.zero, t.half
    polar_iterations = POLAR_ITERATIONS
    polar_tolerance = scalar(math.sqrt(4.0 * float(t.unit_roundoff)))   # δ with δ² = 4 ε_p
    stretch_series = scalar(pm.cbrt(0.5 * float(t.unit_roundoff)))     # portable cube root
    eighth = scalar(0.125)

    @wp.func
    def affine(q: vec12):
        """A of q (rows a1, a2, a3)."""
        return mat33(q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11])

    @wp.func
    def world_point(q: vec12, x_bar: vec3):
        """x = p + A x̄ [m] of the rest point x̄."""
        return vec3(q[0], q[1], q[2]) + affine(q) @ x_bar

    @wp.func
    def jacobian_transpose(x_bar: vec3, f: vec3):
        """J(x̄)ᵀ f = [f; f_1 x̄; f_2 x̄; f_3 x̄]: a force f at rest point x̄ as a 12-vector."""
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
    def direction_jacobian_transpose(u_bar: vec3, f: vec3):
        """J̊(ū)ᵀ f = [0; f_1 ū; f_2 ū; f_3 ū]: the gradient of f·(A ū) with respect to q."""
        return affine_part(wp.outer(f, u_bar))

    @wp.func
    def couple_acceleration(a: mat33, e: vec3, tau: scalar, s: vec3):
        """The affine acceleration of a couple τ ê [N·m] (world; ê need not be a unit
        vector): the generalized force (τ/2)[ê]× A⁻ᵀ mapped by S⁻¹, whose virtual work on a
        spin δω is τ ê·δω (docs/physics.md#revolute-torque).

        Returns (acceleration 12-vector, 1) or (zero, 0) when A is near-singular (the guard).
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
    def svd(a: mat33):
        """(U, σ, V) with A = U diag(σ) Vᵀ (one 3×3 SVD)."""
        u = mat33()
        sigma = vec3()
        v = mat33()
        wp.svd3(a, u, sigma, v)
        return u, sigma, v

    @wp.func
    def polar(a: mat33):
        """(R, S) of the polar decomposition A = R S (R orthogonal, S symmetric) of a
        non-singular A, by Newton's iteration R ← ½ (R + R⁻ᵀ) from R = A. It converges
        quadratically: an iteration that moves no entry by more than δ leaves an error of about
        δ², so it stops after one whose δ² is within a few rounding units (a near-rotation of
        strain 1e-4 takes two iterations; at most POLAR_ITERATIONS). Several times cheaper
        than an SVD, and as exact."""
        r = a
        for _ in range(polar_iterations):
            update = half * (wp.transpose(wp.inverse(r)) - r)
            r = r + update
            change = zero
            for i in range(3):
                for j in range(3):
                    change = wp.max(change, wp.abs(update[i, j]))
            if change <= polar_tolerance:
                break
        s = wp.transpose(r) @ a
        return r, half * (s + wp.transpose(s))

    @wp.func
    def stretch(a: mat33):
        """S of the polar decomposition A = R S. For a near-rotation (every entry of
        E = AᵀA − I within the cube root of half a rounding unit) the series S = I + E/2 − E²/8,
        whose first dropped term E³/16 is below rounding; otherwise from ``polar``."""
        identity = wp.identity(n=3, dtype=scalar)
        e = wp.transpose(a) @ a - identity
        size = zero
        for i in range(3):
            for j in range(3):
                size = wp.max(size, wp.abs(e[i, j]))
        out = identity + half * e - eighth * (e @ e)
        if size > stretch_series:
            r, out = polar(a)
        return out

    @wp.func
    def mass_times(m: scalar, s: vec3, x: vec12):
        """M x with M = blockdiag(m I3, S, S, S), S = diag(s) (COM-centred rest frame)."""
        return vec12(m * x[0], m * x[1], m * x[2], s[0] * x[3], s[1] * x[4], s[2] * x[5],
                     s[0] * x[6], s[1] * x[7], s[2] * x[8], s[0] * x[9], s[1] * x[10],
                     s[2] * x[11])

    @wp.func
    def add_mass(h: mat12, m: scalar, s: vec3, scale: scalar):
        """h + scale·M."""
        out = h
        for r in range(3):
            out[r, r] += scale * m
            for c in range(3):
                out[3 + 3 * r + c, 3 + 3 * r + c] += scale * s[c]
        return out

    return SimpleNamespace(affine=affine, world_point=world_point,
                           jacobian_transpose=jacobian_transpose,
                           translation_part=translation_part, affine_part=affine_part,
                           direction_jacobian_transpose=direction_jacobian_transpose,
                           couple_acceleration=couple_acceleration, svd=svd, polar=polar,
                           stretch=stretch,
                           mass_times=mass_times, add_mass=add_mass)
