"""The geometry of contact pairs in NumPy, host side: each pair's distance, normal and nearest
points as the kernel's ``contact.pair_gap`` computes them (refusing a touching scene,
``Stepper.energy``, ``Stepper.contacts``; the last bits may differ from the kernel's).

Pairs are numbered as in the model (physics.fields ``pair``): point × static thing, then
moving edge × static edge, then moving face × static vertex.
"""

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.physics.static_shapes import shape_separation, triangle_weights

__all__ = ['Gap', 'pair_gap', 'pair_weight', 'pair_distances', 'point_distances',
           'segment_params']


class Gap:
    """One pair at one state: ``body`` (moving), ``distance`` d [m], ``normal`` (unit, from the
    static side towards the body), ``rest`` (x̄ of the moving side's nearest point, body
    frame), ``radius`` (of the moving side [m]) and ``point`` (the nearest point of the static
    side's surface [m, world]); ``static`` indexes the names of the static things, then of the
    static edges' and vertices' fixed bodies (HostModel.static_names)."""

    def __init__(self, body, distance, normal, rest, radius, point, static):
        self.body, self.distance, self.normal = int(body), float(distance), normal
        self.rest, self.radius, self.point, self.static = rest, float(radius), point, static


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


def pair_gap(model, q, p: int) -> Gap:
    """Pair ``p`` of ``model`` (a dict of its fields) at states ``q`` (n_bodies, 12)."""
    things, points, edges = _families(model)
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
    if not points <= p < points + edges:
        return 1.0
    e, s = divmod(p - points, len(model['static_edge_a']))
    own = model['edge_b'][e] - model['edge_a'][e]
    other = model['static_edge_b'][s] - model['static_edge_a'][s]
    limit = 1.0e-3 * pm.dot(own, own) * pm.dot(other, other)
    cross = pm.cross(pm.matmul(q_n[model['edge_body'][e], 3:].reshape(3, 3), own), other)
    ratio = pm.dot(cross, cross) / limit if limit > 0.0 else 1.0
    return (2.0 - ratio) * ratio if ratio < 1.0 else 1.0


def pair_distances(q, model, count: int | None = None) -> np.ndarray:
    """The distance [m] of every pair (the first ``count``) at states ``q`` (n_bodies, 12),
    +∞ where it may not touch (pair_on 0)."""
    count = len(model['pair_on']) if count is None else count
    return np.array([pair_gap(model, q, p).distance if model['pair_on'][p] else np.inf
                     for p in range(count)])


def point_distances(q, model) -> np.ndarray:
    """The point pairs' distances [m] at states ``q``, shape (points, planes + shapes), +∞
    where they may not touch."""
    things, points, edges = _families(model)
    return pair_distances(q, model, points).reshape(-1, things)
