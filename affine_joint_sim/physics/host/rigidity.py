"""Each body's rigidity κ v̄ [J]: from the loads its joints carry, so that it strains by at most
TARGET_STRAIN under them (docs/physics.md#rigidity).

A body strained by ε stores about 4 κ v̄ ‖ε‖² of orthogonality energy, so a moment L [N·m]
that its joints apply strains it by about L / (8 κ v̄). The moment of joint k on body b is
the larger of
- the weight it carries, W_k = g·m_k with m_k the free mass beyond k (the side without a fixed
  body; the lighter side of a floating robot), at the lever from b's centre of mass out to k's
  anchors and on to that mass's centre, and
- its effort limit (a torque up to it loads both bodies; a prismatic joint's force, at that
  lever; ``.inf`` counts nothing).
A body whose ``kappa`` the scene gives keeps it; every other body gets
max(DEFAULT_KAPPA v̄, min(L_max / (8 TARGET_STRAIN), s_min / (8 dt² ε RESOLUTION))): the
second bound keeps its stiffest affine entry 8 dt² κ v̄ within what the precision (rounding
unit ε) resolves against its smallest second moment s_min, with room to spare, so that float32
still sees its turns. Scene frame at t = 0, SI units.
"""

import math

import numpy as np

from affine_joint_sim import portable_math as pm

__all__ = ['DEFAULT_KAPPA', 'TARGET_STRAIN', 'LOAD_GRAVITY', 'RESOLUTION', 'body_rigidity']

DEFAULT_KAPPA = 1.0e8    # Pa: the softest a body gets (the fixed default before loads counted)
TARGET_STRAIN = 1.0e-7   # the largest strain the joints' loads may cause
LOAD_GRAVITY = 9.81      # m/s²: the least acceleration loads are sized for (zero-g scenes too)
RESOLUTION = 1.0e3       # rounding units the smallest second moment keeps above the stiffest entry


def body_rigidity(scene, props) -> np.ndarray:
    """κ v̄ [J] per body of ``scene`` (``props``: its bodies' MassProperties)."""
    volume = np.array([p.volume for p in props])
    load = _largest_moments(scene, props)
    eps = np.finfo(np.float32 if scene.solver.precision == 'float32' else np.float64).eps
    smallest = np.array([p.second_moment.min() for p in props])
    resolved = smallest / (8.0 * (scene.dt * scene.dt) * eps * RESOLUTION)
    auto = np.maximum(DEFAULT_KAPPA * volume,
                      np.minimum(load / (8.0 * TARGET_STRAIN), resolved))
    return np.array([rigid if b.kappa is None else b.kappa * v
                     for b, v, rigid in zip(scene.bodies, volume, auto)])


def _largest_moments(scene, props) -> np.ndarray:
    """L_max [N·m] per body: the largest moment one of its joints loads it with."""
    g = max(pm.norm(np.asarray(scene.gravity, dtype=np.float64)), LOAD_GRAVITY)
    centre = np.array([b.position for b in scene.bodies], dtype=np.float64)
    mass = np.array([0.0 if b.fixed else p.mass for b, p in zip(scene.bodies, props)])
    fixed = [b.fixed for b in scene.bodies]
    ends = [(scene.body_index(j.parent), scene.body_index(j.child)) for j in scene.joints]
    links = [[] for _ in scene.bodies]          # per body: (joint, body at its other end)
    for k, (p, c) in enumerate(ends):
        links[p].append((k, c))
        links[c].append((k, p))
    moments = np.zeros(len(scene.bodies))
    for k, joint in enumerate(scene.joints):
        carried, carried_centre = _far_side(links, fixed, ends[k], k, mass, centre)
        anchors = ([np.asarray(joint.x0, dtype=np.float64), np.asarray(joint.x1, dtype=np.float64)]
                   if joint.x0 is not None else [0.5 * (centre[ends[k][0]] + centre[ends[k][1]])])
        effort = joint.effort_limit if math.isfinite(joint.effort_limit) else 0.0
        for b in ends[k]:
            lever = max(pm.norm(a - centre[b]) + pm.norm(carried_centre - a) for a in anchors)
            # a revolute effort is a torque [N·m]; a prismatic one a force [N] at the lever
            push = effort * lever if joint.type == 'prismatic' else effort
            moments[b] = max(moments[b], g * carried * lever, push)
    return moments


def _far_side(links, fixed, ends, k, mass, centre) -> tuple[float, np.ndarray]:
    """(mass [kg], centre of mass [m]) that joint k carries: the free bodies joined to its
    child without passing k, unless they reach a fixed body (then its parent's side), the
    lighter side when neither does."""
    sides = [_component(links, fixed, k, start) for start in ends]
    grounded = [any(fixed[b] for b in side) for side in sides]
    side_mass = [float(sum(mass[b] for b in side)) for side in sides]
    if grounded[0] != grounded[1]:
        pick = 1 if grounded[0] else 0
    else:
        pick = 0 if side_mass[0] < side_mass[1] else 1
    total = side_mass[pick]
    if total <= 0.0:
        return 0.0, centre[ends[pick]]
    return total, sum(mass[b] * centre[b] for b in sorted(sides[pick])) / total


def _component(links, fixed, skip, start) -> set:
    """Bodies joined to ``start`` by the joints other than ``skip``; a fixed body (the world)
    ends a path: it passes no load on."""
    seen, todo = {start}, [start]
    while todo:
        b = todo.pop()
        if fixed[b] and b != start:
            continue
        for k, other in links[b]:
            if k != skip and other not in seen:
                seen.add(other)
                todo.append(other)
    return seen
