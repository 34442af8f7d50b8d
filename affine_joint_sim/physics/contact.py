"""Contact of free bodies with static half-spaces: the IPC barrier on each contact point's
distance, its gradient and Hessian mapped into the body's block, the step bound along a Newton
direction, and the statistics (docs/physics.md#contact).

The distance of point i to half-space g is d = n·(p + A x̄) − h − r, linear in the body's q
with gradient w = J(x̄)ᵀ n. The barrier (libuipc's form on D = d², D̂ = d̂²)
b(D) = −κ (D − D̂)² ln(D / D̂) for 0 < d < d̂ (zero beyond) enters the incremental potential
as dt² b; as a function of d it is convex on (0, d̂), so its Hessian dt² b''(d) w wᵀ is PSD
(clamped at 0 against rounding) and adds to one diagonal block only: the tree solve stays
exact. Every loop is skipped in a scene without contact (model.has_contact = 0).
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['STEP_SLACK', 'build']

STEP_SLACK = 0.1     # η: a step along dq keeps this fraction of every shrinking gap


def build(t) -> SimpleNamespace:
    """Warp functions of contact for the types namespace ``t``."""
    vec12, scalar = t.vec12, t.scalar
    zero, one, two, four = t.zero, t.one, t.two, t.four
    Model, Scratch = t.structs.Model, t.structs.Scratch
    world_point, jacobian_transpose, log = t.world_point, t.jacobian_transpose, t.log
    keep = scalar(1.0 - STEP_SLACK)
    infinity = scalar(float('inf'))

    @wp.func
    def distance(model: Model, q: vec12, i: int, g: int):
        """Distance [m] of contact point i, on a body at state q, to half-space g."""
        x = world_point(q, model.point_rest[i])
        return wp.dot(model.plane_normal[g], x) - model.plane_offset[g] - model.point_radius[i]

    @wp.func
    def barrier(model: Model, d: scalar):
        """(b, db/dd, d²b/dd²) of the barrier at distance 0 < d < d̂ [J, J/m, J/m²]."""
        d_hat = model.contact_d_hat
        kappa = model.contact_kappa
        big_d = d * d
        gap = big_d - d_hat * d_hat
        ln = log(big_d / (d_hat * d_hat))
        b_big = -kappa * (two * gap * ln + gap * gap / big_d)
        b_big2 = -kappa * (two * ln + four * gap / big_d - gap * gap / (big_d * big_d))
        return -kappa * gap * gap * ln, two * d * b_big, four * big_d * b_big2 + two * b_big

    @wp.func
    def contact_energy(model: Model, q: wp.array2d(dtype=vec12), env: int):
        """dt² Σ b over the (point, half-space) pairs closer than d̂ [J·s²]; +∞ if a point is
        at or beyond a half-space's boundary."""
        energy = zero
        for i in range(model.point_body.shape[0]):
            qb = q[env, model.point_body[i]]
            for g in range(model.plane_offset.shape[0]):
                d = distance(model, qb, i, g)
                if d <= zero:
                    energy = infinity
                elif d < model.contact_d_hat:
                    b, b1, b2 = barrier(model, d)
                    energy += model.dt * model.dt * b
        return energy

    @wp.func
    def add_contact(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                    hessian: int):
        """The barrier's gradient into scratch.rhs and, with ``hessian``, its Hessian into the
        diagonal blocks. Returns the number of active pairs."""
        active = int(0)
        dt2 = model.dt * model.dt
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(model.plane_offset.shape[0]):
                d = distance(model, q[env, b], i, g)
                if d > zero and d < model.contact_d_hat:
                    active += 1
                    e, b1, b2 = barrier(model, d)
                    w = jacobian_transpose(model.point_rest[i], model.plane_normal[g])
                    scratch.rhs[env, b] -= dt2 * b1 * w
                    if hessian != 0:
                        scratch.hessian[env, b] += wp.outer(dt2 * wp.max(b2, zero) * w, w)
        return active

    @wp.func
    def step_bound(model: Model, scratch: Scratch, env: int):
        """The largest α ≤ 1 at which every point keeps at least (1 − η) of its gap's share
        along q_start + α dq: exact, since distances are linear in α."""
        alpha = one
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(model.plane_offset.shape[0]):
                d = distance(model, scratch.q_start[env, b], i, g)
                rate = wp.dot(jacobian_transpose(model.point_rest[i], model.plane_normal[g]),
                              scratch.dq[env, b])
                if rate < zero:
                    alpha = wp.min(alpha, keep * d / (-rate))
        return alpha

    @wp.func
    def touching(model: Model, q: wp.array2d(dtype=vec12), env: int):
        """(smallest distance [m] of a point to a half-space, +∞ without any; pairs closer
        than d̂) at q."""
        nearest = infinity
        active = int(0)
        for i in range(model.point_body.shape[0]):
            qb = q[env, model.point_body[i]]
            for g in range(model.plane_offset.shape[0]):
                d = distance(model, qb, i, g)
                nearest = wp.min(nearest, d)
                if d < model.contact_d_hat:
                    active += 1
        return nearest, active

    return SimpleNamespace(contact_distance=distance, barrier=barrier,
                           contact_energy=contact_energy, add_contact=add_contact,
                           step_bound=step_bound, touching=touching)
