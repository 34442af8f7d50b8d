"""Orthogonality potential ‖AAᵀ − I‖²: energy, gradient, PSD Hessian.

Values are per unit κ·v̄; the incremental potential scales them by dt²·κ·v̄. The PSD Hessian
is the closed-form eigensystem of one 3×3 SVD, negative modes dropped, added scaled into a
given 12×12 block (no 12×12 temporary of its own). docs/physics.md#orthogonality-potential
gives the eigensystem.
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the orthogonality potential for the types namespace ``t``."""
    vec3, mat33, mat12, scalar = t.vec3, t.mat33, t.mat12, t.scalar
    zero, four, inv_sqrt2 = t.zero, t.four, t.inv_sqrt2
    affine_part, svd = t.affine_part, t.svd

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
    def add_ortho_hessian(h: mat12, scale: scalar, a: mat33):
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

    return SimpleNamespace(ortho_energy=ortho_energy, ortho_gradient=ortho_gradient,
                           add_ortho_hessian=add_ortho_hessian)
