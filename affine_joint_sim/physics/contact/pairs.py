"""The geometry of contact pairs in NumPy, host side: each pair's distance, normal and nearest
points as the kernel's ``contact.geometry.pair_gap`` computes them (refusing a touching scene,
``Stepper.energy``, ``Stepper.contacts``; the last bits may differ from the kernel's).

Pairs are numbered as in the model (physics.host.fields ``pair``): point × static thing, then
moving edge × static edge, then moving face × static vertex (the static pairs), then the pairs
of bodies that may touch (``touch_blocks``).
"""

import math

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.physics.contact.kinds import (BOX, CAPSULE, EDGE_EDGE, POINT_FACE, SPHERE,
                                                    TOUCH_CHUNK)
from affine_joint_sim.physics.contact.shapes import shape_separation, triangle_weights

__all__ = ['Gap', 'body_pair', 'near_pairs', 'pair_gap', 'pair_total', 'pair_weight',
           'pair_distances', 'point_distances', 'segment_params', 'touch_blocks', 'touch_chunks',
           'touch_first']


class Gap:
    """One pair at one state: ``body`` (moving), ``distance`` d [m], ``normal`` (unit, from the
    other side towards the body), ``rest`` (x̄ of the moving side's nearest point, body
    frame), ``radius`` (of the moving side [m]) and ``point`` (the nearest point of the other
    side's surface [m, world]); ``static`` indexes the names of the static things, then of the
    static edges' and vertices' fixed bodies (HostModel.static_names), or is None where the
    other side is the moving body ``other``, whose nearest point has rest position
    ``other_rest`` and radius ``other_radius``."""

    def __init__(self, body, distance, normal, rest, radius, point, static, other=None,
                 other_rest=None, other_radius=0.0):
        self.body, self.distance, self.normal = int(body), float(distance), normal
        self.rest, self.radius, self.point, self.static = rest, float(radius), point, static
        self.other, self.other_rest, self.other_radius = other, other_rest, float(other_radius)


def segment_params(a, b, c, e) -> tuple[float, float]:
    """(s, t) ∈ [0, 1]² of the nearest points a + s (b − a), c + t (e − c) of two segments (the
    kernel's ``segment_params``)."""
    d1, d2, r = b - a, e - c, a - c
    aa, ee, f = pm.dot(d1, d1), pm.dot(d2, d2), pm.dot(d2, r)
    s = t = 0.0
    if aa <= 0.0 < ee:
        t = min(max(f / ee, 0.0), 1.0)
    elif aa > 0.0:
        cc = pm.dot(d1, r)
        if ee <= 0.0:
            s = min(max(-cc / aa, 0.0), 1.0)
        else:
            bb = pm.dot(d1, d2)
            denominator = aa * ee - bb * bb
            if denominator > 0.0:
                s = min(max((bb * f - cc * ee) / denominator, 0.0), 1.0)
            t = (bb * s + f) / ee
            if t < 0.0:
                t, s = 0.0, min(max(-cc / aa, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((bb - cc) / aa, 0.0), 1.0)
    return s, t


def _world(q_body, rest) -> np.ndarray:
    return q_body[:3] + pm.matmul(q_body[3:].reshape(3, 3), rest)


def _families(model) -> tuple[int, int, int]:
    """(statics, point pairs, edge pairs) of a model (a dict of its fields)."""
    things = len(model['plane_offset']) + len(model['shape_kind'])
    return (things, len(model['point_body']) * things,
            len(model['edge_body']) * len(model['static_edge_a']))


def _unit(gap) -> tuple[float, np.ndarray]:
    length = pm.norm(gap)
    return length, gap / length if length > 0.0 else np.array([0.0, 0.0, 1.0])


def pair_total(model) -> int:
    """How many pairs ``model`` (a dict of its fields) numbers: the static ones, then those of
    the pairs of bodies that may touch each other."""
    return len(model['pair_on']) + int(model['touch_first'][-1])


def touch_blocks(model, j: int) -> list[tuple[int, range, range]]:
    """The pairs of the j-th pair of bodies (touch_a, touch_b) = (a, b) that may touch, as
    three blocks (family code: contact.kinds.BODY_FAMILIES; the first sides; the other
    sides), each numbered row by row: the points of a against the faces of b, the points of b
    against the faces of a, the edges of a against the edges of b."""
    a, b = int(model['touch_a'][j]), int(model['touch_b'][j])

    def of(kind, body):
        first = model[f'body_first_{kind}']
        return range(int(first[body]), int(first[body + 1]))
    return [(family.code, of(family.first, first), of(family.other, other))
            for family, first, other in ((POINT_FACE, a, b), (POINT_FACE, b, a),
                                         (EDGE_EDGE, a, b))]


def touch_first(model) -> np.ndarray:
    """Where each pair of bodies' pairs start after the static ones, and their end (touch
    + 1,): the model field ``touch_first`` of a dict of the other fields."""
    sizes = [sum(len(first) * len(other) for _, first, other in touch_blocks(model, j))
             for j in range(len(model['touch_a']))]
    return np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)]).astype(np.int32)


def touch_chunks(first: np.ndarray) -> np.ndarray:
    """The model field ``touch_chunk`` of ``touch_first`` (``first``): for c = 0 … end //
    TOUCH_CHUNK, the touch pair j with first[j] ≤ c·TOUCH_CHUNK < first[j + 1] (0 where no
    pair of bodies has pairs), from which the search for the touch pair of the k-th pair of
    bodies, k in c's chunk, goes forward over the few touch pairs that start within it."""
    starts = np.arange(int(first[-1]) // TOUCH_CHUNK + 1, dtype=np.int64) * TOUCH_CHUNK
    j = np.searchsorted(first, starts, side='right') - 1
    return np.clip(j, 0, max(len(first) - 2, 0)).astype(np.int32)


def body_pair(model, k: int) -> tuple[int, int, int]:
    """(family code, contact.kinds.BODY_FAMILIES; the first side's point or edge; the other
    side's face or edge) of the k-th pair of bodies (``touch_blocks``)."""
    j = int(np.searchsorted(model['touch_first'], k, side='right')) - 1
    k -= int(model['touch_first'][j])
    for family, first, other in touch_blocks(model, j):
        if k < len(first) * len(other):
            row, column = divmod(k, len(other))
            return family, first[row], other[column]
        k -= len(first) * len(other)
    raise IndexError(f'pair of bodies {k} is not numbered')


def _body_gap(model, q, k: int) -> Gap:
    """The k-th pair of bodies (``body_pair``)."""
    family, i, f = body_pair(model, k)
    if family == POINT_FACE.code:
        body, other = model['point_body'][i], model['face_body'][f]
        rest, radius = model['point_rest'][i], model['point_radius'][i]
        corners = np.asarray(model['face_rest'][f]).T
        x = _world(q[body], rest)
        weights = triangle_weights(x, *(_world(q[other], c) for c in corners))
        other_rest = weights[0] * corners[0] + weights[1] * corners[1] + weights[2] * corners[2]
        nearest = _world(q[other], other_rest)
        length, normal = _unit(x - nearest)
        return Gap(body, length - radius, normal, rest, radius, nearest, None, other,
                   other_rest)
    e, s = i, f
    body, other = model['edge_body'][e], model['edge_body'][s]
    ea, eb, sa, sb = (model[end][j] for end, j in (('edge_a', e), ('edge_b', e),
                                                    ('edge_a', s), ('edge_b', s)))
    u, w = segment_params(_world(q[body], ea), _world(q[body], eb), _world(q[other], sa),
                          _world(q[other], sb))
    rest, other_rest = ea + u * (eb - ea), sa + w * (sb - sa)
    nearest = _world(q[other], other_rest)
    length, normal = _unit(_world(q[body], rest) - nearest)
    radius, own = model['edge_radius'][e], model['edge_radius'][s]
    return Gap(body, length - radius - own, normal, rest, radius, nearest + own * normal, None,
               other, other_rest, own)


def pair_gap(model, q, p: int) -> Gap:
    """Pair ``p`` of ``model`` (a dict of its fields) at states ``q`` (n_bodies, 12)."""
    things, points, edges = _families(model)
    if p >= len(model['pair_on']):
        return _body_gap(model, q, p - len(model['pair_on']))
    if p < points:
        i, g = divmod(p, things)
        body, rest, radius = model['point_body'][i], model['point_rest'][i], \
            model['point_radius'][i]
        x = _world(q[body], rest)
        planes = len(model['plane_offset'])
        if g < planes:
            normal = model['plane_normal'][g]
            centre = pm.dot(normal, x) - model['plane_offset'][g]
        else:
            s = g - planes
            centre, normal = shape_separation(model['shape_kind'][s], model['shape_rotation'][s],
                                              model['shape_center'][s], model['shape_size'][s], x)
        return Gap(body, centre - radius, np.asarray(normal), rest, radius,
                   x - np.asarray(normal) * centre, g)
    if p < points + edges:
        e, s = divmod(p - points, len(model['static_edge_a']))
        body, ea, eb = model['edge_body'][e], model['edge_a'][e], model['edge_b'][e]
        c, other = model['static_edge_a'][s], model['static_edge_b'][s]
        u, w = segment_params(_world(q[body], ea), _world(q[body], eb), c, other)
        rest = ea + u * (eb - ea)
        nearest = c + w * (other - c)
        length, normal = _unit(_world(q[body], rest) - nearest)
        radius, own = model['edge_radius'][e], model['static_edge_radius'][s]
        return Gap(body, length - radius - own, normal, rest, radius, nearest + own * normal,
                   things + s)
    f, v = divmod(p - points - edges, len(model['static_vertex']))
    body, corners = model['face_body'][f], np.asarray(model['face_rest'][f]).T
    vertex = model['static_vertex'][v]
    weights = triangle_weights(vertex, *(_world(q[body], c) for c in corners))
    rest = weights[0] * corners[0] + weights[1] * corners[1] + weights[2] * corners[2]
    length, normal = _unit(_world(q[body], rest) - vertex)
    own = model['static_vertex_radius'][v]
    return Gap(body, length - own, normal, rest, 0.0, vertex + own * normal,
               things + len(model['static_edge_a']) + v)


def pair_weight(model, q_n, p: int) -> float:
    """The barrier's weight of pair ``p`` for a step that started at ``q_n``: IPC's
    near-parallel mollifier for an edge pair (the kernel's ``pair_weight``), else 1."""
    things, points, edges = _families(model)
    statics = len(model['pair_on'])
    family, e, s = body_pair(model, p - statics) if p >= statics else (-1, 0, 0)
    if points <= p < points + edges:
        e, s = divmod(p - points, len(model['static_edge_a']))
        other = model['static_edge_b'][s] - model['static_edge_a'][s]
        other_world = other
    elif family == EDGE_EDGE.code:
        other = model['edge_b'][s] - model['edge_a'][s]
        other_world = pm.matmul(q_n[model['edge_body'][s], 3:].reshape(3, 3), other)
    else:
        return 1.0
    own = model['edge_b'][e] - model['edge_a'][e]
    limit = 1.0e-3 * pm.dot(own, own) * pm.dot(other, other)
    cross = pm.cross(pm.matmul(q_n[model['edge_body'][e], 3:].reshape(3, 3), own), other_world)
    ratio = pm.dot(cross, cross) / limit if limit > 0.0 else 1.0
    return (2.0 - ratio) * ratio if ratio < 1.0 else 1.0


def pair_distances(q, model, count: int | None = None) -> np.ndarray:
    """The distance [m] of every static pair (the first ``count``) at states ``q``
    (n_bodies, 12), +∞ where it may not touch (pair_on 0)."""
    count = len(model['pair_on']) if count is None else count
    return np.array([pair_gap(model, q, p).distance if model['pair_on'][p] else np.inf
                     for p in range(count)])


def near_pairs(model, q, reach: float) -> np.ndarray:
    """The pairs that may touch whose distance at states ``q`` may be below ``reach`` [m]
    (ascending): every pair of a family is tested at once by a lower bound of its distance
    (the exact distance to a half-space; between the bounding spheres of a point and a
    shape, of two segments, of a triangle and a vertex or a point)."""
    near = np.concatenate([_near_points(model, q, reach), _near_edges(model, q, reach),
                           _near_faces(model, q, reach)]) & (np.asarray(model['pair_on']) != 0)
    points = _moved(q, model['point_body'], np.asarray(model['point_rest'])[:, None])[:, 0]
    faces = _ball(_moved(q, model['face_body'], np.transpose(model['face_rest'], (0, 2, 1))))
    centre, size = _ball(_moved(q, model['edge_body'],
                                np.stack([model['edge_a'], model['edge_b']], axis=1)))
    edges = centre, size + model['edge_radius']
    balls = {POINT_FACE.code: ((points, np.asarray(model['point_radius'])), faces),
             EDGE_EDGE.code: (edges, edges)}
    listed = [np.flatnonzero(near)]
    for j in range(len(model['touch_a'])):
        base = len(near) + int(model['touch_first'][j])
        for family, first, other in touch_blocks(model, j):
            mine, theirs = balls[family]
            close = _apart(tuple(x[first.start:first.stop] for x in mine),
                           tuple(x[other.start:other.stop] for x in theirs)) < reach
            listed.append(base + np.flatnonzero(close))
            base += len(first) * len(other)
    return np.concatenate(listed)


def _apart(first, second) -> np.ndarray:
    """The gaps [m] between every ball of ``first`` and of ``second``, each (centres (k, 3),
    radii (k,))."""
    return (np.linalg.norm(first[0][:, None] - second[0][None], axis=2) - first[1][:, None]
            - second[1][None])


def _near_points(model, q, reach) -> np.ndarray:
    body, radius = model['point_body'], np.asarray(model['point_radius'])
    x = _moved(q, body, np.asarray(model['point_rest'])[:, None])[:, 0]
    planes, shapes = len(model['plane_offset']), len(model['shape_kind'])
    near = np.zeros((len(body), planes + shapes), dtype=bool)
    if planes:
        near[:, :planes] = (x @ np.asarray(model['plane_normal']).T - model['plane_offset']
                            - radius[:, None] < reach)
    for s in range(shapes):
        near[:, planes + s] = (np.linalg.norm(x - model['shape_center'][s], axis=1)
                               - _bounding_radius(model['shape_kind'][s], model['shape_size'][s])
                               - radius < reach)
    return near.reshape(-1)


def _ball(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres, radii) of spheres holding each row's points (k, m, 3)."""
    centre = points.mean(axis=1)
    return centre, np.linalg.norm(points - centre[:, None], axis=2).max(axis=1, initial=0.0)


def _moved(q, bodies, rests) -> np.ndarray:
    """World points (k, m, 3) of rest points ``rests`` (k, m, 3) on ``bodies`` (k,)."""
    return q[bodies, None, :3] + np.einsum('kij,kmj->kmi', q[bodies, 3:].reshape(-1, 3, 3),
                                           rests)


def _near_edges(model, q, reach) -> np.ndarray:
    ends = _moved(q, model['edge_body'], np.stack([model['edge_a'], model['edge_b']], axis=1))
    centre, size = _ball(ends)
    other, other_size = _ball(np.stack([model['static_edge_a'], model['static_edge_b']], axis=1))
    return (_apart((centre, size + model['edge_radius']),
                   (other, other_size + model['static_edge_radius'])) < reach).reshape(-1)


def _near_faces(model, q, reach) -> np.ndarray:
    centre, size = _ball(_moved(q, model['face_body'], np.transpose(model['face_rest'], (0, 2, 1))))
    return (_apart((centre, size), (np.asarray(model['static_vertex']).reshape(-1, 3),
                                    np.asarray(model['static_vertex_radius'])))
            < reach).reshape(-1)


def _bounding_radius(kind: int, size) -> float:
    """The radius [m] of a sphere about a shape's centre that holds it."""
    if kind == BOX.code:
        return float(np.linalg.norm(size))
    if kind == SPHERE.code:
        return float(size[0])
    if kind == CAPSULE.code:
        return float(size[0] + size[1])
    return float(math.hypot(size[0], size[1]))


def point_distances(q, model) -> np.ndarray:
    """The point pairs' distances [m] at states ``q``, shape (points, planes + shapes), +∞
    where they may not touch."""
    things, points, edges = _families(model)
    return pair_distances(q, model, points).reshape(-1, things)
