"""The contact report's reference: the active contacts of a state evaluated pair by pair in plain
NumPy from the host model (``physics.contact.pairs``), independent of the kernel that
``Stepper.contacts`` replays (``physics.contact.report``).

A pair is active when its distance is below d̂, or when friction was lagged for it at the
step's start (it acts until the step ends). Its normal force is the barrier's push −db/dd
[N] at the state's distance, plus the contact damping's −c (d − min(d_n, d̂))/dt against its
approach or opening within d̂ (the sum never below 0: a damper never pulls), c frozen at the
step's start (``scratch.normal_damping`` / dt); its friction force the lagged smoothed
Coulomb friction of the last step: μ λ (f1(|u|)/|u|) against the slip u since the step's
start, λ the normal force frozen at that start (``scratch.friction_normal`` / dt²). These are
the forces the step balanced, as ``physics.contact.terms`` computes them, evaluated once more in
plain NumPy (the last bits may differ from the kernel's, and between machines).
"""

import math

import numpy as np

from affine_joint_sim.physics.contact.model import tangent
from affine_joint_sim.physics.contact.pairs import near_pairs, pair_gap, pair_weight

__all__ = ['barrier_force', 'active_contacts']


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

    Each is a dict: ``body`` (the moving body's name), ``other`` (the half-space's, fixed
    body's or other moving body's name), ``point`` (the nearest point of the other's surface
    [m, world]), ``normal`` (unit, from the other towards the body), ``distance`` [m],
    ``normal_force`` [N] and ``friction_force`` (3-vector [N, world], on the body).
    """
    model = vars(host)
    dt2 = float(host.dt) ** 2
    out = []
    for pair in _candidates(host, q, friction_normal):
        gap = pair_gap(model, q, pair)
        d = gap.distance
        if not (0.0 < d < host.contact_d_hat or (friction_normal[pair] > 0.0 and d > 0.0)):
            continue
        force = np.zeros(3)
        if friction_normal[pair] > 0.0:
            force = _friction(host, q, q_n, pair, friction_normal[pair] / dt2)
        push = pair_weight(model, q_n, pair) * barrier_force(
            d, host.contact_d_hat, host.contact_kappa) if d < host.contact_d_hat else 0.0
        if normal_damping[pair] > 0.0 and d < host.contact_d_hat:
            d_n = min(pair_gap(model, q_n, pair).distance, host.contact_d_hat)
            push = max(push - normal_damping[pair] * (d - d_n) / dt2, 0.0)
        other = static_names[gap.static] if gap.other is None else body_names[gap.other]
        out.append({'body': body_names[gap.body], 'other': other,
                    'point': gap.point, 'normal': np.asarray(gap.normal),
                    'distance': float(d), 'normal_force': push, 'friction_force': force})
    return out


def _candidates(host, q, friction_normal) -> list[int]:
    """Pairs that may touch and may be closer than d̂ (``contact.pairs.near_pairs``), and
    those with friction lagged at the step's start (it acts on them even once they are beyond
    d̂; damping acts only within d̂). The pairs are then evaluated one by one."""
    lagged = np.flatnonzero(friction_normal > 0.0)
    return [int(p) for p in np.union1d(near_pairs(vars(host), q, host.contact_d_hat), lagged)]


def _friction(host, q, q_n, pair: int, lam: float) -> np.ndarray:
    """The friction force [N, world] of ``pair``: −μ λ (f1(y)/y) u, u the slip since q_n of
    the material point that touches, in the basis lagged at q_n (the kernel's ``slip``)."""
    start = pair_gap(vars(host), q_n, pair)
    b, n = start.body, start.normal
    rest = _touching(q_n[b], start.rest, start.radius, n)
    things = len(host.plane_offset) + len(host.shape_kind)
    g = pair - (pair // things) * things if things else 0
    point_pair = pair < len(host.point_body) * things
    t1 = host.plane_tangent[g] if point_pair and g < len(host.plane_offset) else tangent(n)
    t2 = np.array([n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2],
                   n[0] * t1[1] - n[1] * t1[0]])          # n × t₁ (np.cross costs 60 µs)
    moved = _world(q[b], rest) - _world(q_n[b], rest)
    mu = host.body_friction[b, start.other] if start.other is not None else \
        host.pair_friction[pair]
    if start.other is not None:         # the slip relative to the other body's point
        c = start.other
        rest = _touching(q_n[c], start.other_rest, start.other_radius, -n)
        moved = moved - (_world(q[c], rest) - _world(q_n[c], rest))
    u1, u2 = float(t1 @ moved), float(t2 @ moved)
    y = math.hypot(u1, u2)
    eps = host.contact_eps_velocity * host.dt
    f1_over_y = 1.0 / y if y >= eps else (2.0 * eps - y) / (eps * eps)
    return -mu * lam * f1_over_y * (u1 * t1 + u2 * t2)


def _touching(q_body, rest, radius: float, normal) -> np.ndarray:
    """The rest position of the material point that touches along ``normal`` (towards the
    body): x̄ − r A⁻¹ n, as the kernel's ``touch_rest``."""
    if radius > 0.0:
        rest = rest - radius * np.linalg.solve(q_body[3:].reshape(3, 3), normal)
    return rest
