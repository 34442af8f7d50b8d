"""Host-side contact model: a scene's collision geometry as contact points, its ground as
half-spaces and its fixed bodies' geometry as static shapes (``contact.shapes``; the model
fields of physics.host.fields under ``has_contact``), and the refusal of a scene whose initial state
already touches (docs/physics.md#contact).

A contact point is a rest point x̄ of a free body (COM-centred body frame) with a radius r: a
box's corners (r = 0), a sphere's centre, a capsule's two sphere centres, the corners of a
mesh's convex hull (``mesh_hull``). Its distance to the half-space n·x ≥ h is
n·(p + A x̄) − h − r, exact for these (a box or a hull touches a plane first at a corner). A
cylinder touches as its two rims, ``CYLINDER_RIM_POINTS`` points each: exact standing on an end
face or tipped onto a rim, and up to r (1 − cos(π/16)) = 1.9 % of its radius low between two
points lying on its side.
"""

import warnings

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.contact_schema import Collision, Contact
from affine_joint_sim.physics.contact.kinds import TRIANGLE
from affine_joint_sim.physics.contact.hull import mesh_hull
from affine_joint_sim.physics.contact.pairs import (near_pairs, pair_gap, touch_chunks,
                                                    touch_first)
from affine_joint_sim.physics.contact.primitives import Surface, moving_surface, static_surfaces
from affine_joint_sim.physics.contact.shapes import shape_separation, static_shapes
from affine_joint_sim.rotations import rpy_matrix
from affine_joint_sim.scene import SceneError
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['CYLINDER_RIM_POINTS', 'combined_friction', 'contact_arrays', 'refuse_touching',
           'tangent']

CYLINDER_RIM_POINTS = 16
_CORNERS = np.array([[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)
                     for sz in (-1.0, 1.0)])


def _shape_collision(shape) -> Collision:
    """A body's own shape as a collision geometry."""
    if shape.kind == 'box':
        return Collision(box=shape.box)
    if shape.kind == 'sphere':
        return Collision(sphere={'radius': shape.sphere.radius})
    return Collision(cylinder={'radius': shape.cylinder.radius,
                               'length': shape.cylinder.length})


def _points(geometry: Collision, hull) -> list[tuple[np.ndarray, float]]:
    """(x̄, r) of one geometry's contact points in the body frame (a mesh: its ``hull``'s
    corners)."""
    rotation = rpy_matrix(*geometry.origin.rpy)
    origin = np.array(geometry.origin.xyz, dtype=np.float64)
    radius = 0.0
    if geometry.kind == 'box':
        local = [0.5 * np.array(geometry.box) * corner for corner in _CORNERS]
    elif geometry.kind == 'sphere':
        local, radius = [np.zeros(3)], geometry.sphere.radius
    elif geometry.kind == 'capsule':
        half = 0.5 * geometry.capsule.length
        local, radius = [np.array([0.0, 0.0, -half]), np.array([0.0, 0.0, half])], \
            geometry.capsule.radius
    elif geometry.kind == 'cylinder':
        r, half = geometry.cylinder.radius, 0.5 * geometry.cylinder.length
        turns = [2.0 * np.pi * k / CYLINDER_RIM_POINTS for k in range(CYLINDER_RIM_POINTS)]
        local = [np.array([r * pm.cos(a), r * pm.sin(a), z]) for z in (-half, half)
                 for a in turns]
    else:
        local = list(hull.vertices)
    return [(origin + pm.matmul(rotation, x), float(radius)) for x in local]


def _half_spaces(scene) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(unit normals, offsets h of n·x ≥ h, names) of the scene's ground."""
    normals, offsets, names = [], [], []
    for g, half in enumerate(scene.ground or []):
        if half.height is not None:
            normal, offset = np.array([0.0, 0.0, 1.0]), float(half.height)
        else:
            normal = np.array(half.normal, dtype=np.float64)
            normal = normal / pm.norm(normal)
            offset = pm.dot(normal, np.array(half.point, dtype=np.float64))
        normals.append(normal)
        offsets.append(offset)
        names.append('ground' if len(scene.ground) == 1 else f'ground[{g}]')
    return (np.array(normals).reshape(-1, 3), np.array(offsets, dtype=np.float64), names)


def tangent(normal) -> np.ndarray:
    """t₁ of a half-space's friction basis: x̂ × n normalized (ẑ × n where n is within
    about 26° of x̂); t₂ = n × t₁."""
    axis = np.array([0.0, 0.0, 1.0]) if abs(normal[0]) > 0.9 else np.array([1.0, 0.0, 0.0])
    t1 = pm.cross(axis, normal)
    return t1 / pm.norm(t1)


def combined_friction(mu_a: float, mu_b: float) -> float:
    """μ of a pair of surfaces: 2 μa μb / (μa + μb), the harmonic-mean rule Drake uses (near
    the smaller one: ice under rubber is slippery; 0 if either is 0)."""
    return 0.0 if mu_a + mu_b == 0.0 else 2.0 * mu_a * mu_b / (mu_a + mu_b)


def _geometries(body) -> list[Collision]:
    """A body's collision geometries (its own shape for ``collision: shape``)."""
    return [_shape_collision(body.shape)] if body.collision == 'shape' else body.collision


def contact_arrays(scene, q0: np.ndarray, starts=None) -> tuple[dict, list[str]]:
    """(the contact model fields of ``scene`` with initial states ``q0`` (n_bodies, 12), the
    name of each static thing: ``ground`` or ``ground[k]``, then the fixed bodies, then the
    fixed body of each static edge and each static vertex); a scene without ``contact`` and
    ``ground`` gets empty tables and has_contact 0. Raises SceneError if a pair starts
    touching or a contact point inside a half-space or a static shape, at ``q0`` or at each
    state of ``starts`` where given (the states a changed scene goes on from:
    ``Stepper.spawn``)."""
    on = scene.contact is not None or scene.ground is not None
    settings = scene.contact or Contact()
    bodies, rests, radii = [], [], []
    shapes, owners, shape_names = static_shapes(scene.bodies if on else [], q0, _geometries)
    group, jointed = scene.articulations()
    excluded = {(scene.body_index(a), scene.body_index(b)) for a, b in settings.exclude}
    excluded |= {(b, a) for a, b in excluded}

    def may_touch(b, f):
        if f is None:
            return 1
        if (b, f) in excluded:
            return 0
        if group[b] != group[f]:
            return 1
        return int(settings.self_collision and (b, f) not in jointed)

    solids = [b for b, body in enumerate(scene.bodies if on else [])
              if body.collision is not None and not body.fixed]
    touch = [(a, b) for a in solids for b in solids if a < b and may_touch(a, b)]
    moving = _Moving()
    for b in solids:
        body = scene.bodies[b]
        for k, geometry in enumerate(_geometries(body)):
            where = f'body {body.name!r} (bodies[{b}].collision' + (
                ')' if body.collision == 'shape' else f'[{k}])')
            hull = None if geometry.kind != 'mesh' else mesh_hull(
                geometry.mesh.path or geometry.mesh.uri, geometry.mesh.scale, where,
                settings.mesh_tolerance)
            for rest, radius in _points(geometry, hull):
                bodies.append(b)
                rests.append(rest)
                radii.append(radius)
            if len(owners) or touch:    # edges and faces: static shapes, other bodies
                moving.add(b, moving_surface(geometry, hull), static=True)
            if touch and geometry.kind == 'sphere':     # its centre, for other bodies only
                moving.add(b, Surface([geometry.origin.xyz], [(0, 0)],
                                      radius=geometry.sphere.radius), static=False)
    if on and not scene.solver.line_search:
        warnings.warn('solver.line_search is false, but a scene with contact always searches '
                      '(a step must never end inside the ground)', SimulationWarning,
                      stacklevel=3)
    normals, offsets, names = _half_spaces(scene) if on else (np.zeros((0, 3)), np.zeros(0), [])
    fixed = _Fixed(*static_surfaces(shapes, owners))
    body_mu = [settings.friction if body.friction is None else body.friction
               for body in scene.bodies]
    static_mu = [settings.friction if half.friction is None else half.friction
                 for half in (scene.ground or [])] if on else []
    static_mu += [body_mu[f] for f in owners]
    families = [(bodies, [None] * len(offsets) + list(owners)),
                (moving.edge_body, fixed.edge_owner), (moving.face_body, fixed.vertex_owner)]
    solid = [[1] * len(bodies), moving.edge_static, [1] * len(moving.face_body)]
    mu = [static_mu] + [[body_mu[f] for f in owners_] for _, owners_ in families[1:]]
    n = len(scene.bodies)
    slot = np.full((n, n), -1, dtype=np.int32)
    for j, (a, b) in enumerate(touch):
        slot[a, b] = slot[b, a] = j
    arrays = dict(has_contact=int(on), contact_d_hat=settings.d_hat,
                  contact_kappa=settings.kappa, contact_eps_velocity=settings.eps_velocity,
                  contact_damping=settings.damping,
                  plane_tangent=np.array([tangent(n) for n in normals]).reshape(-1, 3),
                  pair_friction=np.array([combined_friction(body_mu[b], m)
                                          for (moving_, _), mus in zip(families, mu)
                                          for b in moving_ for m in mus], dtype=np.float64),
                  pair_on=np.array([may_touch(b, f) * on_ for (moving_, owners_), flags in
                                    zip(families, solid)
                                    for b, on_ in zip(moving_, flags) for f in owners_],
                                   dtype=np.int32),
                  point_body=np.array(bodies, dtype=np.int32),
                  point_rest=np.array(rests, dtype=np.float64).reshape(-1, 3),
                  point_radius=np.array(radii, dtype=np.float64),
                  plane_normal=normals, plane_offset=offsets, **shapes,
                  **moving.arrays(n, zip(bodies, rests, radii)), **fixed.arrays(),
                  body_first_point=np.searchsorted(bodies, np.arange(n + 1)).astype(np.int32),
                  touch_a=np.array([a for a, _ in touch], dtype=np.int32),
                  touch_b=np.array([b for _, b in touch], dtype=np.int32), touch_slot=slot,
                  body_friction=np.array([[combined_friction(ma, mb) for mb in body_mu]
                                          for ma in body_mu], dtype=np.float64).reshape(n, n))
    arrays['touch_first'] = touch_first(arrays)
    arrays['touch_chunk'] = touch_chunks(arrays['touch_first'])
    names += shape_names + [scene.bodies[f].name for f in fixed.edge_owner + fixed.vertex_owner]
    for start in [q0] if starts is None else starts:
        refuse_touching(scene, start, arrays, names)
    return arrays, names


class _Moving:
    """The moving bodies' edges and faces, collected geometry by geometry."""

    def __init__(self):
        self.edge_body, self.edges, self.edge_radius, self.edge_static = [], [], [], []
        self.face_body, self.faces = [], []

    def add(self, body: int, surface, static: bool) -> None:
        """A geometry's edges and faces; ``static``: its edges touch static edges too (a
        sphere's centre, a zero-length edge, touches other bodies' edges only)."""
        for a, b in surface.edges:
            self.edge_body.append(body)
            self.edges.append((surface.vertices[a], surface.vertices[b]))
            self.edge_radius.append(surface.radius)
            self.edge_static.append(int(static))
        for face in surface.faces:
            self.face_body.append(body)
            self.faces.append(surface.vertices[face].T)        # the corners as columns

    def arrays(self, bodies: int, points) -> dict:
        """The fields, with body_reach and body_bound over the edges', faces' and ``points``'
        (body, x̄, radius) rest positions."""
        ends = np.array(self.edges, dtype=np.float64).reshape(-1, 2, 3)
        reach, bound = np.zeros(bodies), np.zeros(bodies)
        corners = list(points) + [(b, end, r) for b, pair, r in zip(
            self.edge_body, ends, self.edge_radius) for end in pair]
        corners += [(b, corner, 0.0) for b, face in zip(self.face_body, self.faces)
                    for corner in face.T]
        for b, corner, radius in corners:
            reach[b] = max(reach[b], pm.norm(corner))
            bound[b] = max(bound[b], pm.norm(corner) + radius)
        first = np.arange(bodies + 1)
        return dict(body_reach=reach, body_bound=bound,
                    edge_body=np.array(self.edge_body, dtype=np.int32),
                    body_first_edge=np.searchsorted(self.edge_body, first).astype(np.int32),
                    body_first_face=np.searchsorted(self.face_body, first).astype(np.int32),
                    edge_a=ends[:, 0], edge_b=ends[:, 1],
                    edge_radius=np.array(self.edge_radius, dtype=np.float64),
                    face_body=np.array(self.face_body, dtype=np.int32),
                    face_rest=np.array(self.faces, dtype=np.float64).reshape(-1, 3, 3))


# relative growth of a static surface's bounding sphere: its test must never skip a pair
# that the exact test of one of its edges or vertices would list, whatever the rounding
SURFACE_SLACK = 1.0e-5


class _Fixed:
    """The static shapes' edges and vertices, with the fixed body owning each, and a bounding
    sphere of each surface's (the broad phase skips a surface far from a moving edge or face)."""

    def __init__(self, surfaces, owners):
        self.edges, self.edge_radius, self.edge_owner = [], [], []
        self.vertices, self.vertex_radius, self.vertex_owner = [], [], []
        self.centres, self.radii, self.edge_ends, self.vertex_ends = [], [], [], []
        for surface, owner in zip(surfaces, owners):
            for a, b in surface.edges:
                self.edges.append((surface.vertices[a], surface.vertices[b]))
                self.edge_radius.append(surface.radius)
                self.edge_owner.append(owner)
            for vertex in surface.vertices:
                self.vertices.append(vertex)
                self.vertex_radius.append(surface.radius)
                self.vertex_owner.append(owner)
            corners = np.asarray(surface.vertices, dtype=np.float64).reshape(-1, 3)
            centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
            radius = max(pm.norm(c - centre) for c in corners) + surface.radius
            self.centres.append(centre)
            self.radii.append(radius + SURFACE_SLACK * (radius + pm.norm(centre)))
            self.edge_ends.append(len(self.edges))
            self.vertex_ends.append(len(self.vertices))

    def arrays(self) -> dict:
        ends = np.array(self.edges, dtype=np.float64).reshape(-1, 2, 3)
        return dict(static_edge_a=ends[:, 0], static_edge_b=ends[:, 1],
                    static_edge_radius=np.array(self.edge_radius, dtype=np.float64),
                    static_vertex=np.array(self.vertices, dtype=np.float64).reshape(-1, 3),
                    static_vertex_radius=np.array(self.vertex_radius, dtype=np.float64),
                    surface_centre=np.array(self.centres, dtype=np.float64).reshape(-1, 3),
                    surface_radius=np.array(self.radii, dtype=np.float64),
                    surface_edge_end=np.array(self.edge_ends, dtype=np.int32),
                    surface_vertex_end=np.array(self.vertex_ends, dtype=np.int32))


_STARTS = ('a scene with contact must start with nothing touching (move it clear; a URDF '
           "robot: raise its root link with the scene file's base: {xyz: [x, y, z]} or "
           '`affine-joint-sim run --base X Y Z`)')


def refuse_touching(scene, q, arrays, names, body: int | None = None, verb: str = 'starts',
                    rule: str = _STARTS) -> None:
    """SceneError naming the body, how deep it is (``verb``: "body 'a' starts 0.01 m inside
    ...") and what it is inside (a half-space, shape, fixed body or other body), then ``rule``,
    if a pair that may touch is at distance ≤ 0 at states ``q`` (n_bodies, 12), or a contact
    point of a body is inside (or on) the convex geometry of another it may touch (their
    distances, unsigned between two moving bodies, cannot tell a point inside from one
    outside). With ``body``, only the pairs that body is part of. ``arrays``: the contact model
    fields (contact_arrays, or a HostModel's), ``names``: its static things' names."""
    inside = _overlap(scene, q, arrays, body) or _touching(scene, q, arrays, names, body)
    if inside is not None:
        name, depth, what = inside
        raise SceneError(f'body {name!r} {verb} {depth:.6g} m inside {what}: {rule}')


def _touching(scene, q, arrays, names, body) -> tuple | None:
    """(body name, depth [m], what it is inside) of the deepest pair at distance ≤ 0 (of
    ``body`` if given), or None."""
    gaps = [pair_gap(arrays, q, int(p)) for p in near_pairs(arrays, q, 0.0)]
    inside = [gap for gap in gaps if gap.distance <= 0.0
              and body in (None, gap.body, gap.other)]
    if not inside:
        return None
    gap = min(inside, key=lambda g: g.distance)
    other = names[gap.static] if gap.other is None else f'body {scene.bodies[gap.other].name!r}'
    return scene.bodies[gap.body].name, -gap.distance, f'{other} (distance {gap.distance:.6g} m)'


def _overlap(scene, q, arrays, only) -> tuple | None:
    """(body name, depth [m], the other body) of the deepest contact point inside another
    body's convex geometry (of or in ``only`` if given), or None."""
    if not len(arrays['touch_a']):
        return None
    shapes, owners, _ = static_shapes(scene.bodies, q, _geometries, moving=True)
    rests, radii = arrays['point_rest'], arrays['point_radius']
    deepest = None
    for s, owner in enumerate(owners):
        kind, rotation, centre, size = (shapes[key][s] for key in (
            'shape_kind', 'shape_rotation', 'shape_center', 'shape_size'))
        if kind == TRIANGLE.code:
            continue
        for i, body in enumerate(arrays['point_body']):
            if arrays['touch_slot'][body, owner] < 0 or only not in (None, body, owner):
                continue
            x = q[body, :3] + pm.matmul(q[body, 3:].reshape(3, 3), rests[i])
            if pm.norm(x - centre) > pm.norm(size) + size[0] + radii[i]:
                continue                # beyond every shape's bounding sphere
            depth = radii[i] - shape_separation(kind, rotation, centre, size, x)[0]
            if depth >= 0.0 and (deepest is None or depth > deepest[0]):
                deepest = depth, body, owner
    if deepest is None:
        return None
    depth, body, owner = deepest
    return scene.bodies[body].name, depth, f'body {scene.bodies[owner].name!r}'
