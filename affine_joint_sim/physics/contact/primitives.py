"""Edges and faces of collision geometry for edge–edge and vertex–face contact, host side
(README.md#contact, docs/physics.md#contact).

Two convex solids are nearest at a vertex of one against the other (the contact points of
``contact.model`` against a static shape), at an edge of one against an edge of the other, or
at a vertex of the static one against a face of the moving one. So beside its points a moving
body has **edges** (rest endpoints and a radius: a box's 12, a capsule's axis with its radius,
a cylinder's rims and 16 side lines, a mesh's) and **faces** (rest triangles: a box's 12, a
cylinder's caps and sides, a mesh's); the static world has **static edges** (a box's 12, a
capsule's axis and a sphere's centre as a zero-length edge with their radius, a cylinder's
rims and sides, each mesh edge once) and **static vertices** (corners, a sphere's centre and a
capsule's two with their radius, each mesh vertex once). A sphere moving is exact with its
centre alone, so it has neither. A moving mesh touches as its convex hull (``mesh_hull``).
"""

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.physics.contact.kinds import BOX, CAPSULE, CYLINDER, TRIANGLE
from affine_joint_sim.rotations import rpy_matrix

__all__ = ['CYLINDER_SEGMENTS', 'Surface', 'box_surface',
           'cylinder_surface', 'moving_surface', 'static_surfaces']

CYLINDER_SEGMENTS = 16


class Surface:
    """Vertices (n, 3) [m], edges (k, 2) and faces (m, 3) as vertex indices, and a radius r
    [m] around every one of them."""

    def __init__(self, vertices, edges=(), faces=(), radius: float = 0.0):
        self.vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        self.edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
        self.faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        self.radius = float(radius)

    def placed(self, rotation, origin) -> 'Surface':
        """This surface with its vertices mapped by x ↦ origin + rotation x."""
        moved = [np.asarray(origin, float) + pm.matmul(rotation, v) for v in self.vertices]
        return Surface(moved, self.edges, self.faces, self.radius)


def box_surface(half) -> Surface:
    """A box of half sides ``half`` about its centre: 8 corners (index 4 i + 2 j + k for the
    signs of x, y, z), 12 edges, 12 triangles."""
    signs = [(sx, sy, sz) for sx in (-1.0, 1.0) for sy in (-1.0, 1.0) for sz in (-1.0, 1.0)]
    corners = [np.array(half, dtype=np.float64) * np.array(s) for s in signs]
    edges = [(k, k | bit) for bit in (4, 2, 1) for k in range(8) if not k & bit]
    faces = []
    for axis, others in ((4, (2, 1)), (2, (4, 1)), (1, (4, 2))):
        for side in (0, axis):
            u, v = others
            ring = [side, side | u, side | u | v, side | v]
            faces += [(ring[0], ring[1], ring[2]), (ring[0], ring[2], ring[3])]
    return Surface(corners, edges, faces)


def cylinder_surface(radius: float, half: float) -> Surface:
    """A cylinder along z: ``CYLINDER_SEGMENTS`` vertices on each rim (bottom first), the rims'
    edges and the side lines joining them, caps as triangle fans and the side as quads split
    in two."""
    count = CYLINDER_SEGMENTS
    turns = [2.0 * np.pi * k / count for k in range(count)]
    vertices = [np.array([radius * pm.cos(a), radius * pm.sin(a), z]) for z in (-half, half)
                for a in turns]
    edges, faces = [], []
    for k in range(count):
        nxt = (k + 1) % count
        edges += [(k, nxt), (count + k, count + nxt), (k, count + k)]
        faces += [(k, nxt, count + nxt), (k, count + nxt, count + k)]
    for k in range(1, count - 1):
        faces += [(0, k, k + 1), (count, count + k, count + k + 1)]
    return Surface(vertices, edges, faces)


def _mesh_surface(triangles: np.ndarray) -> Surface:
    """A triangle soup (n, 3, 3) as a surface, equal vertices merged, each edge once."""
    vertices, index = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    faces = index.reshape(-1, 3)
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                              faces[:, [0, 2]]]), axis=1), axis=0)
    return Surface(vertices, edges, faces)


def moving_surface(geometry, hull=None) -> Surface:
    """The edges and faces a moving body's collision ``geometry`` touches static geometry
    with, in the body frame (a sphere: none; its centre is exact); a mesh's are those of its
    ``hull`` (``contact.hull.Hull``)."""
    kind = geometry.kind
    if kind == 'box':
        local = box_surface([0.5 * side for side in geometry.box])
    elif kind == 'capsule':
        half = 0.5 * geometry.capsule.length
        local = Surface([[0.0, 0.0, -half], [0.0, 0.0, half]], [(0, 1)],
                        radius=geometry.capsule.radius)
    elif kind == 'cylinder':
        local = cylinder_surface(geometry.cylinder.radius, 0.5 * geometry.cylinder.length)
    elif kind == 'mesh':
        local = _mesh_surface(hull.vertices[hull.faces])
    else:
        return Surface([])
    return local.placed(rpy_matrix(*geometry.origin.rpy), geometry.origin.xyz)


def static_surfaces(shapes: dict, owners) -> tuple[list[Surface], list[int]]:
    """(one world surface per fixed body's convex geometry or mesh, the body index of each)
    from the static shape fields (``contact.shapes``): a mesh's triangles, consecutive with
    the same owner, become one surface so each of its edges and vertices counts once."""
    surfaces, surface_owners, soup = [], [], []
    kinds = shapes['shape_kind']
    for s, kind in enumerate(kinds):
        rotation, centre, size = (shapes['shape_rotation'][s], shapes['shape_center'][s],
                                  shapes['shape_size'][s])
        if kind == TRIANGLE.code:
            soup.append(np.asarray(rotation).T)
            last = s + 1 == len(kinds) or kinds[s + 1] != kind or owners[s + 1] != owners[s]
            if last:
                surfaces.append(_mesh_surface(np.array(soup)))
                surface_owners.append(owners[s])
                soup = []
            continue
        if kind == BOX.code:
            local = box_surface(size)
        elif kind == CYLINDER.code:
            local = cylinder_surface(size[0], size[1])
        elif kind == CAPSULE.code:
            local = Surface([[0.0, 0.0, -size[1]], [0.0, 0.0, size[1]]], [(0, 1)],
                            radius=size[0])
        else:                                   # a sphere: its centre, a zero-length edge
            local = Surface([[0.0, 0.0, 0.0]], [(0, 0)], radius=size[0])
        surfaces.append(local.placed(rotation, centre))
        surface_owners.append(owners[s])
    return surfaces, surface_owners
