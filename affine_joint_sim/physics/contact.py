"""Contact of free bodies with static things: half-spaces and fixed bodies' shapes (boxes,
spheres, capsules, cylinders, triangles). The IPC barrier on each pair's distance, lagged
smoothed Coulomb friction, their gradients and Hessians mapped into the body's block, the step
bound along a Newton direction, and the statistics (docs/physics.md#contact).

A pair is a contact point and a static thing, a moving edge and a static edge, or a moving
face and a static vertex (``physics.primitives``), numbered in that order (``pair_gap``). An
edge's or face's distance is that of its nearest point x̄_c (by the envelope theorem its
gradient is J(x̄_c)ᵀ n, as for a point).

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

__all__ = ['ADVANCE_STEPS', 'STEP_SLACK', 'build']

STEP_SLACK = 0.1     # η: a step along dq keeps this fraction of every shrinking gap
ADVANCE_STEPS = 64  # conservative advancement steps of an edge or face pair at most
# Warp passes a struct argument by value: a call the C++ compiler keeps out of line copies the
# whole Model (and Scratch) each time. The contact stages a step calls whatever is near are
# inlined; a box far from everything paid 0.6 µs more a step without (docs/physics.md#contact)
INLINE = True


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
    def triangle_weights(x: vec3, a: vec3, b: vec3, c: vec3):
        """The barycentric weights (of a, b, c) of the point of triangle abc nearest to x, by
        the Voronoi region x is in (a vertex, an edge or the face)."""
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
        weights = vec3(one, zero, zero)
        if d1 <= zero and d2 <= zero:
            weights = vec3(one, zero, zero)
        elif d3 >= zero and d4 <= d3:
            weights = vec3(zero, one, zero)
        elif d6 >= zero and d5 <= d6:
            weights = vec3(zero, zero, one)
        elif vc <= zero and d1 >= zero and d3 <= zero:
            s = d1 / (d1 - d3)
            weights = vec3(one - s, s, zero)
        elif vb <= zero and d2 >= zero and d6 <= zero:
            s = d2 / (d2 - d6)
            weights = vec3(one - s, zero, s)
        elif va <= zero and d4 - d3 >= zero and d5 - d6 >= zero:
            s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            weights = vec3(zero, one - s, s)
        else:
            total = va + vb + vc
            weights = vec3(va / total, vb / total, vc / total)
        return weights

    @wp.func
    def shape_separation(model: Model, x: vec3, s: int):
        """(signed distance [m] of the world point x to shape s's surface, negative inside;
        its unit outward direction n, the distance's gradient in x). A triangle (kind 5, its
        vertices the columns of shape_rotation) has no inside: its distance is ≥ 0."""
        rot = model.shape_rotation[s]
        size = model.shape_size[s]
        kind = model.shape_kind[s]
        if kind == 5:
            a = vec3(rot[0, 0], rot[1, 0], rot[2, 0])
            b = vec3(rot[0, 1], rot[1, 1], rot[2, 1])
            c = vec3(rot[0, 2], rot[1, 2], rot[2, 2])
            weights = triangle_weights(x, a, b, c)
            gap = x - (weights[0] * a + weights[1] * b + weights[2] * c)
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
    def point_pairs(model: Model):
        """Pairs of a contact point and a static thing: pair i·statics + g."""
        return model.point_body.shape[0] * statics(model)

    @wp.func
    def edge_pairs(model: Model):
        """Pairs of a moving edge and a static edge, after the point pairs."""
        return model.edge_body.shape[0] * model.static_edge_a.shape[0]

    @wp.func
    def pair_count(model: Model):
        """Every pair: point pairs, edge pairs, then (moving face, static vertex) pairs."""
        return (point_pairs(model) + edge_pairs(model)
                + model.face_body.shape[0] * model.static_vertex.shape[0])

    @wp.func
    def pair_body(model: Model, p: int):
        """The moving body of pair p."""
        body = int(0)
        if p < point_pairs(model):
            body = model.point_body[p / statics(model)]
        elif p < point_pairs(model) + edge_pairs(model):
            body = model.edge_body[(p - point_pairs(model)) / model.static_edge_a.shape[0]]
        else:
            k = p - point_pairs(model) - edge_pairs(model)
            body = model.face_body[k / model.static_vertex.shape[0]]
        return body

    @wp.func
    def segment_params(a: vec3, b: vec3, c: vec3, e: vec3):
        """(s, t) ∈ [0, 1]² of the nearest points a + s (b − a), c + t (e − c) of two segments
        (zero-length ones included; parallel ones: one nearest pair of the many)."""
        d1 = b - a
        d2 = e - c
        r = a - c
        aa = wp.dot(d1, d1)
        ee = wp.dot(d2, d2)
        f = wp.dot(d2, r)
        s = zero
        t = zero
        if aa <= zero and ee > zero:
            t = wp.clamp(f / ee, zero, one)
        elif aa > zero:
            cc = wp.dot(d1, r)
            if ee <= zero:
                s = wp.clamp(-cc / aa, zero, one)
            else:
                bb = wp.dot(d1, d2)
                denominator = aa * ee - bb * bb
                if denominator > zero:
                    s = wp.clamp((bb * f - cc * ee) / denominator, zero, one)
                t = (bb * s + f) / ee
                if t < zero:
                    t = zero
                    s = wp.clamp(-cc / aa, zero, one)
                elif t > one:
                    t = one
                    s = wp.clamp((bb - cc) / aa, zero, one)
        return s, t

    @wp.func
    def pair_gap(model: Model, q: vec12, p: int):
        """(distance d [m] of pair p with its body at state q; the unit direction n [world]
        in which it grows fastest, from the static side towards the body; the rest point
        x̄ [m] whose motion changes d, its gradient J(x̄)ᵀ n; the radius [m] of the moving
        side: the surface point that touches is x̄ − r A⁻¹ n). A point's x̄ is its own; an
        edge's the nearest point of its segment; a face's the nearest point of its triangle."""
        d = zero
        n = vec3(zero, zero, one)
        rest = vec3(zero, zero, zero)
        radius = zero
        if p < point_pairs(model):
            i = p / statics(model)
            d, n = distance(model, q, i, p - i * statics(model))
            rest = model.point_rest[i]
            radius = model.point_radius[i]
        elif p < point_pairs(model) + edge_pairs(model):
            k = p - point_pairs(model)
            e = k / model.static_edge_a.shape[0]
            s = k - e * model.static_edge_a.shape[0]
            ea = model.edge_a[e]
            eb = model.edge_b[e]
            c = model.static_edge_a[s]
            u, w = segment_params(world_point(q, ea), world_point(q, eb), c,
                                  model.static_edge_b[s])
            rest = ea + u * (eb - ea)
            gap = world_point(q, rest) - (c + w * (model.static_edge_b[s] - c))
            length = wp.length(gap)
            if length > zero:
                n = gap / length
            radius = model.edge_radius[e]
            d = length - radius - model.static_edge_radius[s]
        else:
            k = p - point_pairs(model) - edge_pairs(model)
            f = k / model.static_vertex.shape[0]
            v = k - f * model.static_vertex.shape[0]
            corners = model.face_rest[f]
            a = vec3(corners[0, 0], corners[1, 0], corners[2, 0])
            b = vec3(corners[0, 1], corners[1, 1], corners[2, 1])
            c = vec3(corners[0, 2], corners[1, 2], corners[2, 2])
            weights = triangle_weights(model.static_vertex[v], world_point(q, a),
                                       world_point(q, b), world_point(q, c))
            rest = weights[0] * a + weights[1] * b + weights[2] * c
            gap = world_point(q, rest) - model.static_vertex[v]
            length = wp.length(gap)
            if length > zero:
                n = gap / length
            d = length - model.static_vertex_radius[v]
        return d, n, rest, radius

    @wp.func
    def pair_weight(model: Model, q_n: vec12, p: int):
        """The weight of pair p's barrier for this step: 1, but for an edge pair IPC's
        near-parallel mollifier at q_n (held for the step, like friction): with
        c = |e₀ × e₁|² and ε = 10⁻³ |ē₀|² |e₁|² (rest lengths), (2 − c/ε) c/ε below ε. Two
        near-parallel edges have no single nearest pair; their ends' points and faces carry
        the contact."""
        weight = one
        if p >= point_pairs(model) and p < point_pairs(model) + edge_pairs(model):
            k = p - point_pairs(model)
            e = k / model.static_edge_a.shape[0]
            s = k - e * model.static_edge_a.shape[0]
            own = model.edge_b[e] - model.edge_a[e]
            other = model.static_edge_b[s] - model.static_edge_a[s]
            limit = scalar(1.0e-3) * wp.dot(own, own) * wp.dot(other, other)
            cross = wp.cross(affine(q_n) @ own, other)
            if wp.dot(cross, cross) < limit:
                ratio = wp.dot(cross, cross) / limit
                weight = (two - ratio) * ratio
        return weight

    @wp.func
    def listed(model: Model, scratch: Scratch, env: int):
        """How many pairs this step evaluates: the near pairs (``gather_near``)."""
        return scratch.near_count[env]

    @wp.func
    def listed_pair(model: Model, scratch: Scratch, env: int, k: int):
        """The k-th pair this step evaluates (ascending)."""
        return scratch.near_pairs[env, k]

    @wp.func
    def motion(model: Model, b: int, dq: vec12):
        """A bound [m] on how far a change dq of body b's state moves any of its contact
        points or any point of its edges and faces: |Δp| + ‖ΔA‖_F ρ (ρ: body_reach)."""
        a = affine(dq)
        frobenius = zero
        for r in range(3):
            for c in range(3):
                frobenius += a[r, c] * a[r, c]
        return (wp.length(vec3(dq[0], dq[1], dq[2]))
                + wp.sqrt(frobenius) * model.body_reach[b])

    @wp.func
    def add_near(model: Model, scratch: Scratch, env: int, p: int, reach: scalar, at: int):
        """Write pair p to near_pairs[at] if it may touch and its distance at q_n is below
        ``reach`` [m]; returns the next free index."""
        out = at
        if model.pair_on[p] != 0:
            d, n, rest, radius = pair_gap(model, scratch.q_n[env, pair_body(model, p)], p)
            if d < reach:
                scratch.near_pairs[env, at] = p
                out = at + 1
        return out

    @wp.func(inline=INLINE)
    def gather_near(model: Model, scratch: Scratch, env: int, start: int):
        """The pairs within d̂ + body_margin of their body at q_n, ascending, into
        near_pairs from index ``start``; returns how many. Edges and faces are found edge by
        edge and face by face: a pair is not evaluated where the moving side's bounding
        sphere at q_n (about its midpoint or centroid) is farther from the static edge or
        vertex."""
        at = start
        first = point_pairs(model)
        things = statics(model)
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            reach = model.contact_d_hat + scratch.body_margin[env, b]
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    d, n = distance(model, scratch.q_n[env, b], i, g)
                    if d < reach:
                        scratch.near_pairs[env, at] = i * things + g
                        at += 1
        statics_e = model.static_edge_a.shape[0]
        edges = model.edge_body.shape[0]
        for e in range(edges):
            b = model.edge_body[e]
            reach = model.contact_d_hat + scratch.body_margin[env, b]
            end_a = world_point(scratch.q_n[env, b], model.edge_a[e])
            end_b = world_point(scratch.q_n[env, b], model.edge_b[e])
            size = half * wp.length(end_b - end_a) + model.edge_radius[e]
            middle = half * (end_a + end_b)
            for s in range(statics_e):
                start_s = model.static_edge_a[s]
                along = model.static_edge_b[s] - start_s
                t = zero
                if wp.dot(along, along) > zero:
                    t = wp.clamp(wp.dot(middle - start_s, along) / wp.dot(along, along), zero,
                                 one)
                apart = (wp.length(middle - start_s - t * along) - size
                         - model.static_edge_radius[s])
                if apart < reach:
                    at = add_near(model, scratch, env, first + e * statics_e + s, reach, at)
        statics_v = model.static_vertex.shape[0]
        for f in range(model.face_body.shape[0]):
            b = model.face_body[f]
            reach = model.contact_d_hat + scratch.body_margin[env, b]
            corners = model.face_rest[f]
            c0 = world_point(scratch.q_n[env, b], vec3(corners[0, 0], corners[1, 0],
                                                       corners[2, 0]))
            c1 = world_point(scratch.q_n[env, b], vec3(corners[0, 1], corners[1, 1],
                                                       corners[2, 1]))
            c2 = world_point(scratch.q_n[env, b], vec3(corners[0, 2], corners[1, 2],
                                                       corners[2, 2]))
            centre = (c0 + c1 + c2) / three
            size = wp.max(wp.length(c0 - centre), wp.max(wp.length(c1 - centre),
                                                         wp.length(c2 - centre)))
            for v in range(statics_v):
                apart = (wp.length(centre - model.static_vertex[v]) - size
                         - model.static_vertex_radius[v])
                if apart < reach:
                    at = add_near(model, scratch, env,
                                  first + edges * statics_e + f * statics_v + v, reach, at)
        return at - start

    @wp.func(inline=INLINE)
    def cover(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
              along: int):
        """Keep every pair not listed beyond d̂ at q, or with ``along`` on the whole path
        q + α dq, α ∈ [0, 1] (dq: scratch.dq): a body whose points, edges and faces may be
        farther from where they were at q_n than its margin (``motion`` of q − q_n, plus of
        dq along the path) gets twice that margin, and near_pairs is gathered again."""
        if pair_count(model) > 0:
            wider = int(0)
            for k in range(model.elim_order.shape[0]):
                b = model.elim_order[k]
                reach = motion(model, b, q[env, b] - scratch.q_n[env, b])
                if along != 0:
                    reach += motion(model, b, scratch.dq[env, b])
                if reach > scratch.body_margin[env, b]:
                    scratch.body_margin[env, b] = two * reach
                    wider = 1
            if wider != 0:
                scratch.near_count[env] = gather_near(model, scratch, env, 0)

    @wp.func
    def pair_on(model: Model, p: int):
        """Whether pair p may touch (see the model's pair_on)."""
        return model.pair_on[p] != 0

    @wp.func
    def tangent_of(n: vec3):
        """t₁ of a friction basis for normal n: x̂ × n normalized (ẑ × n where n is within
        about 26° of x̂), as contact_model._tangent gives a half-space."""
        axis = vec3(one, zero, zero)
        if wp.abs(n[0]) > scalar(0.9):
            axis = vec3(zero, zero, one)
        return wp.normalize(wp.cross(axis, n))

    @wp.func
    def pair_tangent(model: Model, p: int, n: vec3):
        """t₁ of pair p's friction basis: a half-space's own, else ``tangent_of`` n."""
        t1 = tangent_of(n)
        things = statics(model)
        if p < point_pairs(model):
            g = p - (p / things) * things
            if g < model.plane_offset.shape[0]:
                t1 = model.plane_tangent[g]
        return t1

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
    def touch_rest(q_n: vec12, rest: vec3, radius: scalar, n: vec3):
        """x̄_c: the rest position of the material point that touches, x̄ − r A_n⁻¹ n (a
        sphere's or capsule's surface point, r below its centre; x̄ for a vertex)."""
        out = rest
        if radius > zero:
            out = rest - radius * (wp.inverse(affine(q_n)) @ n)
        return out

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
    def retire(scratch: Scratch, env: int, old: int, fresh: int):
        """Zero the lagged forces of the pairs in near_pairs[0, old) that are not in
        near_pairs[old, old + fresh) (both ascending), then move the fresh list to the front:
        only listed pairs ever hold lagged forces."""
        k = int(old)
        for j in range(old):
            p = scratch.near_pairs[env, j]
            while k < old + fresh and scratch.near_pairs[env, k] < p:
                k += 1
            if k >= old + fresh or scratch.near_pairs[env, k] != p:
                scratch.friction_normal[env, p] = zero
                scratch.normal_damping[env, p] = zero
        for j in range(fresh):
            scratch.near_pairs[env, j] = scratch.near_pairs[env, old + j]
        scratch.near_count[env] = fresh

    @wp.func(inline=INLINE)
    def lag_friction(model: Model, state: State, scratch: Scratch, env: int):
        """Gathers this step's near pairs (margins of twice each body's predicted ``motion``,
        at least d̂), then per pair closer than d̂ at q_n, frozen for the step: the normal
        force dt² λ into scratch.friction_normal (friction's weight: the barrier's
        −dt² db/dd plus the last step's damping force c (d_{n−1} − d_n)/dt while the pair
        was approaching, at most as much again as the barrier's: friction sees the load the
        damper carries while it settles, not an impact's spike) and the contact damping
        c·dt = 2ζ √(b''(d) m_eff) dt into scratch.normal_damping (0 for the others); an edge
        pair's mollifier weighs both."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            scratch.body_margin[env, b] = wp.max(model.contact_d_hat, two * motion(
                model, b, scratch.q_tilde[env, b] - scratch.q_n[env, b]))
        old = scratch.near_count[env]
        fresh = gather_near(model, scratch, env, old)
        for k in range(old, old + fresh):
            p = scratch.near_pairs[env, k]
            b = pair_body(model, p)
            qb = scratch.q_n[env, b]
            force = zero
            damping = zero
            last_damping = scratch.normal_damping[env, p]
            d, n, rest, radius = pair_gap(model, qb, p)
            if d > zero and d < model.contact_d_hat:
                e, b1, b2 = barrier(model, d)
                weight = pair_weight(model, qb, p)
                force = -model.dt * model.dt * weight * b1
                if last_damping > zero:
                    d_prev, n_prev, rest_prev, r_prev = pair_gap(
                        model, state.q_prev[env, b], p)
                    force += wp.min(last_damping * wp.max(d_prev - d, zero), force)
                if model.contact_damping > zero:
                    mass = point_mass(model, b, qb, touch_rest(qb, rest, radius, n), n)
                    damping = (two * model.contact_damping
                               * wp.sqrt(wp.max(weight * b2, zero) * mass) * model.dt)
            scratch.friction_normal[env, p] = force
            scratch.normal_damping[env, p] = damping
        retire(scratch, env, old, fresh)

    @wp.func
    def approach(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 p: int):
        """(min(d(q) − d(q_n), 0) [m]: how far pair p closed since the step's start, 0 while
        it separates; its normal n and rest point x̄ at q)."""
        b = pair_body(model, p)
        d, n, rest, radius = pair_gap(model, q[env, b], p)
        d_n, n_n, rest_n, radius_n = pair_gap(model, scratch.q_n[env, b], p)
        return wp.min(d - d_n, zero), n, rest

    @wp.func
    def damping_energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                       env: int):
        """Σ ½ c dt min(d(q) − d(q_n), 0)² over the pairs with lagged damping [J·s²]: a
        viscous force −c ḋ against each contact's approach (ḋ ≈ (d − d_n)/dt < 0), none
        while it separates (a damper that pulled would hold a lifting foot down)."""
        energy = zero
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            weight = scratch.normal_damping[env, p]
            if weight > zero:
                closed, n, rest = approach(model, q, scratch, env, p)
                energy += half * weight * closed * closed
        return energy

    @wp.func
    def add_damping(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                    hessian: int):
        """Contact damping's gradient c dt min(d − d_n, 0) w into scratch.rhs and, while the
        pair approaches, c dt w wᵀ (w = J(x̄)ᵀ n; a shape's curvature left out, as for the
        barrier)."""
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            weight = scratch.normal_damping[env, p]
            if weight > zero:
                closed, n, rest = approach(model, q, scratch, env, p)
                if closed < zero:
                    b = pair_body(model, p)
                    w = jacobian_transpose(rest, n)
                    scratch.rhs[env, b] -= weight * closed * w
                    if hessian != 0:
                        scratch.hessian[env, b] += wp.outer(weight * w, w)

    @wp.func
    def slip(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, p: int):
        """(u₁, u₂, w₁, w₂): the tangential displacement [m] since the start of the step, along
        pair p's friction basis (t₁, t₂ = n × t₁) lagged at q_n, of the material point that
        touches (``touch_rest`` at q_n: a sphere's or capsule's surface point, so friction
        turns it), and its gradients J(x̄_c)ᵀ t."""
        b = pair_body(model, p)
        d, n, rest, radius = pair_gap(model, scratch.q_n[env, b], p)
        rest = touch_rest(scratch.q_n[env, b], rest, radius, n)
        moved = world_point(q[env, b], rest) - world_point(scratch.q_n[env, b], rest)
        t1 = pair_tangent(model, p, n)
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
        eps = model.contact_eps_velocity * model.dt
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            force = scratch.friction_normal[env, p]
            if force > zero:
                u1, u2, w1, w2 = slip(model, q, scratch, env, p)
                f0, f1_over_y = smooth_friction(wp.sqrt(u1 * u1 + u2 * u2), eps)
                energy += model.pair_friction[p] * force * f0
        return energy

    @wp.func
    def add_friction(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                     hessian: int):
        """Friction's gradient into scratch.rhs and, with ``hessian``, its PSD Hessian
        (IPC's closed forms in the tangent plane, mapped by W = [J̄ᵀt₁, J̄ᵀt₂]) into the
        diagonal blocks. Returns the number of pairs with friction."""
        eps = model.contact_eps_velocity * model.dt
        count = int(0)
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            weight = model.pair_friction[p] * scratch.friction_normal[env, p]
            if weight > zero:
                b = pair_body(model, p)
                count += 1
                u1, u2, w1, w2 = slip(model, q, scratch, env, p)
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
    def contact_energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int):
        """dt² Σ m b over the pairs closer than d̂ (m: ``pair_weight``) [J·s²]; +∞ if a pair
        is at or beyond the boundary."""
        energy = zero
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            if pair_on(model, p):
                b = pair_body(model, p)
                d, n, rest, radius = pair_gap(model, q[env, b], p)
                if d <= zero:
                    energy = infinity
                elif d < model.contact_d_hat:
                    e, b1, b2 = barrier(model, d)
                    weight = pair_weight(model, scratch.q_n[env, b], p)
                    energy += model.dt * model.dt * weight * e
        return energy

    @wp.func
    def add_contact(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                    hessian: int):
        """The barrier's gradient into scratch.rhs and, with ``hessian``, its Hessian into the
        diagonal blocks. Returns the number of active pairs."""
        active = int(0)
        dt2 = model.dt * model.dt
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            if pair_on(model, p):
                b = pair_body(model, p)
                d, n, rest, radius = pair_gap(model, q[env, b], p)
                if d > zero and d < model.contact_d_hat:
                    active += 1
                    e, b1, b2 = barrier(model, d)
                    weight = dt2 * pair_weight(model, scratch.q_n[env, b], p)
                    w = jacobian_transpose(rest, n)
                    scratch.rhs[env, b] -= weight * b1 * w
                    if hessian != 0:
                        scratch.hessian[env, b] += wp.outer(weight * wp.max(b2, zero) * w, w)
        return active

    @wp.func
    def reach(model: Model, dq: vec12, p: int):
        """The most [m] any point of pair p's moving edge or face moves under dq: the largest
        of its corners' |J(x̄) dq| (a segment's or triangle's points are their corners'
        convex combinations)."""
        k = p - point_pairs(model)
        most = zero
        if k < edge_pairs(model):
            e = k / model.static_edge_a.shape[0]
            most = wp.max(wp.length(world_point(dq, model.edge_a[e])),
                          wp.length(world_point(dq, model.edge_b[e])))
        else:
            corners = model.face_rest[(k - edge_pairs(model)) / model.static_vertex.shape[0]]
            for c in range(3):
                moved = world_point(dq, vec3(corners[0, c], corners[1, c], corners[2, c]))
                most = wp.max(most, wp.length(moved))
        return most

    @wp.func
    def advance_bound(model: Model, scratch: Scratch, env: int, p: int, b: int):
        """Conservative advancement along q_start + α dq for an edge or face pair: its
        distance changes at most ``reach`` per unit α, so from a distance d at α it keeps
        η d₀ up to α + (d − η d₀)/reach; repeated until the gap is within 2 η d₀ (the first
        time it would close), α = 1, or ``ADVANCE_STEPS`` steps."""
        d, n, rest, radius = pair_gap(model, scratch.q_start[env, b], p)
        rate = reach(model, scratch.dq[env, b], p)
        alpha = one
        if d <= zero:
            alpha = zero
        elif rate > keep * d:
            floor = (one - keep) * d
            alpha = zero
            for k in range(ADVANCE_STEPS):
                alpha = wp.min(alpha + (d - floor) / rate, one)
                if alpha < one:
                    d, n, rest, radius = pair_gap(
                        model, scratch.q_start[env, b] + alpha * scratch.dq[env, b], p)
                    if d <= two * floor:
                        break
                else:
                    break
        return alpha

    @wp.func(inline=INLINE)
    def step_bound(model: Model, scratch: Scratch, env: int):
        """The largest α ≤ 1 at which every pair keeps at least η of its gap along
        q_start + α dq: a point moves on a straight line, its distance to a half-space is
        linear in α and to a convex shape convex, so the tangent at α = 0 is a lower bound
        (exact for half-spaces, conservative for shapes); an edge's or face's distance is
        neither, and advances conservatively (``advance_bound``); the pairs not listed stay
        beyond d̂ (``cover``)."""
        cover(model, scratch.q_start, scratch, env, 1)
        alpha = one
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            if pair_on(model, p):
                b = pair_body(model, p)
                if p < point_pairs(model):
                    d, n, rest, radius = pair_gap(model, scratch.q_start[env, b], p)
                    rate = wp.dot(jacobian_transpose(rest, n), scratch.dq[env, b])
                    if rate < zero:
                        alpha = wp.min(alpha, keep * d / (-rate))
                else:
                    alpha = wp.min(alpha, advance_bound(model, scratch, env, p, b))
        return alpha

    @wp.func(inline=INLINE)
    def touching(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 every_point: int):
        """(smallest distance [m] of a pair that may touch, +∞ without any; pairs closer than
        d̂) at q, over the listed pairs (the others are beyond d̂), or with ``every_point``
        over every point pair and the listed edge and face pairs (the statistics)."""
        nearest = infinity
        active = int(0)
        start = int(0)
        if every_point != 0:
            for p in range(point_pairs(model)):
                if model.pair_on[p] != 0:
                    d, n, rest, radius = pair_gap(model, q[env, pair_body(model, p)], p)
                    nearest = wp.min(nearest, d)
                    if d < model.contact_d_hat:
                        active += 1
            while start < listed(model, scratch, env) and listed_pair(
                    model, scratch, env, start) < point_pairs(model):
                start += 1
        for k in range(start, listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            d, n, rest, radius = pair_gap(model, q[env, pair_body(model, p)], p)
            nearest = wp.min(nearest, d)
            if d < model.contact_d_hat:
                active += 1
        return nearest, active

    return SimpleNamespace(contact_distance=distance, barrier=barrier, cover=cover,
                           gather_near=gather_near,
                           lag_friction=lag_friction, friction_energy=friction_energy,
                           add_friction=add_friction, damping_energy=damping_energy,
                           add_damping=add_damping,
                           contact_energy=contact_energy, add_contact=add_contact,
                           step_bound=step_bound, touching=touching)
