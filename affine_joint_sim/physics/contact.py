"""Contact of free bodies with static things: half-spaces and fixed bodies' shapes (boxes,
spheres, capsules, cylinders). The IPC barrier on each contact point's distance, lagged
smoothed Coulomb friction, their gradients and Hessians mapped into the body's block, the step
bound along a Newton direction, and the statistics (docs/physics.md#contact).

Static thing g is half-space g for g < planes, else shape g − planes. The distance of point i
to half-space g is d = n·(p + A x̄) − h − r, linear in the body's q with gradient
w = J(x̄)ᵀ n; to a shape it is the exact distance of x = p + A x̄ to the convex shape, less r,
with gradient J(x̄)ᵀ n for n its unit outward direction at x. The barrier (libuipc's form on
D = d², D̂ = d̂²) b(D) = −κ (D − D̂)² ln(D / D̂) for 0 < d < d̂ (zero beyond) enters the
incremental potential as dt² b; as a function of d it is convex on (0, d̂), so dt² b''(d) w wᵀ
is PSD (clamped at 0 against rounding): the whole Hessian against a half-space; against a
shape its curvature term b'(d) ∇²d (negative semidefinite: b' < 0, and the distance to a convex
set is convex) is left out, the Gauss–Newton part of IPC's PSD projection. Either adds to one
diagonal block only: the tree solve stays exact. Every loop is skipped in a scene without
contact (model.has_contact = 0), and a pair that may not touch (pair_on 0) everywhere.
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['STEP_SLACK', 'build']

STEP_SLACK = 0.1     # η: a step along dq keeps this fraction of every shrinking gap


def build(t) -> SimpleNamespace:
    """Warp functions of contact for the types namespace ``t``."""
    vec3, vec12, scalar = t.vec3, t.vec12, t.scalar
    zero, half, one, two, three, four = t.zero, t.half, t.one, t.two, t.three, t.four
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    world_point, jacobian_transpose, log = t.world_point, t.jacobian_transpose, t.log
    affine = t.affine
    keep = scalar(1.0 - STEP_SLACK)
    infinity = scalar(float('inf'))

    @wp.func
    def sign_of(x: scalar):
        """+1 for x ≥ 0, else −1."""
        out = one
        if x < zero:
            out = -one
        return out

    @wp.func
    def closest_on_triangle(x: vec3, a: vec3, b: vec3, c: vec3):
        """The point of triangle abc nearest to x [m] (by the Voronoi region x is in: a
        vertex, an edge or the face)."""
        ab = b - a
        ac = c - a
        d1 = wp.dot(ab, x - a)
        d2 = wp.dot(ac, x - a)
        d3 = wp.dot(ab, x - b)
        d4 = wp.dot(ac, x - b)
        d5 = wp.dot(ab, x - c)
        d6 = wp.dot(ac, x - c)
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        nearest = a
        if d1 <= zero and d2 <= zero:
            nearest = a
        elif d3 >= zero and d4 <= d3:
            nearest = b
        elif d6 >= zero and d5 <= d6:
            nearest = c
        elif vc <= zero and d1 >= zero and d3 <= zero:
            nearest = a + (d1 / (d1 - d3)) * ab
        elif vb <= zero and d2 >= zero and d6 <= zero:
            nearest = a + (d2 / (d2 - d6)) * ac
        elif va <= zero and d4 - d3 >= zero and d5 - d6 >= zero:
            nearest = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)
        else:
            total = va + vb + vc
            nearest = a + (vb / total) * ab + (vc / total) * ac
        return nearest

    @wp.func
    def shape_separation(model: Model, x: vec3, s: int):
        """(signed distance [m] of the world point x to shape s's surface, negative inside;
        its unit outward direction n, the distance's gradient in x). A triangle (kind 5, its
        vertices the columns of shape_rotation) has no inside: its distance is ≥ 0."""
        rot = model.shape_rotation[s]
        size = model.shape_size[s]
        kind = model.shape_kind[s]
        if kind == 5:
            gap = x - closest_on_triangle(x, vec3(rot[0, 0], rot[1, 0], rot[2, 0]),
                                          vec3(rot[0, 1], rot[1, 1], rot[2, 1]),
                                          vec3(rot[0, 2], rot[1, 2], rot[2, 2]))
            length = wp.length(gap)
            away = vec3(zero, zero, one)
            if length > zero:
                away = gap / length
            return length, away
        local = wp.transpose(rot) @ (x - model.shape_center[s])
        d = zero
        n = vec3(zero, zero, one)
        if kind == 1:               # box: the clamped excess over its half sides
            e = vec3(wp.max(wp.abs(local[0]) - size[0], zero),
                     wp.max(wp.abs(local[1]) - size[1], zero),
                     wp.max(wp.abs(local[2]) - size[2], zero))
            d = wp.length(e)
            if d > zero:
                n = vec3(sign_of(local[0]) * e[0], sign_of(local[1]) * e[1],
                         sign_of(local[2]) * e[2]) / d
            else:                   # inside: the nearest face
                d = wp.abs(local[0]) - size[0]
                n = vec3(sign_of(local[0]), zero, zero)
                if wp.abs(local[1]) - size[1] > d:
                    d = wp.abs(local[1]) - size[1]
                    n = vec3(zero, sign_of(local[1]), zero)
                if wp.abs(local[2]) - size[2] > d:
                    d = wp.abs(local[2]) - size[2]
                    n = vec3(zero, zero, sign_of(local[2]))
        elif kind == 4:             # cylinder along z: radial and axial excess
            radial = wp.sqrt(local[0] * local[0] + local[1] * local[1])
            out = vec3(one, zero, zero)
            if radial > zero:
                out = vec3(local[0] / radial, local[1] / radial, zero)
            dr = radial - size[0]
            dz = wp.abs(local[2]) - size[1]
            up = vec3(zero, zero, sign_of(local[2]))
            if dr > zero and dz > zero:
                d = wp.sqrt(dr * dr + dz * dz)
                n = (dr * out + dz * up) / d
            elif dr > dz:
                d = dr
                n = out
            else:
                d = dz
                n = up
        else:                       # sphere (2), capsule (3): from the nearest axis point
            nearest = vec3(zero, zero, zero)
            if kind == 3:
                nearest = vec3(zero, zero, wp.clamp(local[2], -size[1], size[1]))
            gap = local - nearest
            length = wp.length(gap)
            if length > zero:
                n = gap / length
            d = length - size[0]
        return d, rot @ n

    @wp.func
    def distance(model: Model, q: vec12, i: int, g: int):
        """(distance [m] of contact point i, on a body at state q, to static thing g; the unit
        direction n in which it grows fastest)."""
        x = world_point(q, model.point_rest[i])
        planes = model.plane_offset.shape[0]
        if g < planes:
            return (wp.dot(model.plane_normal[g], x) - model.plane_offset[g]
                    - model.point_radius[i]), model.plane_normal[g]
        d, n = shape_separation(model, x, g - planes)
        return d - model.point_radius[i], n

    @wp.func
    def statics(model: Model):
        """Static things: half-spaces, then shapes."""
        return model.plane_offset.shape[0] + model.shape_kind.shape[0]

    @wp.func
    def tangent_of(n: vec3):
        """t₁ of a friction basis for normal n: x̂ × n normalized (ẑ × n where n is within
        about 26° of x̂), as contact_model._tangent gives a half-space."""
        axis = vec3(one, zero, zero)
        if wp.abs(n[0]) > scalar(0.9):
            axis = vec3(zero, zero, one)
        return wp.normalize(wp.cross(axis, n))

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
    def contact_rest(model: Model, q_n: vec12, i: int, n: vec3):
        """x̄_c: the rest position of the material point where point i touches (x̄ − r A_n⁻¹ n:
        a sphere's or capsule's surface point, r below its centre; x̄ for a vertex)."""
        rest = model.point_rest[i]
        radius = model.point_radius[i]
        if radius > zero:
            rest = rest - radius * (wp.inverse(affine(q_n)) @ n)
        return rest

    @wp.func
    def point_mass(model: Model, b: int, q_n: vec12, rest: vec3, n: vec3):
        """m_eff [kg] of body b at rest point x̄ along the world normal n, as a rigid body:
        1 / (1/m + (x̄ × n_b)ᵀ I⁻¹ (x̄ × n_b)), n_b = A_nᵀ n, I the body's principal moments."""
        s = model.body_second_moment[b]
        lever = wp.cross(rest, wp.transpose(affine(q_n)) @ n)
        inverse = one / model.body_mass[b]
        inverse += lever[0] * lever[0] / (s[1] + s[2]) + lever[1] * lever[1] / (s[0] + s[2])
        inverse += lever[2] * lever[2] / (s[0] + s[1])
        return one / inverse

    @wp.func
    def lag_friction(model: Model, state: State, scratch: Scratch, env: int):
        """Per pair closer than d̂ at q_n, frozen for the step: the normal force dt² λ into
        scratch.friction_normal (friction's weight: the barrier's −dt² db/dd plus the last
        step's damping force c (d_{n−1} − d_n)/dt while the pair was approaching, at most as
        much again as the barrier's: friction sees the load the damper carries while it
        settles, not an impact's spike) and the contact damping c·dt = 2ζ √(b''(d) m_eff) dt
        into scratch.normal_damping (0 for the others)."""
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            qb = scratch.q_n[env, b]
            for g in range(things):
                force = zero
                damping = zero
                last_damping = scratch.normal_damping[env, i * things + g]
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, qb, i, g)
                    if d > zero and d < model.contact_d_hat:
                        e, b1, b2 = barrier(model, d)
                        force = -model.dt * model.dt * b1
                        if last_damping > zero:
                            d_prev, n_prev = distance(model, state.q_prev[env, b], i, g)
                            force += wp.min(last_damping * wp.max(d_prev - d, zero), force)
                        if model.contact_damping > zero:
                            mass = point_mass(model, b, qb, contact_rest(model, qb, i, n), n)
                            damping = (two * model.contact_damping
                                       * wp.sqrt(wp.max(b2, zero) * mass) * model.dt)
                scratch.friction_normal[env, i * things + g] = force
                scratch.normal_damping[env, i * things + g] = damping

    @wp.func
    def approach(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 i: int, g: int):
        """(min(d(q) − d(q_n), 0) [m]: how far pair (i, g) closed since the step's start,
        0 while it separates; its normal n at q)."""
        d, n = distance(model, q[env, model.point_body[i]], i, g)
        d_n, n_n = distance(model, scratch.q_n[env, model.point_body[i]], i, g)
        return wp.min(d - d_n, zero), n

    @wp.func
    def damping_energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                       env: int):
        """Σ ½ c dt min(d(q) − d(q_n), 0)² over the pairs with lagged damping [J·s²]: a
        viscous force −c ḋ against each contact's approach (ḋ ≈ (d − d_n)/dt < 0), none
        while it separates (a damper that pulled would hold a lifting foot down)."""
        energy = zero
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            for g in range(things):
                weight = scratch.normal_damping[env, i * things + g]
                if weight > zero:
                    closed, n = approach(model, q, scratch, env, i, g)
                    energy += half * weight * closed * closed
        return energy

    @wp.func
    def add_damping(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                    hessian: int):
        """Contact damping's gradient c dt min(d − d_n, 0) w into scratch.rhs and, while the
        pair approaches, c dt w wᵀ (w = J(x̄)ᵀ n; a shape's curvature left out, as for the
        barrier)."""
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(things):
                weight = scratch.normal_damping[env, i * things + g]
                if weight > zero:
                    closed, n = approach(model, q, scratch, env, i, g)
                    if closed < zero:
                        w = jacobian_transpose(model.point_rest[i], n)
                        scratch.rhs[env, b] -= weight * closed * w
                        if hessian != 0:
                            scratch.hessian[env, b] += wp.outer(weight * w, w)

    @wp.func
    def slip(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, i: int,
             g: int):
        """(u₁, u₂, w₁, w₂): the tangential displacement [m] since the start of the step, along
        the friction basis (t₁, t₂ = n × t₁) of static thing g lagged at q_n (a half-space's
        own; a shape's from its normal at q_n), of the material point where point i touches
        (x̄ − r A_n⁻¹ n: a sphere's or capsule's surface point, so friction turns it), and
        its gradients J(x̄_c)ᵀ t."""
        b = model.point_body[i]
        d, n = distance(model, scratch.q_n[env, b], i, g)
        rest = contact_rest(model, scratch.q_n[env, b], i, n)
        moved = world_point(q[env, b], rest) - world_point(scratch.q_n[env, b], rest)
        t1 = tangent_of(n)
        if g < model.plane_offset.shape[0]:
            t1 = model.plane_tangent[g]
        t2 = wp.cross(n, t1)
        return (wp.dot(t1, moved), wp.dot(t2, moved), jacobian_transpose(rest, t1),
                jacobian_transpose(rest, t2))

    @wp.func
    def smooth_friction(y: scalar, eps: scalar):
        """(f0(y), f1(y)/y) of IPC's smoothed Coulomb friction at slip y ≥ 0 [m] with the
        slip threshold eps = ε_v dt [m]: f0 = y beyond eps, y²/eps − y³/(3 eps²) + eps/3
        below (C¹ at eps)."""
        f0 = y
        f1_over_y = zero
        if y >= eps:
            f1_over_y = one / y
        else:
            f0 = y * y / eps - y * y * y / (three * eps * eps) + eps / three
            f1_over_y = (two * eps - y) / (eps * eps)
        return f0, f1_over_y

    @wp.func
    def friction_energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                        env: int):
        """Σ μ dt²λ f0(|u|) over the pairs with a lagged normal force [J·s²]."""
        energy = zero
        things = statics(model)
        eps = model.contact_eps_velocity * model.dt
        for i in range(model.point_body.shape[0]):
            for g in range(things):
                pair = i * things + g
                force = scratch.friction_normal[env, pair]
                if force > zero:
                    u1, u2, w1, w2 = slip(model, q, scratch, env, i, g)
                    f0, f1_over_y = smooth_friction(wp.sqrt(u1 * u1 + u2 * u2), eps)
                    energy += model.pair_friction[pair] * force * f0
        return energy

    @wp.func
    def add_friction(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                     hessian: int):
        """Friction's gradient into scratch.rhs and, with ``hessian``, its PSD Hessian
        (IPC's closed forms in the tangent plane, mapped by W = [J̄ᵀt₁, J̄ᵀt₂]) into the
        diagonal blocks. Returns the number of pairs with friction."""
        things = statics(model)
        eps = model.contact_eps_velocity * model.dt
        count = int(0)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(things):
                pair = i * things + g
                weight = model.pair_friction[pair] * scratch.friction_normal[env, pair]
                if weight > zero:
                    count += 1
                    u1, u2, w1, w2 = slip(model, q, scratch, env, i, g)
                    y = wp.sqrt(u1 * u1 + u2 * u2)
                    f0, f1_over_y = smooth_friction(y, eps)
                    scratch.rhs[env, b] -= weight * f1_over_y * (u1 * w1 + u2 * w2)
                    if hessian != 0:
                        h11 = weight * f1_over_y
                        h22 = h11
                        h12 = zero
                        if y >= eps:            # μλ/y³ ū ūᵀ, ū = (−u₂, u₁)
                            c = weight / (y * y * y)
                            h11 = c * u2 * u2
                            h22 = c * u1 * u1
                            h12 = -c * u1 * u2
                        elif y > zero:          # μλ [(f1/y) I − u uᵀ / (eps² y)]
                            c = weight / (eps * eps * y)
                            h11 -= c * u1 * u1
                            h22 -= c * u2 * u2
                            h12 = -c * u1 * u2
                        scratch.hessian[env, b] += (wp.outer(h11 * w1 + h12 * w2, w1)
                                                    + wp.outer(h12 * w1 + h22 * w2, w2))
        return count

    @wp.func
    def contact_energy(model: Model, q: wp.array2d(dtype=vec12), env: int):
        """dt² Σ b over the pairs closer than d̂ [J·s²]; +∞ if a point is at or beyond a
        static thing's boundary."""
        energy = zero
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            qb = q[env, model.point_body[i]]
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, qb, i, g)
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
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, q[env, b], i, g)
                    if d > zero and d < model.contact_d_hat:
                        active += 1
                        e, b1, b2 = barrier(model, d)
                        w = jacobian_transpose(model.point_rest[i], n)
                        scratch.rhs[env, b] -= dt2 * b1 * w
                        if hessian != 0:
                            scratch.hessian[env, b] += wp.outer(dt2 * wp.max(b2, zero) * w, w)
        return active

    @wp.func
    def step_bound(model: Model, scratch: Scratch, env: int):
        """The largest α ≤ 1 at which every point keeps at least η of its gap along
        q_start + α dq: each point moves on a straight line, its distance to a half-space is
        linear in α and to a convex shape convex, so the tangent at α = 0 is a lower bound
        (exact for half-spaces, conservative for shapes)."""
        alpha = one
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, scratch.q_start[env, b], i, g)
                    rate = wp.dot(jacobian_transpose(model.point_rest[i], n),
                                  scratch.dq[env, b])
                    if rate < zero:
                        alpha = wp.min(alpha, keep * d / (-rate))
        return alpha

    @wp.func
    def touching(model: Model, q: wp.array2d(dtype=vec12), env: int):
        """(smallest distance [m] of a point to a static thing it may touch, +∞ without any;
        pairs closer than d̂) at q."""
        nearest = infinity
        active = int(0)
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            qb = q[env, model.point_body[i]]
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, qb, i, g)
                    nearest = wp.min(nearest, d)
                    if d < model.contact_d_hat:
                        active += 1
        return nearest, active

    return SimpleNamespace(contact_distance=distance, barrier=barrier,
                           lag_friction=lag_friction, friction_energy=friction_energy,
                           add_friction=add_friction, damping_energy=damping_energy,
                           add_damping=add_damping,
                           contact_energy=contact_energy, add_contact=add_contact,
                           step_bound=step_bound, touching=touching)
