"""The active contacts of a state, host side (``Stepper.contacts``, sensors, markers;
README.md#contact).

A pair is active when its distance is below d̂, or when forces were lagged for it at the
step's start (they act until the step ends). Its normal force is the barrier's push −db/dd
[N] at the state's distance, plus the contact damping's c max(d_n − d, 0)/dt against its
approach, c frozen at the step's start (``scratch.normal_damping`` / dt); its friction force
the lagged smoothed Coulomb friction of the last step: μ λ (f1(|u|)/|u|) against the slip u
since the step's start, λ the normal force frozen at that start (``scratch.friction_normal``
/ dt²). These are the forces the step balanced, as ``physics.contact`` computes them,
evaluated once more in plain NumPy (the last bits may differ from the kernel's, and between
machines).
"""

import math

import numpy as np

from affine_joint_sim.physics.contact_model import tangent
from affine_joint_sim.physics.pair_geometry import pair_gap, pair_weight
from affine_joint_sim.physics.static_shapes import SHAPE_KINDS

__all__ = ['barrier_energy', 'barrier_force', 'active_contacts']


def barrier_energy(d: float, d_hat: float, kappa: float) -> float:
    """b [J] of the barrier b(D) = −κ (D − D̂)² ln(D/D̂), D = d², at 0 < d < d̂."""
    big, big_hat = d * d, d_hat * d_hat
    return -kappa * (big - big_hat) ** 2 * math.log(big / big_hat)


def barrier_force(d: float, d_hat: float, kappa: float) -> float:
    """−db/dd [N] of the barrier b(D) = −κ (D − D̂)² ln(D/D̂), D = d², at 0 < d < d̂."""
    big, big_hat = d * d, d_hat * d_hat
    gap = big - big_hat
    return 2.0 * kappa * d * (2.0 * gap * math.log(big / big_hat) + gap * gap / big)


def _world(q_body, rest) -> np.ndarray:
    return q_body[:3] + q_body[3:].reshape(3, 3) @ rest


def active_contacts(host, q, q_n, friction_normal, normal_damping, body_names,
                    static_names) -> list[dict]:
    """The active contact pairs of one environment at states ``q`` (n_bodies, 12), the last
    step having started at ``q_n`` with lagged normal forces ``friction_normal`` (pairs,)
    [N·s²] and damping ``normal_damping`` (pairs,) [kg].

    Each is a dict: ``body`` (the moving body's name), ``other`` (the half-space's or fixed
    body's name), ``point`` (the nearest point of the other's surface [m, world]),
    ``normal`` (unit, from the other towards the body), ``distance`` [m], ``normal_force``
    [N] and ``friction_force`` (3-vector [N, world], on the body).
    """
    model = vars(host)
    dt2 = float(host.dt) ** 2
    out = []
    for pair in _candidates(host, q, friction_normal, normal_damping):
        gap = pair_gap(model, q, pair)
        d = gap.distance
        lagged = friction_normal[pair] > 0.0 or normal_damping[pair] > 0.0
        if not (0.0 < d < host.contact_d_hat or (lagged and d > 0.0)):
            continue
        force = np.zeros(3)
        if friction_normal[pair] > 0.0:
            force = _friction(host, q, q_n, pair, friction_normal[pair] / dt2)
        push = pair_weight(model, q_n, pair) * barrier_force(
            d, host.contact_d_hat, host.contact_kappa) if d < host.contact_d_hat else 0.0
        if normal_damping[pair] > 0.0:
            d_n = pair_gap(model, q_n, pair).distance
            push += normal_damping[pair] * max(d_n - d, 0.0) / dt2
        out.append({'body': body_names[gap.body], 'other': static_names[gap.static],
                    'point': gap.point, 'normal': np.asarray(gap.normal),
                    'distance': float(d), 'normal_force': push, 'friction_force': force})
    return out


def _candidates(host, q, friction_normal, normal_damping) -> list[int]:
    """Pairs that may touch and may be closer than d̂, found for every pair of a family at
    once by a lower bound of its distance (the exact distance to a half-space; between the
    bounding spheres of a point and a shape, of two segments, of a triangle and a vertex),
    and those with forces lagged at the step's start (friction and damping act on them even
    once they are beyond d̂). The pairs are then evaluated one by one."""
    near = np.concatenate([_near_points(host, q), _near_edges(host, q), _near_faces(host, q)])
    near &= host.pair_on != 0
    near |= (friction_normal > 0.0) | (normal_damping > 0.0)   # lagged: they acted on it
    return [int(p) for p in np.flatnonzero(near)]


def _near_points(host, q) -> np.ndarray:
    body, radius = host.point_body, host.point_radius
    x = q[body, :3] + np.einsum('nij,nj->ni', q[body, 3:].reshape(-1, 3, 3), host.point_rest)
    planes, shapes = len(host.plane_offset), len(host.shape_kind)
    near = np.zeros((len(body), planes + shapes), dtype=bool)
    if planes:
        near[:, :planes] = (x @ host.plane_normal.T - host.plane_offset - radius[:, None]
                            < host.contact_d_hat)
    for s in range(shapes):
        near[:, planes + s] = (np.linalg.norm(x - host.shape_center[s], axis=1)
                               - _bounding_radius(host.shape_kind[s], host.shape_size[s])
                               - radius < host.contact_d_hat)
    return near.reshape(-1)


def _ball(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres, radii) of spheres holding each row's points (k, m, 3)."""
    centre = points.mean(axis=1)
    return centre, np.linalg.norm(points - centre[:, None], axis=2).max(axis=1, initial=0.0)


def _moved(q, bodies, rests) -> np.ndarray:
    """World points (k, m, 3) of rest points ``rests`` (k, m, 3) on ``bodies`` (k,)."""
    return q[bodies, None, :3] + np.einsum('kij,kmj->kmi', q[bodies, 3:].reshape(-1, 3, 3),
                                           rests)


def _near_edges(host, q) -> np.ndarray:
    ends = _moved(q, host.edge_body, np.stack([host.edge_a, host.edge_b], axis=1))
    centre, reach = _ball(ends)
    other, other_reach = _ball(np.stack([host.static_edge_a, host.static_edge_b], axis=1))
    gap = (np.linalg.norm(centre[:, None] - other[None], axis=2) - reach[:, None]
           - other_reach[None] - host.edge_radius[:, None] - host.static_edge_radius[None])
    return (gap < host.contact_d_hat).reshape(-1)


def _near_faces(host, q) -> np.ndarray:
    corners = _moved(q, host.face_body, np.transpose(host.face_rest, (0, 2, 1)))
    centre, reach = _ball(corners)
    gap = (np.linalg.norm(centre[:, None] - host.static_vertex[None], axis=2)
           - reach[:, None] - host.static_vertex_radius[None])
    return (gap < host.contact_d_hat).reshape(-1)


def _bounding_radius(kind: int, size) -> float:
    """The radius [m] of a sphere about a shape's centre that holds it."""
    if kind == SHAPE_KINDS['box']:
        return float(np.linalg.norm(size))
    if kind == SHAPE_KINDS['sphere']:
        return float(size[0])
    if kind == SHAPE_KINDS['capsule']:
        return float(size[0] + size[1])
    return float(math.hypot(size[0], size[1]))


def _friction(host, q, q_n, pair: int, lam: float) -> np.ndarray:
    """The friction force [N, world] of ``pair``: −μ λ (f1(y)/y) u, u the slip since q_n of
    the material point that touches, in the basis lagged at q_n (the kernel's ``slip``)."""
    start = pair_gap(vars(host), q_n, pair)
    b, rest, n = start.body, start.rest, start.normal
    if start.radius > 0.0:              # the material point that touches, as the kernel
        rest = rest - start.radius * np.linalg.solve(q_n[b, 3:].reshape(3, 3), n)
    things = len(host.plane_offset) + len(host.shape_kind)
    g = pair - (pair // things) * things if things else 0
    point_pair = pair < len(host.point_body) * things
    t1 = host.plane_tangent[g] if point_pair and g < len(host.plane_offset) else tangent(n)
    t2 = np.array([n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2],
                   n[0] * t1[1] - n[1] * t1[0]])          # n × t₁ (np.cross costs 60 µs)
    moved = _world(q[b], rest) - _world(q_n[b], rest)
    u1, u2 = float(t1 @ moved), float(t2 @ moved)
    y = math.hypot(u1, u2)
    eps = host.contact_eps_velocity * host.dt
    f1_over_y = 1.0 / y if y >= eps else (2.0 * eps - y) / (eps * eps)
    return -host.pair_friction[pair] * lam * f1_over_y * (u1 * t1 + u2 * t2)
