"""Contact: the IPC barrier on each pair's distance (``contact.geometry``), lagged smoothed
Coulomb friction and contact damping, their gradients and Hessians mapped into the bodies'
blocks, the near-pair list, the step bound along a Newton direction, and the statistics
(docs/physics.md#contact).

The barrier (libuipc's form on D = d², D̂ = d̂²) b(D) = −κ (D − D̂)² ln(D / D̂) for 0 < d < d̂
(zero beyond) enters the incremental potential as dt² b; as a function of d it is convex on
(0, d̂), so dt² b''(d) w wᵀ is PSD (clamped at 0 against rounding), w = [J(x̄)ᵀ n; −J(ȳ)ᵀ n]
the distance's gradient over the pair's bodies: the whole Hessian against a half-space;
otherwise its curvature term b'(d) ∇²d is left out, the Gauss–Newton part of IPC's PSD
projection. A pair with a static side adds to one diagonal block only; a pair of two bodies
also couples their blocks (scratch.contact_block, solved by ``coupled_solve``). Every loop is
skipped in a scene without contact (model.has_contact = 0), and a pair that may not touch
everywhere.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart
from affine_joint_sim.physics.contact.kinds import TRIANGLE

__all__ = ['ADVANCE_STEPS', 'ARRIVING', 'DRIFT_SLACK', 'IMPACT_ACCELERATION', 'IMPACT_SHARE',
           'RELEASE_STEPS', 'STEP_SLACK', 'STIFF', 'build']

STEP_SLACK = 0.1     # η: a step along dq keeps this fraction of every shrinking gap
ADVANCE_STEPS = 64  # conservative advancement steps of an edge or face pair at most
ARRIVING = 0.1      # a pair beyond d̂ that the prediction takes this share of d̂ inside arrives
STIFF = 1000.0      # a pair stiffer than this many m_eff/dt²: deep in the barrier, a push-out
                    # that the step does not resolve (docs/physics.md#impacts)
IMPACT_ACCELERATION = 100.0   # m/s²: a pair's normal acceleration within d̂ above it (10 g),
IMPACT_SHARE = 0.1            # or its Δ² min(d, d̂) in a step above this share of d̂: an impact
                              # (docs/physics.md#impacts)
RELEASE_STEPS = 48   # safeguarded Newton steps of an opening pair's damper release at most
DRIFT_SLACK = 1.0 / 16.0    # a pair is skipped as beyond a distance only with this share of d̂
                            # to spare (``surely_beyond``: the rounding of the distances)
# Warp passes a struct argument by value: a call the C++ compiler keeps out of line copies the
# whole Model (and Scratch) each time. The contact stages a step calls whatever is near are
# inlined; a box far from everything paid 0.6 µs more a step without (docs/physics.md#contact).
# The gathering of the near list is out of line, its structs by reference (it runs once a step
# and where the margins widen): inlined at each of its call sites it was half of the step
# kernel that NVRTC optimises as one function (bench.inlining; ``gather_near_apart``).
INLINE = True


def build(t) -> SimpleNamespace:
    """Warp functions of contact for the types namespace ``t``."""
    vec3, vec12, mat33, mat12, scalar = t.vec3, t.vec12, t.mat33, t.mat12, t.scalar
    zero, half, one, two, three, four = t.zero, t.half, t.one, t.two, t.three, t.four
    update_roundoff = t.update_roundoff
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    world_point, jacobian_transpose, log = t.world_point, t.jacobian_transpose, t.log
    affine = t.affine
    distance, statics, point_pairs = t.contact_distance, t.statics, t.point_pairs
    static_pairs, pair_count, pair_bodies = t.static_pairs, t.pair_count, t.pair_bodies
    pair_gap, gap_at, gap_between, other_state = (t.pair_gap, t.gap_at, t.gap_between,
                                                   t.other_state)
    pair_weight, motion, reach, unit_gap = t.pair_weight, t.motion, t.reach, t.unit_gap
    keep = scalar(1.0 - STEP_SLACK)
    arrival, stiff = scalar(1.0 - ARRIVING), scalar(STIFF)
    impact_acceleration, impact_share = scalar(IMPACT_ACCELERATION), scalar(IMPACT_SHARE)
    drift_slack = scalar(DRIFT_SLACK)
    bodies = t.bodies       # pairs of moving bodies compiled in (kernels.step_kernels)
    shapes = t.shapes       # static shapes, meshes, their edges and vertices compiled in
    triangle = TRIANGLE.code
    infinity = scalar(float('inf'))

    @wp.func(inline=True)
    def listed(model: Model, scratch: Scratch, env: int):
        """How many pairs this step evaluates: the near pairs (``gather_near``)."""
        return scratch.near_count[env]

    @wp.func(inline=True)
    def listed_pair(model: Model, scratch: Scratch, env: int, k: int):
        """The k-th pair this step evaluates (the static pairs first, ascending)."""
        return scratch.near_pairs[env, k]

    @wp.func(inline=True)
    def pair_on(model: Model, p: int):
        """Whether pair p may touch: a static pair's model.pair_on; a pair of bodies is listed
        only for bodies that may touch each other."""
        on = True
        if p < static_pairs(model):
            on = model.pair_on[p] != 0
        return on

    @wp.func(inline=True)
    def pair_friction(model: Model, p: int, body: int, other: int):
        """Coulomb μ of pair p (bodies ``body`` and ``other``, −1 for a static side)."""
        mu = zero
        if other < 0:
            mu = model.pair_friction[p]
        else:
            mu = model.body_friction[body, other]
        return mu

    @wp.func
    def friction_weight(model: Model, scratch: Scratch, env: int, k: int, p: int, body: int,
                        other: int):
        """μ dt²λ [N·s²] of the k-th listed pair p (bodies ``body``, ``other``): its friction's
        weight this step, 0 without a lagged normal load or without friction."""
        force = scratch.friction_normal[env, k]
        weight = zero
        if force > zero:
            weight = pair_friction(model, p, body, other) * force
        return weight

    @wp.func
    def friction_loaded(model: Model, scratch: Scratch, env: int):
        """Whether a listed pair has friction this step (``friction_weight``): its term acts at
        every iterate and ``add_pairs`` counts it against the last factors."""
        found = int(0)
        for k in range(listed(model, scratch, env)):
            if scratch.friction_normal[env, k] > zero:
                p = listed_pair(model, scratch, env, k)
                body, other = pair_bodies(model, p)
                if friction_weight(model, scratch, env, k, p, body, other) > zero:
                    found = 1
        return found

    @wp.func
    def measure_drift(model: Model, q: wp.array2d(dtype=vec12), also: wp.array2d(dtype=vec12),
                      scratch: Scratch, env: int, along: int):
        """How far each free body's contact points, edges and faces are at most from where
        they were at q_n, at q or at ``also`` (``motion`` of q − q_n, the larger), with
        ``along`` plus their motion along the path q + α dq (dq: scratch.dq) over 1 − η, into
        scratch.body_drift."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            q_n = scratch.q_n[env, b]
            drift = wp.max(motion(model, b, q[env, b] - q_n), motion(model, b, also[env, b] - q_n))
            if along != 0:
                drift += motion(model, b, scratch.dq[env, b]) / keep
            scratch.body_drift[env, b] = drift

    drift_apart = apart(t, measure_drift)   # out of line: one loop for every pass's call

    @wp.func(inline=True)
    def measure(model: Model, q: wp.array2d(dtype=vec12), also: wp.array2d(dtype=vec12),
                scratch: Scratch, env: int, along: int):
        """``measure_drift`` where a pair is listed (nothing reads it otherwise)."""
        if scratch.near_count[env] > 0:
            drift_apart(model, q, also, scratch, env, along)

    @wp.func(inline=True)
    def pair_drift(scratch: Scratch, env: int, body: int, other: int):
        """How far a pair's points drifted at most (``measure_drift`` of its body plus its
        other's, −1 for a static side): its distance changed by no more."""
        moved = scratch.body_drift[env, body]
        if other >= 0:
            moved += scratch.body_drift[env, other]
        return moved

    @wp.func(inline=True)
    def surely_beyond(model: Model, scratch: Scratch, env: int, k: int, body: int,
                      other: int, limit: scalar):
        """Whether the k-th listed pair (bodies ``body`` and ``other``, −1 for a static side)
        is farther than ``limit`` [m], with DRIFT_SLACK d̂ to spare, at the state of the last
        ``measure_drift``: its distance at q_n (scratch.gap_n; 0 where unknown) less how far
        its bodies' points drifted since (a distance changes no more than its points move).
        Skipping a pair only where it adds nothing that far changes no bit: most listed
        pairs are beyond d̂."""
        return (scratch.gap_n[env, k] - pair_drift(scratch, env, body, other)
                > limit + drift_slack * model.contact_d_hat)

    @wp.func(inline=True)
    def put_near(scratch: Scratch, env: int, p: int, at: int):
        """near_pairs[at] = p where the room holds it; returns at + 1 either way (a list
        longer than the room is counted, not written: ``relist``)."""
        if at < scratch.near_pairs.shape[1]:
            scratch.near_pairs[env, at] = p
        return at + 1

    @wp.func
    def add_near(model: Model, scratch: Scratch, env: int, p: int, reach_: scalar, at: int):
        """Write pair p to near_pairs[at] if it may touch and its distance at q_n is below
        ``reach_`` [m]; returns the next index (counted on beyond the room: ``put_near``)."""
        out = at
        if pair_on(model, p):
            d, n, rest, radius, rest_o, radius_o = gap_at(model, scratch.q_n, env, p)
            if d < reach_:
                out = put_near(scratch, env, p, at)
        return out

    @wp.func
    def spread(q: vec12):
        """A bound on |A x| / |x| (A's largest singular value): the square root of the largest
        Gershgorin row sum of AᵀA (1 to rounding for a rotation)."""
        a = affine(q)
        g = wp.transpose(a) @ a
        most = zero
        for r in range(3):
            most = wp.max(most, wp.abs(g[r, 0]) + wp.abs(g[r, 1]) + wp.abs(g[r, 2]))
        return wp.sqrt(most)

    @wp.func(inline=True)
    def edge_ball(model: Model, q: vec12, e: int):
        """(midpoint [m], half length plus radius [m]) of moving edge e on a body at state q:
        a sphere holding it."""
        end_a = world_point(q, model.edge_a[e])
        end_b = world_point(q, model.edge_b[e])
        return half * (end_a + end_b), half * wp.length(end_b - end_a) + model.edge_radius[e]

    @wp.func(inline=True)
    def near_surface(model: Model, g: int, centre: vec3, size: scalar):
        """A lower bound [m] of the gap between a sphere (``centre``, radius ``size``) and
        static surface g's edges and vertices: the distance between it and their bounding
        sphere."""
        return wp.length(centre - model.surface_centre[g]) - size - model.surface_radius[g]

    @wp.func(inline=True)
    def face_ball(q: vec12, corners: mat33):
        """(centroid [m], its farthest corner's distance [m]) of the triangle with rest corners
        ``corners`` (columns) on a body at state q: a sphere holding it."""
        c0 = world_point(q, vec3(corners[0, 0], corners[1, 0], corners[2, 0]))
        c1 = world_point(q, vec3(corners[0, 1], corners[1, 1], corners[2, 1]))
        c2 = world_point(q, vec3(corners[0, 2], corners[1, 2], corners[2, 2]))
        centre = (c0 + c1 + c2) / three
        return centre, wp.max(wp.length(c0 - centre), wp.max(wp.length(c1 - centre),
                                                              wp.length(c2 - centre)))

    @wp.func
    def body_axes(q: vec12):
        """The unit directions [world] of the axes of a body at state q (A's columns
        normalized), as rows."""
        a = affine(q)
        return wp.matrix_from_rows(wp.normalize(vec3(a[0, 0], a[1, 0], a[2, 0])),
                                   wp.normalize(vec3(a[0, 1], a[1, 1], a[2, 1])),
                                   wp.normalize(vec3(a[0, 2], a[1, 2], a[2, 2])))

    @wp.func
    def in_box(axes: mat33, low: vec3, high: vec3, centre: vec3, size: scalar, reach_: scalar):
        """Whether a ball (``centre``, radius ``size``) comes within ``reach_`` of the slabs
        between ``low`` and ``high`` along the three unit directions ``axes`` (rows)."""
        height = axes @ centre
        inside = True
        for k in range(3):
            if height[k] - size - high[k] >= reach_ or low[k] - height[k] - size >= reach_:
                inside = False
        return inside

    @wp.func
    def near_body(scratch: Scratch, env: int, b: int, axes: mat33, n: vec3, top: scalar,
                  centre: vec3, size: scalar, reach_: scalar):
        """Whether a ball (``centre``, radius ``size``) may come within ``reach_`` of body b
        at q_n: b lies below ``top`` along n and within its box along its ``axes``."""
        return wp.dot(n, centre) - size - top < reach_ and in_box(
            axes, scratch.body_low[env, b], scratch.body_high[env, b], centre, size, reach_)

    @wp.func
    def list_near(scratch: Scratch, env: int, centres: wp.array2d(dtype=vec3),
                  sizes: wp.array2d(dtype=scalar), first: int, end: int, b: int, n: vec3,
                  top: scalar, reach_: scalar, into: wp.array2d(dtype=int)):
        """Into ``into[env]`` from 0, the balls ``first`` … ``end`` − 1 (``centres``,
        ``sizes``) that may come within ``reach_`` of body b (``near_body``); returns how
        many."""
        axes = body_axes(scratch.q_n[env, b])
        count = int(0)
        for k in range(first, end):
            if near_body(scratch, env, b, axes, n, top, centres[env, k], sizes[env, k], reach_):
                into[env, count] = k
                count += 1
        return count

    @wp.func
    def place_primitives(model: Model, scratch: Scratch, env: int, b: int):
        """Body b's contact points, edge balls and face balls at q_n into scratch, and its
        extent along its own axes (``body_axes``: body_low, body_high), over its points and
        edge balls (its faces' corners are its edges' ends): the broad phase of pairs of
        bodies."""
        q = scratch.q_n[env, b]
        axes = body_axes(q)
        low = vec3(infinity, infinity, infinity)
        high = -low
        for i in range(model.body_first_point[b], model.body_first_point[b + 1]):
            x = world_point(q, model.point_rest[i])
            scratch.point_world[env, i] = x
            scratch.point_size[env, i] = model.point_radius[i]
            radius = vec3(model.point_radius[i], model.point_radius[i], model.point_radius[i])
            low = wp.min(low, axes @ x - radius)
            high = wp.max(high, axes @ x + radius)
        for e in range(model.body_first_edge[b], model.body_first_edge[b + 1]):
            middle, size = edge_ball(model, q, e)
            scratch.edge_centre[env, e] = middle
            scratch.edge_size[env, e] = size
            low = wp.min(low, axes @ middle - vec3(size, size, size))
            high = wp.max(high, axes @ middle + vec3(size, size, size))
        scratch.body_low[env, b] = low
        scratch.body_high[env, b] = high
        for f in range(model.body_first_face[b], model.body_first_face[b + 1]):
            centre, size = face_ball(q, model.face_rest[f])
            scratch.face_centre[env, f] = centre
            scratch.face_size[env, f] = size

    @wp.func
    def place_once(model: Model, scratch: Scratch, env: int, b: int):
        """``place_primitives`` of body b unless this gathering placed them already
        (scratch.body_placed)."""
        if scratch.body_placed[env, b] == 0 and (
                model.body_first_point[b] < model.body_first_point[b + 1]):
            place_primitives(model, scratch, env, b)
            scratch.body_placed[env, b] = 1

    @wp.func
    def gather_pairs(model: Model, scratch: Scratch, env: int, a: int, b: int, n: vec3,
                     top: scalar, bottom: scalar, reach_: scalar,
                     centres: wp.array2d(dtype=vec3), sizes: wp.array2d(dtype=scalar),
                     first: int, end: int, centres_b: wp.array2d(dtype=vec3),
                     sizes_b: wp.array2d(dtype=scalar), first_b: int, end_b: int,
                     listed_b: wp.array2d(dtype=int), base: int, at: int):
        """The pairs of body a's primitives ``first`` … ``end`` − 1 (balls ``centres``,
        ``sizes`` at q_n: its points or edges) with body b's ``first_b`` … ``end_b`` − 1
        (its faces or edges) within ``reach_``, numbered from ``base`` row by row, into
        near_pairs from index ``at``; returns the next free index. Only a primitive of a
        within reach of b's slab (b lies below ``top`` along n) and b's box, and one of b
        within reach of a's (a lies above ``bottom``; listed in ``listed_b``), are paired,
        by bounding spheres, then the exact distance."""
        axes_b = body_axes(scratch.q_n[env, b])
        count = list_near(scratch, env, centres_b, sizes_b, first_b, end_b, a, -n, -bottom,
                          reach_, listed_b)
        out = at
        for i in range(first, end):
            centre = centres[env, i]
            size = sizes[env, i]
            if near_body(scratch, env, b, axes_b, n, top, centre, size, reach_):
                row = base + (i - first) * (end_b - first_b) - first_b
                for k in range(count):
                    j = listed_b[env, k]
                    if wp.length(centre - centres_b[env, j]) - size - sizes_b[env, j] < reach_:
                        out = add_near(model, scratch, env, row + j, reach_, out)
        return out

    @wp.func
    def extent(model: Model, scratch: Scratch, env: int, b: int, n: vec3):
        """(lowest, highest) [m] along n of body b's contact points and edge balls at q_n
        (placed by ``place_primitives``): its faces' corners are its edges' ends."""
        low = infinity
        high = -infinity
        for i in range(model.body_first_point[b], model.body_first_point[b + 1]):
            height = wp.dot(n, scratch.point_world[env, i])
            low = wp.min(low, height - model.point_radius[i])
            high = wp.max(high, height + model.point_radius[i])
        for e in range(model.body_first_edge[b], model.body_first_edge[b + 1]):
            height = wp.dot(n, scratch.edge_centre[env, e])
            low = wp.min(low, height - scratch.edge_size[env, e])
            high = wp.max(high, height + scratch.edge_size[env, e])
        return low, high

    @wp.func
    def static_gap(model: Model, edge: int, s: int, centre: vec3, size: scalar):
        """The gap [m] between a ball (``centre``, radius ``size``) and static edge ``s``
        (``edge`` ≠ 0: the segment's nearest point to the centre) or static vertex ``s``."""
        gap = zero
        if edge != 0:
            start_s = model.static_edge_a[s]
            along = model.static_edge_b[s] - start_s
            t = zero
            if wp.dot(along, along) > zero:
                t = wp.clamp(wp.dot(centre - start_s, along) / wp.dot(along, along), zero, one)
            gap = wp.length(centre - start_s - t * along) - size - model.static_edge_radius[s]
        else:
            gap = wp.length(centre - model.static_vertex[s]) - size - model.static_vertex_radius[s]
        return gap

    @wp.func
    def near_surfaces(model: Model, scratch: Scratch, env: int, b: int):
        """Whether body b's bounding sphere at q_n (about its centre, body_bound times
        ``spread``) comes within d̂ + its margin of any static surface's: where it does not,
        none of its edges' or faces' balls does (each lies inside it)."""
        q = scratch.q_n[env, b]
        centre = vec3(q[0], q[1], q[2])
        size = model.body_bound[b] * spread(q)
        reach_ = model.contact_d_hat + scratch.body_margin[env, b]
        near = int(0)
        for g in range(model.surface_radius.shape[0]):
            if near_surface(model, g, centre, size) < reach_:
                near = 1
        return near != 0

    @wp.func
    def gather_static(model: Model, scratch: Scratch, env: int, ends: wp.array(dtype=int),
                      edge: int, centre: vec3, size: scalar, reach: scalar, base: int, at: int):
        """The static edges (``edge`` ≠ 0) or vertices within ``reach`` of a moving edge's or
        face's ball (``centre``, ``size``), surface by surface (``ends``: each surface's end
        in them; a surface whose bounding sphere is farther is skipped, ``near_surface``, and
        one the moving side may not touch: its pairs share their pair_on), into near_pairs as
        pair ``base + s``; returns the next free index."""
        s0 = int(0)
        for g in range(model.surface_radius.shape[0]):
            s1 = ends[g]
            if s1 > s0 and model.pair_on[base + s0] != 0 and near_surface(
                    model, g, centre, size) < reach:
                for s in range(s0, s1):
                    if static_gap(model, edge, s, centre, size) < reach:
                        at = add_near(model, scratch, env, base + s, reach, at)
            s0 = s1
        return at

    @wp.func(inline=True)
    def triangle_far(model: Model, s: int, x: vec3, reach_: scalar):
        """Whether shape s (none for s < 0) is a static triangle whose bounding sphere about
        its centroid is farther than ``reach_`` [m] from the point x."""
        far = False
        if s >= 0:
            if model.shape_kind[s] == triangle:
                far = wp.length(x - model.shape_center[s]) - model.shape_size[s][0] >= reach_
        return far

    @wp.func
    def gather_bodies(model: Model, scratch: Scratch, env: int, start: int):
        """The pairs of bodies within d̂ + both bodies' margins at q_n into near_pairs from
        index ``start``: per pair of bodies that may touch, whose bounding spheres are that
        near (their primitives placed then, once a gathering: ``place_primitives``), its
        points against the other's faces both ways and its edges against the other's, each
        side's primitives only where they reach the other's slab along the line of their
        centres and its box along its own axes; returns the next free index."""
        at = start
        for b in range(model.body_reach.shape[0]):
            scratch.body_placed[env, b] = 0
        for j in range(model.touch_a.shape[0]):
            a = model.touch_a[j]
            b = model.touch_b[j]
            reach_ = model.contact_d_hat + scratch.body_margin[env, a] + scratch.body_margin[env, b]
            qa = scratch.q_n[env, a]
            qb = scratch.q_n[env, b]
            length, n = unit_gap(vec3(qa[0] - qb[0], qa[1] - qb[1], qa[2] - qb[2]))
            apart = length - model.body_bound[a] * spread(qa) - model.body_bound[b] * spread(qb)
            if apart < reach_:
                place_once(model, scratch, env, a)
                place_once(model, scratch, env, b)
                low_a, high_a = extent(model, scratch, env, a, n)
                low_b, high_b = extent(model, scratch, env, b, n)
                base = static_pairs(model) + model.touch_first[j]
                points_a = model.body_first_point[a]
                points_b = model.body_first_point[b]
                faces_a = model.body_first_face[a]
                faces_b = model.body_first_face[b]
                at = gather_pairs(model, scratch, env, a, b, n, high_b, low_a, reach_,
                                  scratch.point_world, scratch.point_size, points_a,
                                  model.body_first_point[a + 1], scratch.face_centre,
                                  scratch.face_size, faces_b, model.body_first_face[b + 1],
                                  scratch.slab_faces, base, at)
                base += ((model.body_first_point[a + 1] - points_a)
                         * (model.body_first_face[b + 1] - faces_b))
                at = gather_pairs(model, scratch, env, b, a, -n, -low_a, -high_b, reach_,
                                  scratch.point_world, scratch.point_size, points_b,
                                  model.body_first_point[b + 1], scratch.face_centre,
                                  scratch.face_size, faces_a, model.body_first_face[a + 1],
                                  scratch.slab_faces, base, at)
                base += ((model.body_first_point[b + 1] - points_b)
                         * (model.body_first_face[a + 1] - faces_a))
                at = gather_pairs(model, scratch, env, a, b, n, high_b, low_a, reach_,
                                  scratch.edge_centre, scratch.edge_size,
                                  model.body_first_edge[a], model.body_first_edge[a + 1],
                                  scratch.edge_centre, scratch.edge_size,
                                  model.body_first_edge[b], model.body_first_edge[b + 1],
                                  scratch.slab_edges, base, at)
        return at

    @wp.func(inline=INLINE)
    def gather_near(model: Model, scratch: Scratch, env: int, start: int):
        """The pairs within d̂ + body_margin of their body (of both bodies for a pair of
        bodies: ``gather_bodies``) at q_n, the static ones first and ascending, into
        near_pairs from index ``start``; returns how many. Edges and faces are found edge by
        edge and face by face: a pair is not evaluated where the moving side's bounding
        sphere at q_n (about its midpoint or centroid) is farther from the static edge or
        vertex, nor a static surface's pairs where it is farther from the surface's bounding
        sphere (``near_surface``)."""
        at = start
        first = point_pairs(model)
        things = statics(model)
        planes = model.plane_offset.shape[0]
        for i in range(model.point_body.shape[0]):
            b = model.point_body[i]
            reach = model.contact_d_hat + scratch.body_margin[env, b]
            x = world_point(scratch.q_n[env, b], model.point_rest[i])
            for g in range(things):
                if model.pair_on[i * things + g] != 0:
                    far = False
                    if wp.static(shapes):
                        far = triangle_far(model, g - planes, x, model.point_radius[i] + reach)
                    if not far:
                        d, n = distance(model, scratch.q_n[env, b], i, g)
                        if d < reach:
                            at = put_near(scratch, env, i * things + g, at)
        if wp.static(shapes):
            statics_e = model.static_edge_a.shape[0]
            edges = model.edge_body.shape[0]
            for b in range(model.body_reach.shape[0]):      # edges are numbered body by body
                if model.body_first_edge[b] < model.body_first_edge[b + 1] and near_surfaces(
                        model, scratch, env, b):
                    for e in range(model.body_first_edge[b], model.body_first_edge[b + 1]):
                        middle, size = edge_ball(model, scratch.q_n[env, b], e)
                        at = gather_static(model, scratch, env, model.surface_edge_end, 1,
                                           middle, size,
                                           model.contact_d_hat + scratch.body_margin[env, b],
                                           first + e * statics_e, at)
            statics_v = model.static_vertex.shape[0]
            for b in range(model.body_reach.shape[0]):      # and so are faces
                if model.body_first_face[b] < model.body_first_face[b + 1] and near_surfaces(
                        model, scratch, env, b):
                    for f in range(model.body_first_face[b], model.body_first_face[b + 1]):
                        centre, size = face_ball(scratch.q_n[env, b], model.face_rest[f])
                        at = gather_static(model, scratch, env, model.surface_vertex_end, 0,
                                           centre, size,
                                           model.contact_d_hat + scratch.body_margin[env, b],
                                           first + edges * statics_e + f * statics_v, at)
        if wp.static(bodies):
            at = gather_bodies(model, scratch, env, at)
        return at - start

    gather = apart(t, gather_near)     # out of line (physics.stages.out_of_line)

    @wp.func(inline=True)
    def carry(scratch: Scratch, env: int, to: int, source: int):
        """The lagged values of near list slot ``source`` into slot ``to`` (none: −1)."""
        force = zero
        damping = zero
        release_ = zero
        before = zero
        gap = zero
        if source >= 0:
            force = scratch.friction_normal[env, source]
            damping = scratch.normal_damping[env, source]
            release_ = scratch.damping_release[env, source]
            before = scratch.damping_before[env, source]
            gap = scratch.gap_n[env, source]
        scratch.friction_normal[env, to] = force
        scratch.normal_damping[env, to] = damping
        scratch.damping_release[env, to] = release_
        scratch.damping_before[env, to] = before
        scratch.gap_n[env, to] = gap

    @wp.func
    def relist(scratch: Scratch, env: int, old: int, fresh: int):
        """Make the list gathered into near_pairs[old, old + fresh) the near list: each pair
        keeps the lagged values it had in the list near_pairs[0, old) (both ascending: one
        merge), a new one gets none, and the list moves to the front: only listed pairs hold
        lagged values. A list beyond the room (old + fresh > near_pairs' room) is not taken:
        the old one stays, near_full says how many the room would need (the step is
        rejected and taken again with more room, ``commit.finish``, ``Stepper``) and the
        margins are void (−1: that step gathers anew). Returns 1 if the list was taken."""
        taken = int(0)
        if old + fresh > scratch.near_pairs.shape[1]:
            scratch.near_full[env] = wp.max(scratch.near_full[env], old + fresh)
            for b in range(scratch.body_margin.shape[1]):     # gathered again when retaken
                scratch.body_margin[env, b] = -one
        else:
            taken = 1
            i = int(0)
            for j in range(old, old + fresh):
                p = scratch.near_pairs[env, j]
                while i < old and scratch.near_pairs[env, i] < p:
                    i += 1
                source = int(-1)
                if i < old:
                    if scratch.near_pairs[env, i] == p:
                        source = i
                carry(scratch, env, j, source)
            for j in range(fresh):
                scratch.near_pairs[env, j] = scratch.near_pairs[env, old + j]
                carry(scratch, env, j, old + j)
            scratch.near_count[env] = fresh
        return taken

    @wp.func
    def stale(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
              along: int):
        """Whether a body's points, edges or faces may be farther from where they were when
        the near list was gathered (scratch.q_listed) than its margin, at q or with ``along``
        on the path q + α dq, α ∈ [0, 1] (dq: scratch.dq): ``motion`` of q − q_listed, plus
        of dq along the path."""
        out = int(0)
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            reach = motion(model, b, q[env, b] - scratch.q_listed[env, b])
            if along != 0:
                reach += motion(model, b, scratch.dq[env, b])
            if reach > scratch.body_margin[env, b]:
                out = 1
        return out

    @wp.func
    def regather(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 along: int):
        """Gather the near list again at q_n (``relist``: the lagged values go with their
        pairs), each body's margin twice its reach from q_n, the larger of the prediction
        q̃'s and q's (with ``along``, of the path q + α dq: see ``stale``), at least d̂.
        Returns 1 if the list was taken."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            q_n = scratch.q_n[env, b]
            reach = motion(model, b, q[env, b] - q_n)
            if along != 0:
                reach += motion(model, b, scratch.dq[env, b])
            reach = wp.max(reach, motion(model, b, scratch.q_tilde[env, b] - q_n))
            scratch.body_margin[env, b] = wp.max(model.contact_d_hat, two * reach)
            scratch.q_listed[env, b] = q_n
        old = scratch.near_count[env]
        scratch.near_gathers[env] += 1
        return relist(scratch, env, old, gather(model, scratch, env, old))

    @wp.func
    def refresh_near(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                     along: int):
        """The near list gathered again where it is ``stale`` at q (``regather``). Returns 1 if
        the list holds the pairs (0: it outgrew its room, ``relist``)."""
        taken = int(1)
        if stale(model, q, scratch, env, along) != 0:
            taken = regather(model, q, scratch, env, along)
        return taken

    refresh = apart(t, refresh_near)    # out of line: called by every step bound and the lag

    @wp.func(inline=INLINE)
    def cover(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
              along: int):
        """Keep every pair not listed beyond d̂ at q, or with ``along`` on the whole path
        q + α dq, α ∈ [0, 1]: where a body may have moved beyond its margin (``stale``) the
        list is gathered again (``regather``). Nothing while this step's list has outgrown
        its room (near_full: the step is rejected)."""
        if pair_count(model) > 0:
            if scratch.near_full[env] == 0:
                refresh(model, q, scratch, env, along)

    @wp.func
    def tangent_of(n: vec3):
        """t₁ of a friction basis for normal n: x̂ × n normalized (ẑ × n where n is within
        about 26° of x̂), as contact.model._tangent gives a half-space."""
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
    def pair_mass(model: Model, scratch: Scratch, env: int, body: int, other: int,
                  rest: vec3, radius: scalar, rest_other: vec3, radius_other: scalar, n: vec3):
        """m_eff [kg] of a pair along its normal n at q_n: ``point_mass`` of its body at the
        touching point, in series with the other body's where that moves."""
        q_n = scratch.q_n[env, body]
        mass = point_mass(model, body, q_n, touch_rest(q_n, rest, radius, n), n)
        if wp.static(bodies):
            if other >= 0:
                q_o = scratch.q_n[env, other]
                mass_o = point_mass(model, other, q_o,
                                    touch_rest(q_o, rest_other, radius_other, -n), n)
                mass = one / (one / mass + one / mass_o)
        return mass

    @wp.func
    def release(model: Model, d_n: scalar, damping: scalar, weight: scalar):
        """s [m] in (d_n, d̂): the distance at which a pair opening from d_n, its damper
        pulling c·dt (s − d_n) (``damping`` c·dt [kg]), pulls as hard as the barrier still
        pushes, −``weight`` db/dd (``weight`` dt² w [s²]); beyond it the damper only cancels
        the push (a contact never pulls): the root of f(s) = c·dt (s − d_n) + weight db/dd,
        which grows with s (the pull grows, the push falls; f' = c·dt + weight d²b/dd² > 0).
        Newton's method from d_n inside the bracket (d_n, d̂), a step that would leave it
        bisecting it instead, until a step would move s by less than 16 roundings of d̂
        (d̂ / 2⁴⁸ in float64: a few steps, where 48 bisections to that width cost a resting
        stack of three boxes 44 % of its step)."""
        low = d_n
        high = model.contact_d_hat
        resolution = update_roundoff * high     # d̂ / 2⁴⁸ in float64
        s = d_n
        for i in range(RELEASE_STEPS):
            e, b1, b2 = barrier(model, s)
            f = damping * (s - d_n) + weight * b1
            if f < zero:
                low = s
            else:
                high = s
            after = s - f / (damping + weight * wp.max(b2, zero))
            if wp.abs(after - s) <= resolution:
                s = after
                break
            if not (after > low and after < high):
                after = half * (low + high)
            s = after
        return s

    @wp.func(inline=INLINE)
    def lag_friction(model: Model, state: State, scratch: Scratch, env: int):
        """Gathers this step's near pairs where the last list may miss one (``stale`` at the
        prediction q̃; margins of twice each body's predicted ``motion``, at least d̂:
        ``regather``), then freezes for the step, per pair closer than d̂ at q_n, the normal
        force dt² λ into scratch.friction_normal (friction's weight: the barrier's
        −dt² db/dd plus the last step's damping force c (min(d_{n−1}, d̂) − d_n)/dt, at most
        as much again as the barrier's while the pair approached and never below 0 while it
        opened: friction sees the load the damper carries, not an impact's spike), the
        contact damping c·dt = 2ζ √(b''(d_n) m_eff) dt into scratch.normal_damping (0 for
        the others) and its ``release`` into scratch.damping_release; an edge pair's
        mollifier weighs them. Every listed pair's distance at q_n goes to scratch.gap_n (the
        bound that lets a step's passes skip the pairs surely beyond d̂). Returns how many
        pairs the step cannot resolve: beyond d̂ at q_n and closer than (1 − ARRIVING) d̂ at
        the prediction q̃ (an impact arrives), or stiffer than STIFF m_eff/dt² (deep in the
        barrier); −1 where the list outgrew its room (``relist``: nothing lagged, the step is
        rejected)."""
        # taken again after its list outgrew the room in Newton's search, the step finds this
        # step's damping in its list: the last step's is kept beside it (damping_before)
        again = scratch.near_full[env] != 0
        scratch.near_full[env] = 0
        old = scratch.near_count[env]
        arriving = int(-1)
        count = int(0)
        # the last list where it holds every pair the prediction may reach
        if refresh(model, scratch.q_tilde, scratch, env, 0) != 0:
            arriving = 0
            count = scratch.near_count[env]
        else:       # not taken: the list holds the last step's damping (taken again: ``again``)
            for k in range(old):
                scratch.damping_before[env, k] = scratch.normal_damping[env, k]
                scratch.gap_n[env, k] = zero        # the last step's: unknown at this q_n
        measure(model, scratch.q_tilde, scratch.q_tilde, scratch, env, 0)
        for k in range(count):
            p = scratch.near_pairs[env, k]
            body, other = pair_bodies(model, p)
            qb = scratch.q_n[env, body]
            qo = other_state(scratch.q_n, env, body, other)
            force = zero
            stiffness = zero
            last_damping = scratch.normal_damping[env, k]
            if again:
                last_damping = scratch.damping_before[env, k]
            scratch.damping_before[env, k] = last_damping
            d, n, rest, radius, rest_o, radius_o = pair_gap(model, qb, qo, p)
            scratch.gap_n[env, k] = d
            damping = zero
            if d >= model.contact_d_hat:
                if not surely_beyond(model, scratch, env, k, body, other,
                                     arrival * model.contact_d_hat):
                    d_tilde, n_t, rest_t, rest_ot = clamped_gap(
                        model, scratch.q_tilde, env, p, body, other)
                    if d_tilde < arrival * model.contact_d_hat:
                        arriving += 1
            elif d > zero:
                e, b1, b2 = barrier(model, d)
                weight = pair_weight(model, qb, qo, p)
                stiffness = wp.max(weight * b2, zero)
                force = -model.dt * model.dt * weight * b1
                mass = pair_mass(model, scratch, env, body, other, rest, radius, rest_o,
                                 radius_o, n)
                if stiffness * model.dt * model.dt > stiff * mass:
                    arriving += 1
                if model.contact_damping > zero:
                    damping = (two * model.contact_damping * wp.sqrt(stiffness * mass)
                               * model.dt)
                    scratch.damping_release[env, k] = release(
                        model, d, damping, model.dt * model.dt * weight)
                if last_damping > zero:
                    d_prev, n_prev, r_prev, rr_prev, ro_prev, rro_prev = gap_between(
                        model, state.q_prev, env, p, body, other)
                    force += wp.clamp(last_damping * (wp.min(d_prev, model.contact_d_hat) - d),
                                      -force, force)
            scratch.friction_normal[env, k] = force
            scratch.normal_damping[env, k] = damping
        return arriving

    @wp.func
    def push(scratch: Scratch, env: int, body: int, other: int, coefficient: scalar,
             w: vec12, w_other: vec12):
        """−coefficient·∇ into scratch.rhs of a pair's bodies (gradient w, w_other)."""
        scratch.rhs[env, body] -= coefficient * w
        if wp.static(bodies):
            if other >= 0:
                scratch.rhs[env, other] -= coefficient * w_other

    @wp.func
    def couple(model: Model, scratch: Scratch, env: int, body: int, other: int, block: mat12):
        """Add H[body, other] = ``block`` to the pair of bodies' coupling block (stored as
        H[touch_a, touch_b]); the first this iterate replaces what the last one left."""
        j = model.touch_slot[body, other]
        oriented = block
        if model.touch_a[j] != body:
            oriented = wp.transpose(block)
        if scratch.block_used[env, j] == 0:
            scratch.contact_block[env, j] = oriented
            scratch.block_used[env, j] = 1
        else:
            scratch.contact_block[env, j] += oriented

    @wp.func
    def clamped_gap(model: Model, q: wp.array2d(dtype=vec12), env: int, p: int, body: int,
                    other: int):
        """(min(d(q), d̂) [m] of pair p (bodies ``body``, ``other``: ``pair_bodies``): its
        distance within the barrier's reach; its normal n and rest points x̄, ȳ at q)."""
        d, n, rest, radius, rest_o, radius_o = gap_between(model, q, env, p, body, other)
        return wp.min(d, model.contact_d_hat), n, rest, rest_o

    @wp.func
    def impact(model: Model, state: State, scratch: Scratch, env: int):
        """1 if a listed pair's normal speed within d̂ turned in the step to state.q:
        |Δ² min(d, d̂)| over q_{n−1}, q_n, q above IMPACT_ACCELERATION dt² or IMPACT_SHARE d̂,
        whichever is less (an impact, a stop or a push-out: BDF2's two-step history would
        carry that turn on as a push; a contact resting, rolling or sliding keeps its speed),
        else 0. With D the larger drift of q and q_{n−1} (``measure_drift``), |Δ²| ≤ 2D: a
        pair whose 2D is within half the limit is skipped, and one surely beyond d̂ at both
        (``surely_beyond``: at d̂ at all three); the distance at q_n is the lag's."""
        limit = wp.min(impact_acceleration * model.dt * model.dt,
                       impact_share * model.contact_d_hat)
        d_hat = model.contact_d_hat
        measure(model, state.q, state.q_prev, scratch, env, 0)
        found = int(0)
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            body, other = pair_bodies(model, p)
            if two * pair_drift(scratch, env, body, other) > half * limit and not surely_beyond(
                    model, scratch, env, k, body, other, d_hat):
                d, n, rest, rest_o = clamped_gap(model, state.q, env, p, body, other)
                d_n = scratch.gap_n[env, k]     # the lag's (0 where unknown)
                if d_n <= zero:
                    d_n, n_n, rest_n, rest_on = clamped_gap(model, scratch.q_n, env, p, body,
                                                            other)
                d_p, n_p, rest_p, rest_op = clamped_gap(model, state.q_prev, env, p, body,
                                                        other)
                if wp.abs(d - two * wp.min(d_n, d_hat) + d_p) > limit:
                    found = 1
        return found

    @wp.func
    def damper_of(model: Model, scratch: Scratch, env: int, k: int, p: int, d: scalar,
                  d_n: scalar):
        """(Ψ [J·s²], dΨ/dd [N·s²], d²Ψ/dd² [kg]) of the contact damper of the k-th listed
        pair p at d = min(d(q), d̂), a = d − d_n, d_n = min(d(q_n), d̂): ½ c dt a², a viscous
        force −c ḋ (ḋ ≈ a/dt) against the contact's approach and its opening, until the
        opening pair passes its ``release`` s; beyond s the damper pulls exactly as hard as
        the barrier pushes, Ψ = ½ c dt (s − d_n)² + dt² w (b(s) − b(d)) (a contact is never
        pulled), and its curvature cancels the barrier's (``add_pairs``). Flat beyond d̂."""
        c = scratch.normal_damping[env, k]
        s = scratch.damping_release[env, k]
        energy = half * c * (d - d_n) * (d - d_n)
        gradient = c * (d - d_n)
        curvature = c
        if d > s:
            body, other = pair_bodies(model, p)
            weight = model.dt * model.dt * pair_weight(
                model, scratch.q_n[env, body], other_state(scratch.q_n, env, body, other), p)
            e_s, b1_s, b2_s = barrier(model, s)
            e, b1, b2 = barrier(model, d)
            energy = half * c * (s - d_n) * (s - d_n) + weight * (e_s - e)
            gradient = -weight * b1
            curvature = -weight * wp.max(b2, zero)
        return energy, gradient, curvature

    @wp.func
    def damper(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, k: int):
        """(Ψ, dΨ/dd, d²Ψ/dd², n, x̄, ȳ) of the k-th listed pair's damper at q
        (``damper_of``), with its normal and rest points at q."""
        p = listed_pair(model, scratch, env, k)
        body, other = pair_bodies(model, p)
        d, n, rest, rest_o = clamped_gap(model, q, env, p, body, other)
        d_n, n_n, rest_n, rest_on = clamped_gap(model, scratch.q_n, env, p, body, other)
        energy, gradient, curvature = damper_of(model, scratch, env, k, p, d, d_n)
        return energy, gradient, curvature, n, rest, rest_o

    @wp.func
    def slip_of(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, p: int,
                body: int, other: int, n: vec3, rest_n: vec3, radius: scalar, rest_other: vec3,
                radius_o: scalar):
        """(u₁, u₂, t₁, t₂, x̄_c, ȳ_c): the tangential displacement [m] since the start of the
        step, along pair p's friction basis (t₁, t₂ = n × t₁) lagged at q_n (its normal n and
        rest points there: ``gap_at`` at q_n), of the material point that touches, x̄_c
        (``touch_rest`` at q_n: a sphere's or capsule's surface point, so friction turns it),
        relative to the other body's, ȳ_c, where that moves: u's gradients are J(x̄_c)ᵀ t over
        the body and −J(ȳ_c)ᵀ t over the other."""
        q_n = scratch.q_n[env, body]
        rest = touch_rest(q_n, rest_n, radius, n)
        rest_o = rest_other
        moved = world_point(q[env, body], rest) - world_point(q_n, rest)
        t1 = pair_tangent(model, p, n)
        t2 = wp.cross(n, t1)
        if wp.static(bodies):
            if other >= 0:
                q_o = scratch.q_n[env, other]
                rest_o = touch_rest(q_o, rest_o, radius_o, -n)
                moved -= world_point(q[env, other], rest_o) - world_point(q_o, rest_o)
        return wp.dot(t1, moved), wp.dot(t2, moved), t1, t2, rest, rest_o

    @wp.func
    def slip(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, p: int,
             body: int, other: int):
        """``slip_of`` with pair p's normal and rest points at q_n."""
        d, n, rest, radius, rest_o, radius_o = gap_at(model, scratch.q_n, env, p)
        return slip_of(model, q, scratch, env, p, body, other, n, rest, radius, rest_o,
                       radius_o)

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
    def frame_block(s: mat33, x: vec3, y: vec3):
        """J(x̄)ᵀ S J(ȳ) [12×12] of a 3×3 world matrix S between the rest points x̄ (rows) and
        ȳ (columns): q's entries are p and A's rows, so entry ((r, a), (t, b)) is
        S[r, t] u_a v_b with u = (1, x̄), v = (1, ȳ). A contact's Hessian along its normal and
        tangents is c n nᵀ and Σ h t tᵀ in the world: one product per entry."""
        out = mat12()
        for r in range(3):
            for c in range(3):
                st = s[r, c]
                out[r, c] = st
                for b in range(3):
                    out[r, 3 + 3 * c + b] = st * y[b]
                for a in range(3):
                    sa = st * x[a]
                    out[3 + 3 * r + a, c] = sa
                    for b in range(3):
                        out[3 + 3 * r + a, 3 + 3 * c + b] = sa * y[b]
        return out

    @wp.func
    def friction_hessian(weight: scalar, f1_over_y: scalar, u1: scalar, u2: scalar, y: scalar,
                         eps: scalar):
        """(h11, h12, h22): IPC's PSD friction Hessian in the tangent plane at slip (u1, u2),
        |u| = y, for the weight μλ (dt² λ lagged)."""
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
        return h11, h12, h22

    @wp.func
    def pairs_energy(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int):
        """The listed pairs' energy at q [J·s²]: the barrier's dt² Σ m b over the pairs closer
        than d̂ (m: ``pair_weight``; +∞ if a pair is at or beyond the boundary), friction's
        Σ μ dt²λ f0(|u|) over those with a lagged normal force and the damper's Σ Ψ over
        those with lagged damping (``damper_of``): one pass, each pair's distance taken once
        at q (none surely beyond d̂ without a lagged term: ``surely_beyond``) and, for
        friction and damping, once at q_n."""
        barrier_energy = zero
        friction_energy = zero
        damping_energy = zero
        eps = model.contact_eps_velocity * model.dt
        d_hat = model.contact_d_hat
        measure(model, q, q, scratch, env, 0)
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            body, other = pair_bodies(model, p)
            on = pair_on(model, p)
            damping = scratch.normal_damping[env, k]
            force = scratch.friction_normal[env, k]
            if damping > zero or force > zero or (
                    on and not surely_beyond(model, scratch, env, k, body, other, d_hat)):
                d, n, rest, radius, rest_o, radius_o = gap_between(model, q, env, p, body,
                                                                   other)
                if on:
                    if d <= zero:
                        barrier_energy = infinity
                    elif d < d_hat:
                        e, b1, b2 = barrier(model, d)
                        weight = pair_weight(model, scratch.q_n[env, body],
                                             other_state(scratch.q_n, env, body, other), p)
                        barrier_energy += model.dt * model.dt * weight * e
                if damping > zero or force > zero:
                    d_n, n_n, rest_n, radius_n, rest_on, radius_on = gap_between(
                        model, scratch.q_n, env, p, body, other)
                    if force > zero:
                        u1, u2, t1, t2, rest_c, rest_oc = slip_of(
                            model, q, scratch, env, p, body, other, n_n, rest_n, radius_n,
                            rest_on, radius_on)
                        f0, f1_over_y = smooth_friction(wp.sqrt(u1 * u1 + u2 * u2), eps)
                        friction_energy += friction_weight(model, scratch, env, k, p, body,
                                                           other) * f0
                    if damping > zero:
                        psi, dpsi, ddpsi = damper_of(model, scratch, env, k, p,
                                                     wp.min(d, d_hat), wp.min(d_n, d_hat))
                        damping_energy += psi
        return barrier_energy + friction_energy + damping_energy

    @wp.func
    def add_pairs(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                  hessian: int):
        """The listed pairs' gradients into scratch.rhs and, with ``hessian``, their Hessians
        into the diagonal blocks and a pair of bodies' coupling, in one pass, each pair's
        distance taken once at q (none surely beyond d̂ without a lagged term:
        ``surely_beyond``) and, for friction and damping, once at q_n, and each of its
        blocks written once: the barrier's and the damper's along the normal (dΨ/dd w and the
        curvature w wᵀ, the distance's own left out: with the barrier's, never negative) and
        friction's (IPC's PSD closed forms in the tangent plane, Σ h t tᵀ in the world),
        each block the product of those world 3×3 matrices with the rest points
        (``frame_block``)). Returns the active pairs plus those with friction (an active
        barrier's or friction's curvature changes fast: no last factors)."""
        count = int(0)
        dt2 = model.dt * model.dt
        eps = model.contact_eps_velocity * model.dt
        d_hat = model.contact_d_hat
        measure(model, q, q, scratch, env, 0)
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            body, other = pair_bodies(model, p)
            on = pair_on(model, p)
            damping = scratch.normal_damping[env, k]
            force = scratch.friction_normal[env, k]
            if damping > zero or force > zero or (
                    on and not surely_beyond(model, scratch, env, k, body, other, d_hat)):
                d, n, rest, radius, rest_o, radius_o = gap_between(model, q, env, p, body,
                                                                   other)
                w = jacobian_transpose(rest, n)
                w_o = -jacobian_transpose(rest_o, n)
                slope = zero            # along the normal: dE/dd and d²E/dd²
                curvature = zero
                acts = damping > zero   # a term of this pair acts at q
                if on and d > zero and d < d_hat:
                    count += 1
                    acts = True
                    e, b1, b2 = barrier(model, d)
                    weight = dt2 * pair_weight(model, scratch.q_n[env, body],
                                               other_state(scratch.q_n, env, body, other), p)
                    slope = weight * b1
                    curvature = weight * wp.max(b2, zero)
                grad = slope * w        # the gradient over the body and the other
                grad_o = slope * w_o
                rubs = False            # friction acts: its world Hessian between x̄_c, ȳ_c
                rub = mat33()
                rest_c = rest
                rest_oc = rest_o
                if damping > zero or force > zero:
                    d_n, n_n, rest_n, radius_n, rest_on, radius_on = gap_between(
                        model, scratch.q_n, env, p, body, other)
                    mu_force = friction_weight(model, scratch, env, k, p, body, other)
                    if mu_force > zero:
                        count += 1
                        acts = True
                        u1, u2, t1, t2, rest_c, rest_oc = slip_of(
                            model, q, scratch, env, p, body, other, n_n, rest_n, radius_n,
                            rest_on, radius_on)
                        y = wp.sqrt(u1 * u1 + u2 * u2)
                        f0, f1_over_y = smooth_friction(y, eps)
                        pull = mu_force * f1_over_y * (u1 * t1 + u2 * t2)
                        grad += jacobian_transpose(rest_c, pull)
                        grad_o -= jacobian_transpose(rest_oc, pull)
                        h11, h12, h22 = friction_hessian(mu_force, f1_over_y, u1, u2, y, eps)
                        rubs = True
                        rub = (h11 * wp.outer(t1, t1) + h12 * (wp.outer(t1, t2) + wp.outer(t2, t1))
                               + h22 * wp.outer(t2, t2))
                    if damping > zero:
                        psi, dpsi, ddpsi = damper_of(model, scratch, env, k, p,
                                                     wp.min(d, d_hat), wp.min(d_n, d_hat))
                        grad += dpsi * w
                        grad_o += dpsi * w_o
                        curvature += ddpsi
                if acts:
                    push(scratch, env, body, other, one, grad, grad_o)
                if acts and hessian != 0:
                    press = curvature * wp.outer(n, n)      # the normal's world Hessian
                    own = frame_block(press, rest, rest)
                    if rubs:
                        own += frame_block(rub, rest_c, rest_c)
                    scratch.hessian[env, body] += own
                    if wp.static(bodies):
                        if other >= 0:
                            theirs = frame_block(press, rest_o, rest_o)
                            across = frame_block(-press, rest, rest_o)
                            if rubs:
                                theirs += frame_block(rub, rest_oc, rest_oc)
                                across += frame_block(-rub, rest_c, rest_oc)
                            scratch.hessian[env, other] += theirs
                            couple(model, scratch, env, body, other, across)
        return count

    @wp.func
    def advance_bound(model: Model, scratch: Scratch, env: int, p: int, body: int,
                      other: int):
        """Conservative advancement along q_start + α dq for an edge, face or body pair: its
        distance changes at most ``reach`` per unit α, so from a distance d at α it keeps
        η d₀ up to α + (d − η d₀)/reach; repeated until the gap is within 2 η d₀ (the first
        time it would close), α = 1, or ``ADVANCE_STEPS`` steps."""
        q0 = scratch.q_start[env, body]
        dq = scratch.dq[env, body]
        q0_o = other_state(scratch.q_start, env, body, other)
        dq_o = other_state(scratch.dq, env, body, other)
        d, n, rest, radius, rest_o, radius_o = pair_gap(model, q0, q0_o, p)
        rate = reach(model, dq, dq_o, p)
        alpha = one
        if d <= zero:
            alpha = zero
        elif rate > keep * d:
            floor = (one - keep) * d
            alpha = zero
            for k in range(ADVANCE_STEPS):
                alpha = wp.min(alpha + (d - floor) / rate, one)
                if alpha < one:
                    d, n, rest, radius, rest_o, radius_o = pair_gap(
                        model, q0 + alpha * dq, q0_o + alpha * dq_o, p)
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
        (exact for half-spaces, conservative for shapes); an edge's or face's distance, or
        that of two bodies, is neither, and advances conservatively (``advance_bound``); the
        pairs not listed stay beyond d̂ (``cover``). A pair whose points move along the
        whole path by less than η of its distance at q_start (``surely_beyond`` 0 of each
        body's drift at q_start plus its ``motion`` under dq over 1 − η) keeps α = 1:
        skipped."""
        cover(model, scratch.q_start, scratch, env, 1)
        measure(model, scratch.q_start, scratch.q_start, scratch, env, 1)
        alpha = one
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            body, other = pair_bodies(model, p)
            if pair_on(model, p) and not surely_beyond(model, scratch, env, k, body, other,
                                                       zero):
                if p < point_pairs(model):
                    d, n, rest, radius, rest_o, radius_o = gap_between(
                        model, scratch.q_start, env, p, body, other)
                    rate = wp.dot(jacobian_transpose(rest, n), scratch.dq[env, body])
                    if rate < zero:
                        alpha = wp.min(alpha, keep * d / (-rate))
                elif wp.static(shapes):
                    alpha = wp.min(alpha, advance_bound(model, scratch, env, p, body, other))
        return alpha

    @wp.func(inline=INLINE)
    def touching(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                 every_point: int):
        """(smallest distance [m] of a pair that may touch, +∞ without any; pairs closer than
        d̂) at q, over the listed pairs (the others are beyond d̂; a listed one surely beyond
        d̂ and the nearest so far is skipped), with ``every_point`` (the statistics) also over
        every point pair with a static side where no listed pair is within d̂ (else none of
        those can be nearer: the same minimum, without a pass over every point pair)."""
        nearest = infinity
        active = int(0)
        measure(model, q, q, scratch, env, 0)
        for k in range(listed(model, scratch, env)):
            p = listed_pair(model, scratch, env, k)
            body, other = pair_bodies(model, p)
            if not surely_beyond(model, scratch, env, k, body, other,
                                 wp.max(model.contact_d_hat, nearest)):
                d, n, rest, radius, rest_o, radius_o = gap_between(model, q, env, p, body,
                                                                   other)
                nearest = wp.min(nearest, d)
                if d < model.contact_d_hat:
                    active += 1
        if every_point != 0 and not (nearest < model.contact_d_hat):
            things = statics(model)
            for p in range(point_pairs(model)):
                if model.pair_on[p] != 0:
                    i = p / things
                    d, n = distance(model, q[env, model.point_body[i]], i, p - i * things)
                    nearest = wp.min(nearest, d)
        return nearest, active

    return SimpleNamespace(barrier=barrier, cover=cover, gather_near=gather_near,
                           lag_friction=lag_friction, pairs_energy=pairs_energy,
                           add_pairs=add_pairs,
                           step_bound=step_bound, touching=touching, impact=impact,
                           listed=listed, listed_pair=listed_pair, damper=damper,
                           pair_friction=pair_friction, friction_loaded=friction_loaded,
                           slip=slip,
                           smooth_friction=smooth_friction)
