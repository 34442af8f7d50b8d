"""Contact geometry in the step kernel: how pairs are numbered, and each pair's distance,
normal and nearest points at any state (docs/physics.md#contact).

A pair is a contact point and a static thing, a moving edge and a static edge, a moving face
and a static vertex (the static pairs, numbered in that order and in model.pair_on), then the
pairs of bodies that may touch each other, from static_pairs + touch_first[j] for the j-th
pair of bodies (a, b): the points of a against the faces of b, the points of b against the
faces of a, the edges of a against the edges of b, each block row by row (``body_pair``).
Every distance is that of the nearest points of the two sides, so by the
envelope theorem its gradient is J(x̄)ᵀ n for the first side's nearest rest point x̄ and
−J(ȳ)ᵀ n for the other's ȳ, n the unit normal from the other side towards the first.

Static thing g is half-space g for g < planes, else shape g − planes. The distance of point i
to half-space g is d = n·(p + A x̄) − h − r; to a shape it is the exact distance of
x = p + A x̄ to the convex shape, less r.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart
from affine_joint_sim.physics.contact.kinds import (BOX, CAPSULE, CYLINDER, EDGE_EDGE,
                                                    POINT_FACE, TOUCH_CHUNK, TRIANGLE)

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of contact geometry for the types namespace ``t``."""
    vec3, vec12, mat33, scalar = t.vec3, t.vec12, t.mat33, t.scalar
    zero, one, two = t.zero, t.one, t.two
    Model = t.structs.Model
    world_point, affine = t.world_point, t.affine
    bodies = t.bodies       # pairs of moving bodies compiled in (kernels.step_kernels)
    shapes = t.shapes       # static shapes, meshes, their edges and vertices compiled in
    box, capsule, cylinder, triangle = BOX.code, CAPSULE.code, CYLINDER.code, TRIANGLE.code
    point_face, edge_edge = POINT_FACE.code, EDGE_EDGE.code
    touch_chunk = TOUCH_CHUNK

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
        its unit outward direction n, the distance's gradient in x). A triangle (its vertices
        the columns of shape_rotation) has no inside: its distance is ≥ 0; a sphere's and a
        capsule's is that from their axis segment (any other kind is taken as a sphere)."""
        rot = model.shape_rotation[s]
        size = model.shape_size[s]
        kind = model.shape_kind[s]
        if kind == triangle:
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
        if kind == box:             # the clamped excess over its half sides
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
        elif kind == cylinder:      # along z: radial and axial excess
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
        else:                       # sphere, capsule: from the nearest axis point
            nearest = vec3(zero, zero, zero)
            if kind == capsule:
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
        if wp.static(shapes):
            if g >= planes:
                d, n = shape_separation(model, x, g - planes)
                return d - model.point_radius[i], n
        return (wp.dot(model.plane_normal[g], x) - model.plane_offset[g]
                - model.point_radius[i]), model.plane_normal[g]

    @wp.func(inline=True)
    def statics(model: Model):
        """Static things: half-spaces, then shapes."""
        return model.plane_offset.shape[0] + model.shape_kind.shape[0]

    @wp.func(inline=True)
    def point_pairs(model: Model):
        """Pairs of a contact point and a static thing: pair i·statics + g."""
        return model.point_body.shape[0] * statics(model)

    @wp.func(inline=True)
    def edge_pairs(model: Model):
        """Pairs of a moving edge and a static edge, after the point pairs."""
        return model.edge_body.shape[0] * model.static_edge_a.shape[0]

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

    @wp.func(inline=True)
    def static_pairs(model: Model):
        """Pairs with a static side: point pairs, edge pairs, then (moving face, static
        vertex) pairs."""
        return model.pair_on.shape[0]

    @wp.func(inline=True)
    def pair_count(model: Model):
        """Every pair numbered: the static ones, then those of pairs of bodies."""
        return static_pairs(model) + model.touch_first[model.touch_a.shape[0]]

    @wp.func
    def block_item(first: int, other: int, others: int, k: int):
        """(first + k / others, other + k % others): the k-th pair of a block numbered row by
        row, ``others`` to a row."""
        row = k / others
        return first + row, other + k - row * others

    @wp.func
    def body_pair(model: Model, p: int):
        """(family code, contact.kinds.BODY_FAMILIES; the first side's point or edge; the
        other side's face or edge) of pair p, one of a pair of bodies."""
        k = p - static_pairs(model)
        low = model.touch_chunk[k / touch_chunk]    # touch_first[low] ≤ k
        while model.touch_first[low + 1] <= k:
            low += 1
        a = model.touch_a[low]
        b = model.touch_b[low]
        k = k - model.touch_first[low]
        family = int(point_face)
        points_a = model.body_first_point[a + 1] - model.body_first_point[a]
        faces_b = model.body_first_face[b + 1] - model.body_first_face[b]
        first = int(0)
        other = int(0)
        if k < points_a * faces_b:
            first, other = block_item(model.body_first_point[a], model.body_first_face[b],
                                      faces_b, k)
        else:
            k = k - points_a * faces_b
            points_b = model.body_first_point[b + 1] - model.body_first_point[b]
            faces_a = model.body_first_face[a + 1] - model.body_first_face[a]
            if k < points_b * faces_a:
                first, other = block_item(model.body_first_point[b], model.body_first_face[a],
                                          faces_a, k)
            else:
                family = edge_edge
                first, other = block_item(model.body_first_edge[a], model.body_first_edge[b],
                                          model.body_first_edge[b + 1]
                                          - model.body_first_edge[b], k - points_b * faces_a)
        return family, first, other

    @wp.func(inline=True)
    def pair_bodies(model: Model, p: int):
        """(the moving body of pair p's first side; the body of its other side, −1 where that
        is static)."""
        body = int(0)
        other = int(-1)
        if p < point_pairs(model):
            body = model.point_body[p / statics(model)]
        elif p < point_pairs(model) + edge_pairs(model):
            body = model.edge_body[(p - point_pairs(model)) / model.static_edge_a.shape[0]]
        elif p < static_pairs(model):
            k = p - point_pairs(model) - edge_pairs(model)
            body = model.face_body[k / model.static_vertex.shape[0]]
        if wp.static(bodies):
            if p >= static_pairs(model):
                family, first, second = body_pair(model, p)
                if family == point_face:
                    body = model.point_body[first]
                    other = model.face_body[second]
                else:
                    body = model.edge_body[first]
                    other = model.edge_body[second]
        return body, other

    @wp.func
    def triangle_rest(q: vec12, corners: mat33, x: vec3):
        """The rest position of the point of the triangle with rest corners ``corners``
        (columns), on a body at state q, nearest to the world point x."""
        a = vec3(corners[0, 0], corners[1, 0], corners[2, 0])
        b = vec3(corners[0, 1], corners[1, 1], corners[2, 1])
        c = vec3(corners[0, 2], corners[1, 2], corners[2, 2])
        weights = triangle_weights(x, world_point(q, a), world_point(q, b), world_point(q, c))
        return weights[0] * a + weights[1] * b + weights[2] * c

    @wp.func
    def unit_gap(gap: vec3):
        """(|gap|, gap / |gap|, ẑ for a zero gap)."""
        length = wp.length(gap)
        n = vec3(zero, zero, one)
        if length > zero:
            n = gap / length
        return length, n

    @wp.func
    def static_edge_gap(model: Model, q: vec12, k: int):
        """``pair_gap`` of the k-th (moving edge, static edge) pair."""
        e = k / model.static_edge_a.shape[0]
        s = k - e * model.static_edge_a.shape[0]
        ea = model.edge_a[e]
        eb = model.edge_b[e]
        c = model.static_edge_a[s]
        u, w = segment_params(world_point(q, ea), world_point(q, eb), c, model.static_edge_b[s])
        rest = ea + u * (eb - ea)
        length, n = unit_gap(world_point(q, rest) - (c + w * (model.static_edge_b[s] - c)))
        radius = model.edge_radius[e]
        return (length - radius - model.static_edge_radius[s], n, rest, radius,
                vec3(zero, zero, zero), zero)

    @wp.func
    def static_vertex_gap(model: Model, q: vec12, k: int):
        """``pair_gap`` of the k-th (moving face, static vertex) pair."""
        f = k / model.static_vertex.shape[0]
        v = k - f * model.static_vertex.shape[0]
        rest = triangle_rest(q, model.face_rest[f], model.static_vertex[v])
        length, n = unit_gap(world_point(q, rest) - model.static_vertex[v])
        return (length - model.static_vertex_radius[v], n, rest, zero, vec3(zero, zero, zero),
                zero)

    @wp.func
    def body_face_gap(model: Model, q: vec12, q_other: vec12, i: int, f: int):
        """``pair_gap`` of point i against face f of another body."""
        x = world_point(q, model.point_rest[i])
        rest_other = triangle_rest(q_other, model.face_rest[f], x)
        length, n = unit_gap(x - world_point(q_other, rest_other))
        return (length - model.point_radius[i], n, model.point_rest[i], model.point_radius[i],
                rest_other, zero)

    @wp.func
    def body_edge_gap(model: Model, q: vec12, q_other: vec12, e: int, s: int):
        """``pair_gap`` of edge e against edge s of another body."""
        ea = model.edge_a[e]
        eb = model.edge_b[e]
        sa = model.edge_a[s]
        sb = model.edge_b[s]
        u, w = segment_params(world_point(q, ea), world_point(q, eb), world_point(q_other, sa),
                              world_point(q_other, sb))
        rest = ea + u * (eb - ea)
        rest_other = sa + w * (sb - sa)
        length, n = unit_gap(world_point(q, rest) - world_point(q_other, rest_other))
        return (length - model.edge_radius[e] - model.edge_radius[s], n, rest,
                model.edge_radius[e], rest_other, model.edge_radius[s])

    @wp.func
    def pair_gap(model: Model, q: vec12, q_other: vec12, p: int):
        """(distance d [m] of pair p with its first side's body at state q and its other
        side's (a moving one) at q_other; the unit direction n [world] in which it grows
        fastest, from the other side towards the first; the first side's rest point x̄ [m]
        whose motion changes d, gradient J(x̄)ᵀ n, and its radius [m]: the surface point that
        touches is x̄ − r A⁻¹ n; the other side's rest point ȳ (gradient −J(ȳ)ᵀ n) and radius,
        zero where it is static). A point's x̄ is its own; an edge's the nearest point of its
        segment; a face's the nearest point of its triangle. Each family but the points has a
        function of its own: the point pairs, the most common, stay a short call."""
        if wp.static(shapes):
            if p >= point_pairs(model):
                if p < point_pairs(model) + edge_pairs(model):
                    return static_edge_gap(model, q, p - point_pairs(model))
                if wp.static(bodies):
                    if p >= static_pairs(model):
                        family, first, second = body_pair(model, p)
                        if family == point_face:
                            return body_face_gap(model, q, q_other, first, second)
                        return body_edge_gap(model, q, q_other, first, second)
                return static_vertex_gap(model, q, p - point_pairs(model) - edge_pairs(model))
        i = p / statics(model)
        d, n = distance(model, q, i, p - i * statics(model))
        return d, n, model.point_rest[i], model.point_radius[i], vec3(zero, zero, zero), zero

    # called from some thirty places: out of line (physics.stages.out_of_line)
    gap = apart(t, pair_gap)

    @wp.func(inline=True)
    def other_state(q: wp.array2d(dtype=vec12), env: int, body: int, other: int):
        """The state of a pair's other body (the first body's where the other side is static:
        unused)."""
        out = q[env, body]
        if other >= 0:
            out = q[env, other]
        return out

    @wp.func(inline=True)
    def gap_between(model: Model, q: wp.array2d(dtype=vec12), env: int, p: int, body: int,
                    other: int):
        """``pair_gap`` of pair p, whose bodies are ``body`` and ``other`` (``pair_bodies``),
        at their states in q."""
        return gap(model, q[env, body], other_state(q, env, body, other), p)

    @wp.func(inline=True)
    def gap_at(model: Model, q: wp.array2d(dtype=vec12), env: int, p: int):
        """``pair_gap`` of pair p with its bodies at their states in q."""
        body, other = pair_bodies(model, p)
        return gap_between(model, q, env, p, body, other)

    @wp.func
    def mollifier(own: vec3, own_world: vec3, other: vec3, other_world: vec3):
        """IPC's near-parallel mollifier of two edges, rest vectors ``own``, ``other`` and
        world ones: with c = |e₀ × e₁|² and ε = 10⁻³ |ē₀|² |ē₁|², (2 − c/ε) c/ε below ε,
        else 1 (1 for a zero-length edge)."""
        weight = one
        limit = scalar(1.0e-3) * wp.dot(own, own) * wp.dot(other, other)
        cross = wp.cross(own_world, other_world)
        if wp.dot(cross, cross) < limit:
            ratio = wp.dot(cross, cross) / limit
            weight = (two - ratio) * ratio
        return weight

    @wp.func(inline=True)
    def pair_weight(model: Model, q_n: vec12, q_other_n: vec12, p: int):
        """The weight of pair p's barrier for this step: 1, but for an edge pair IPC's
        near-parallel mollifier (``mollifier``) at the step's start q_n, q_other_n (held for
        the step, like friction). Two near-parallel edges have no single nearest pair; their
        ends' points and faces carry the contact."""
        weight = one
        if wp.static(shapes):
            if p >= point_pairs(model) and p < point_pairs(model) + edge_pairs(model):
                k = p - point_pairs(model)
                e = k / model.static_edge_a.shape[0]
                s = k - e * model.static_edge_a.shape[0]
                own = model.edge_b[e] - model.edge_a[e]
                other = model.static_edge_b[s] - model.static_edge_a[s]
                weight = mollifier(own, affine(q_n) @ own, other, other)
        if wp.static(bodies):
            if p >= static_pairs(model):
                family, e, s = body_pair(model, p)
                if family == edge_edge:
                    own = model.edge_b[e] - model.edge_a[e]
                    other = model.edge_b[s] - model.edge_a[s]
                    weight = mollifier(own, affine(q_n) @ own, other,
                                       affine(q_other_n) @ other)
        return weight

    @wp.func
    def corner_reach(dq: vec12, corners: mat33, shift: vec3):
        """The most [m] a corner of a triangle (rest corners as columns) moves under dq,
        relative to a displacement ``shift``."""
        most = zero
        for c in range(3):
            moved = world_point(dq, vec3(corners[0, c], corners[1, c], corners[2, c]))
            most = wp.max(most, wp.length(moved - shift))
        return most

    @wp.func
    def edge_reach(model: Model, dq: vec12, e: int):
        """The most [m] an end of moving edge e moves under dq."""
        return wp.max(wp.length(world_point(dq, model.edge_a[e])),
                      wp.length(world_point(dq, model.edge_b[e])))

    @wp.func
    def edges_reach(model: Model, dq: vec12, e: int, dq_other: vec12, s: int):
        """The most [m] an end of edge e under dq moves relative to an end of edge s under
        dq_other."""
        a0 = world_point(dq, model.edge_a[e])
        a1 = world_point(dq, model.edge_b[e])
        b0 = world_point(dq_other, model.edge_a[s])
        b1 = world_point(dq_other, model.edge_b[s])
        return wp.max(wp.max(wp.length(a0 - b0), wp.length(a0 - b1)),
                      wp.max(wp.length(a1 - b0), wp.length(a1 - b1)))

    @wp.func
    def reach(model: Model, dq: vec12, dq_other: vec12, p: int):
        """The most [m] pair p's distance changes under dq of its first body and dq_other of
        its other (for a pair of bodies): the largest corner displacement |J(x̄) dq| of its
        moving edge or face against a static side (a segment's or triangle's points are
        their corners' convex combinations); against another body's the largest of one
        side's corners relative to the other's (the relative displacement of the nearest
        points is a convex combination of those: a common motion, two boxes falling
        together, does not count)."""
        k = p - point_pairs(model)
        most = zero
        if k < edge_pairs(model):
            most = edge_reach(model, dq, k / model.static_edge_a.shape[0])
        elif p < static_pairs(model):
            most = corner_reach(dq, model.face_rest[(k - edge_pairs(model))
                                                    / model.static_vertex.shape[0]],
                                vec3(zero, zero, zero))
        if wp.static(bodies):
            if p >= static_pairs(model):
                family, first, second = body_pair(model, p)
                if family == edge_edge:
                    most = edges_reach(model, dq, first, dq_other, second)
                else:
                    most = corner_reach(dq_other, model.face_rest[second],
                                        world_point(dq, model.point_rest[first]))
        return most

    return SimpleNamespace(triangle_weights=triangle_weights, contact_distance=distance,
                           statics=statics, point_pairs=point_pairs, edge_pairs=edge_pairs,
                           static_pairs=static_pairs, pair_count=pair_count,
                           pair_bodies=pair_bodies, pair_gap=gap, gap_at=gap_at,
                           gap_between=gap_between,
                           unit_gap=unit_gap,
                           other_state=other_state, pair_weight=pair_weight, motion=motion,
                           reach=reach)
