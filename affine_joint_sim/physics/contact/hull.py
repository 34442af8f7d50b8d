"""A moving body's collision mesh as contact sees it: its convex hull, simplified only within
a tolerance (README.md#contact, docs/physics.md#contact).

A moving mesh touches as its convex hull, as a mesh geom does in MuJoCo (a concave part, a cup
or a gripper's palm, is split into convex pieces, one ``<collision>`` each). The hull's
corners are kept greedily: first the mesh's extreme vertices along the 26 directions of a
cube's faces, edges and corners, then, again and again, for each face of the hull of those
kept, the vertex farthest beyond it (as quickhull adds them), until every vertex of the mesh
lies within ``contact.mesh_tolerance`` of that hull.
The kept corners are vertices of the mesh, so the contact shape lies inside the mesh's hull
and the mesh never reaches more than the tolerance beyond it, whatever its vertex count: the
bound is a distance, never a count. The hull's vertices are the contact points (a plane meets
a polyhedron first at a corner), its triangles and edges the surface other bodies and static
shapes touch. A simplified hull is said once per mesh, with its bound, as an item of the model
build's summary (``sim_warnings.summarised``).

Qhull (SciPy) builds each hull; every distance is summed in a fixed order from exact IEEE
operations (no BLAS), so the kept corners are the same on every machine.
"""

import warnings
from pathlib import Path

import numpy as np

from affine_joint_sim.meshes import read_mesh
from affine_joint_sim.scene import SceneError
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['Hull', 'mesh_hull', 'simplified_hull', 'hull_distances']

SIMPLIFIED = 'collision meshes simplified for contact'     # the load summary's kind

_DIRECTIONS = [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
               if (i, j, k) != (0, 0, 0)]


class Hull:
    """A convex hull as contact uses it: ``vertices`` (n, 3) [m, in the geometry's frame],
    ``faces`` (k, 3) vertex indices, ``error`` [m] (how far the mesh's farthest vertex lies
    outside it) and ``had`` (the mesh's distinct vertices)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, error: float, had: int):
        self.vertices, self.faces, self.error, self.had = vertices, faces, error, had


def mesh_hull(path: str, scale, where: str, tolerance: float) -> Hull:
    """The convex hull of the mesh file at ``path`` scaled per axis by ``scale``, simplified
    within ``tolerance`` [m] (with a warning naming ``where`` when corners were dropped);
    SceneError naming ``where`` if it cannot be read or is flat (no volume)."""
    vertices, _ = read_mesh(path, scale, where)
    points = np.unique(vertices, axis=0)
    try:
        hull = simplified_hull(points, tolerance)
    except ValueError as exc:
        raise SceneError(f'{where}: collision mesh {path} {exc} (a moving mesh touches as its '
                         'convex hull, which needs a volume)') from None
    corners = len(_qhull(points).vertices)
    if len(hull.vertices) < corners:
        warnings.warn(SimulationWarning(
            f'{where}: collision mesh {path} touches as its convex hull, {len(hull.vertices)} '
            f'of its {corners} corners ({len(points)} vertices): every vertex lies within '
            f'{hull.error * 1e3:.2g} mm of it (contact.mesh_tolerance {tolerance:g} m)',
            SIMPLIFIED, hull.error, f'{Path(path).name} within {hull.error * 1e3:.2g} mm',
            item=f'{where} {path}'), stacklevel=2)
    return hull


def simplified_hull(points: np.ndarray, tolerance: float) -> Hull:
    """The hull of a subset of ``points`` (n, 3) [m] that every point lies within
    ``tolerance`` [m] of; ValueError if the points span no volume."""
    chosen = []
    for i, j, k in _DIRECTIONS:
        pick = int(np.argmax(points[:, 0] * i + points[:, 1] * j + points[:, 2] * k))
        if pick not in chosen:
            chosen.append(pick)
    while True:
        hull = _qhull(points[chosen])
        excess = _plane_excess(points, hull.equations)
        far = _farthest_per_face(excess, tolerance)
        if not len(far):
            distance = hull_distances(points, points[chosen][hull.simplices], excess)
            worst = int(np.argmax(distance))
            if distance[worst] <= tolerance:
                corners = np.sort(hull.vertices)
                faces = np.searchsorted(corners, hull.simplices).astype(np.int64)
                return Hull(points[chosen][corners], faces, float(distance[worst]), len(points))
            far = [worst]
        chosen += [int(k) for k in far]


def _farthest_per_face(excess: np.ndarray, tolerance: float) -> np.ndarray:
    """The points (ascending) that lie farther than ``tolerance`` outside the plane of the
    face they are most outside of (``excess``: (points, faces)) and farthest of those beyond
    that face: quickhull's next corners, one per face."""
    face = np.argmax(excess, axis=1)
    height = excess[np.arange(len(excess)), face]
    out = np.flatnonzero(height > tolerance)
    order = out[np.lexsort((-height[out], face[out]))]
    first = np.ones(len(order), dtype=bool)
    first[1:] = face[order[1:]] != face[order[:-1]]
    return np.sort(order[first])


def hull_distances(points: np.ndarray, triangles: np.ndarray, excess: np.ndarray) -> np.ndarray:
    """Each point's distance [m] to a convex hull given by its ``triangles`` (k, 3, 3) [m]
    and each point's ``excess`` over each face's plane (points, k): 0 inside, else the
    distance to the nearest face it lies beyond (the nearest point of a convex hull is on a
    face whose plane the point is beyond): to the foot on the plane where it falls inside the
    triangle, else to the nearest of its edges."""
    distance = np.full(len(points), np.inf)
    distance[(excess <= 0.0).all(axis=1)] = 0.0
    point, face = np.nonzero(excess > 0.0)
    x = points[point]
    a, b, c = (triangles[face, k] for k in range(3))
    normal = _cross(b - a, c - a)
    inside = ((_dot(_cross(b - a, x - a), normal) >= 0.0)
              & (_dot(_cross(c - b, x - b), normal) >= 0.0)
              & (_dot(_cross(a - c, x - c), normal) >= 0.0))
    edges = np.minimum(np.minimum(_segment(x, a, b), _segment(x, b, c)), _segment(x, c, a))
    np.minimum.at(distance, point, np.where(inside, excess[point, face], edges))
    return distance


def _qhull(points: np.ndarray):
    """SciPy's ConvexHull of ``points``; ValueError if they span no volume."""
    from scipy.spatial import ConvexHull, QhullError
    if len(points) < 4:
        raise ValueError(f'has {len(points)} distinct vertices')
    try:
        return ConvexHull(points)
    except QhullError:
        raise ValueError('is flat') from None


def _plane_excess(points: np.ndarray, equations: np.ndarray) -> np.ndarray:
    """Each point's excess [m] over each of the hull's face planes, (points, faces)
    (n·x + offset, outward unit n; > 0 outside)."""
    n = equations[None, :, :]
    x = points[:, None, :]
    return x[..., 0] * n[..., 0] + x[..., 1] * n[..., 1] + x[..., 2] * n[..., 2] + n[..., 3]


def _segment(x, a, b) -> np.ndarray:
    """Distances [m] of points ``x`` to the segments ab, broadcast."""
    ab = b - a
    t = np.clip(_dot(x - a, ab) / _dot(ab, ab), 0.0, 1.0)
    gap = x - (a + t[..., None] * ab)
    return np.sqrt(_dot(gap, gap))


def _dot(u, v) -> np.ndarray:
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]


def _cross(u, v) -> np.ndarray:
    return np.stack([u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1],
                     u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2],
                     u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]], axis=-1)
