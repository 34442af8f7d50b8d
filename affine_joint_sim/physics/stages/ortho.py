"""Orthogonality potential ‖AAᵀ − I‖²: energy, gradient, Newton's PSD Hessian.

Values are per unit κ·v̄; the incremental potential scales them by dt²·κ·v̄. Newton's
Hessian is the Gauss–Newton one (closed form, no SVD) where the term it drops is small
against the body's inertia, else the PSD projection of the exact one (one SVD), added scaled
into a given 12×12 block (no 12×12 temporary of its own); docs/physics.md#orthogonality-potential
compares their eigensystems.
"""

import math
from types import SimpleNamespace

import warp as wp

__all__ = ['GAUSS_NEWTON_SHARE', 'build']

# the largest share of a body's inertia that the term the Gauss–Newton Hessian drops may reach
GAUSS_NEWTON_SHARE = 0.1


def build(t) -> SimpleNamespace:
    """Warp functions of the orthogonality potential for the types namespace ``t``."""
    vec3, mat33, mat12, scalar = t.vec3, t.mat33, t.mat12, t.scalar
    zero, four = t.zero, t.four
    inv_sqrt2 = scalar(1.0 / math.sqrt(2.0))
    affine_part, svd = t.affine_part, t.svd
    gauss_newton_share = scalar(GAUSS_NEWTON_SHARE)

    @wp.func
    def ortho_energy(a: mat33):
        """‖AAᵀ − I‖²_F."""
        c = a @ wp.transpose(a) - wp.identity(n=3, dtype=scalar)
        return wp.ddot(c, c)

    @wp.func
    def ortho_gradient(a: mat33):
        """∇ of ‖AAᵀ − I‖² as a 12-vector: 4 (AAᵀ − I) A on the affine part."""
        c = a @ wp.transpose(a) - wp.identity(n=3, dtype=scalar)
        return affine_part(four * (c @ a))

    @wp.func
    def add_mode(h: mat12, scale: scalar, lam: scalar, mode: mat33):
        """h += scale·λ vec(mode) vec(mode)ᵀ on the affine block, if λ > 0 (PSD projection)."""
        out = h
        if lam > zero:
            w = affine_part(mode)
            for i in range(3, 12):
                for j in range(3, 12):
                    out[i, j] += scale * lam * w[i] * w[j]
        return out

    @wp.func
    def add_pair_modes(h: mat12, scale: scalar, u: mat33, sigma: vec3, v: mat33, i: int,
                       j: int):
        """Twist and flip eigenpairs of the (i, j) singular-value pair."""
        si, sj = sigma[i], sigma[j]
        ui = vec3(u[0, i], u[1, i], u[2, i])
        uj = vec3(u[0, j], u[1, j], u[2, j])
        vi = vec3(v[0, i], v[1, i], v[2, i])
        vj = vec3(v[0, j], v[1, j], v[2, j])
        twist = inv_sqrt2 * (wp.outer(ui, vj) - wp.outer(uj, vi))
        flip = inv_sqrt2 * (wp.outer(ui, vj) + wp.outer(uj, vi))
        out = add_mode(h, scale, four * (si * si - si * sj + sj * sj) - four, twist)
        return add_mode(out, scale, four * (si * si + si * sj + sj * sj) - four, flip)

    @wp.func
    def add_projected_hessian(h: mat12, scale: scalar, a: mat33):
        """h + scale · (PSD projection of ∇²‖AAᵀ−I‖²), from the closed-form eigensystem of
        one 3×3 SVD."""
        u, sigma, v = svd(a)
        out = h
        for i in range(3):
            ui = vec3(u[0, i], u[1, i], u[2, i])
            vi = vec3(v[0, i], v[1, i], v[2, i])
            out = add_mode(out, scale, scalar(12.0) * sigma[i] * sigma[i] - four,
                           wp.outer(ui, vi))
        out = add_pair_modes(out, scale, u, sigma, v, 0, 1)
        out = add_pair_modes(out, scale, u, sigma, v, 0, 2)
        return add_pair_modes(out, scale, u, sigma, v, 1, 2)

    @wp.func
    def add_gauss_newton_hessian(h: mat12, scale: scalar, a: mat33):
        """h + scale · 2 JᵀJ on the affine block, J the derivative of C = AAᵀ − I: the
        Gauss–Newton Hessian of ‖C‖², PSD by construction, without the term 4 C dA. With
        G = AᵀA, the entry of A[r, c] and A[s, k] is 4 (δ_rs G[k, c] + A[r, k] A[s, c])."""
        g = wp.transpose(a) @ a
        out = h
        for r in range(3):
            for c in range(3):
                i = 3 + 3 * r + c
                for s in range(3):
                    for k in range(3):
                        entry = a[r, k] * a[s, c]
                        if r == s:
                            entry += g[k, c]
                        out[i, 3 + 3 * s + k] += scale * four * entry
        return out

    @wp.func
    def add_ortho_hessian(h: mat12, scale: scalar, a: mat33, inertia: scalar):
        """h + scale · a PSD Hessian of ‖AAᵀ−I‖²: the Gauss–Newton one where the term it drops,
        4 (AAᵀ − I) dA, is below GAUSS_NEWTON_SHARE of ``inertia`` in every direction, else
        the PSD projection of the exact one (one SVD). ``inertia`` [kg·m²] is the body's
        smallest inertial curvature along a turn per unit ‖dA‖²_F: the kinetic scale times half
        its smallest principal moment of inertia; along other directions the Hessian is
        about 8·scale, far above the dropped term (docs/physics.md#orthogonality-potential)."""
        if four * scale * wp.sqrt(ortho_energy(a)) <= gauss_newton_share * inertia:
            return add_gauss_newton_hessian(h, scale, a)
        return add_projected_hessian(h, scale, a)

    return SimpleNamespace(ortho_energy=ortho_energy, ortho_gradient=ortho_gradient,
                           add_ortho_hessian=add_ortho_hessian)
