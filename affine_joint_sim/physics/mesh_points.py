"""A collision mesh's contact points: its vertices, at most ``MAX_MESH_POINTS`` of them
(README.md#contact).

Against a half-space a mesh touches first at a vertex, so its vertices are its contact points.
A finer mesh than contact needs (a visual exported as collision geometry) is reduced: first its
extreme vertices along the 26 directions of a cube's faces, edges and corners (the vertex a
half-space with that normal touches first; a box's corners, a sphere's poles), then farthest-
point sampling (each next vertex the one farthest from every vertex kept so far), so the rest
are spread evenly. The warning names the body and says how far a dropped vertex may be from a
kept one; it is an item of the model build's summary (``sim_warnings.summarised``), where a mesh
whose vertices and surface triangles are both reduced counts once. Exact IEEE operations only
(no BLAS sums), so the points are the same bits on every machine.
"""

import warnings
from pathlib import Path

import numpy as np

from affine_joint_sim.meshes import decimated, read_mesh
from affine_joint_sim.scene import SceneError
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['MAX_MESH_POINTS', 'MAX_STATIC_TRIANGLES', 'mesh_points', 'mesh_triangles',
           'reduce_points']

MAX_MESH_POINTS = 64
MAX_STATIC_TRIANGLES = 256   # a fixed body's mesh: every contact point is tested against each
REDUCED = 'collision meshes reduced for contact'     # the summary's kind of both reductions
_DIRECTIONS = [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
               if (i, j, k) != (0, 0, 0)]


def mesh_points(path: str, scale, where: str) -> np.ndarray:
    """The contact points (n, 3) [m, in the geometry's frame] of the mesh file at ``path``
    scaled per axis by ``scale``; SceneError naming ``where`` if it cannot be read."""
    vertices, _ = read_mesh(path, scale, where)
    points = np.unique(vertices, axis=0)
    if len(points) <= MAX_MESH_POINTS:
        return points
    kept, gap = reduce_points(points, MAX_MESH_POINTS)
    _reduced(f'{where}: collision mesh {path} has {len(points)} distinct vertices; contact uses '
             f'{MAX_MESH_POINTS} of them (its extremes along 26 directions, then farthest-point '
             f'sampling; every vertex dropped is within {gap:.3g} m of one kept)',
             path, where, len(points), MAX_MESH_POINTS, 'vertices')
    return kept


def mesh_triangles(path: str, scale, where: str, most: int = MAX_STATIC_TRIANGLES) -> np.ndarray:
    """The triangles (n, 3, 3) [m, in the geometry's frame] of the mesh file at ``path``
    scaled per axis by ``scale``, at most ``most`` (more: vertex clustering, with a warning),
    degenerate ones dropped; SceneError naming ``where`` if it has none."""
    vertices, faces = read_mesh(path, scale, where)
    triangles = vertices[faces] if len(faces) <= most else decimated(vertices, faces, most)
    if len(faces) > most:
        _reduced(f'{where}: collision mesh {path} has {len(faces)} triangles; contact uses '
                 f'{len(triangles)} (vertex clustering: the outline stays, small detail goes)',
                 path, where, len(faces), len(triangles), 'triangles')
    area = np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0],
                                   triangles[:, 2] - triangles[:, 0]), axis=1)
    triangles = triangles[area > 1e-12 * max(float(area.max(initial=0.0)), 1e-300)]
    if not len(triangles):
        raise SceneError(f'{where}: collision mesh {path} has no triangles (a static mesh '
                         'touches with its faces)')
    return triangles


def _reduced(message: str, path: str, where: str, had: int, kept: int, what: str) -> None:
    """The SimulationWarning of a mesh reduced for contact from ``had`` to ``kept`` ``what``
    (vertices or triangles): one item per geometry, the worst the most reduced."""
    warnings.warn(SimulationWarning(message, REDUCED, had / max(kept, 1),
                                    f'{Path(path).name} {had} → {kept} {what}',
                                    item=f'{where} {path}'), stacklevel=4)


def reduce_points(points: np.ndarray, count: int) -> tuple[np.ndarray, float]:
    """``count`` (≥ 26) of ``points`` (n, 3): the extremes along the 26 directions, then by
    farthest-point sampling (ties: the lowest index); and the largest distance [m] from a
    point to the nearest one kept."""
    chosen = []
    for i, j, k in _DIRECTIONS:
        height = points[:, 0] * i + points[:, 1] * j + points[:, 2] * k
        pick = int(np.argmax(height))
        if pick not in chosen:
            chosen.append(pick)
    nearest = _squared(points, points[chosen[0]])
    for pick in chosen[1:]:
        nearest = np.minimum(nearest, _squared(points, points[pick]))
    while len(chosen) < count:
        pick = int(np.argmax(nearest))
        chosen.append(pick)
        nearest = np.minimum(nearest, _squared(points, points[pick]))
    return points[chosen], float(np.sqrt(nearest.max()))


def _squared(points: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Squared distances of ``points`` to ``point``, summed in a fixed order."""
    d = points - point
    return d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
