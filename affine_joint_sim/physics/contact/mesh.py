"""A fixed body's collision mesh as static triangles, at most ``MAX_STATIC_TRIANGLES`` of them
(README.md#contact): a finer mesh is reduced by vertex clustering (``meshes.decimated``) with
a warning, an item of the model build's summary (``sim_warnings.summarised``).
"""

import warnings
from pathlib import Path

import numpy as np

from affine_joint_sim.meshes import decimated, read_mesh
from affine_joint_sim.scene import SceneError
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['MAX_STATIC_TRIANGLES', 'mesh_triangles']

MAX_STATIC_TRIANGLES = 256   # a fixed body's mesh: every contact point is tested against each
REDUCED = 'fixed collision meshes reduced for contact'     # the load summary's kind


def mesh_triangles(path: str, scale, where: str) -> np.ndarray:
    """The triangles (n, 3, 3) [m, in the geometry's frame] of the mesh file at ``path``
    scaled per axis by ``scale``, at most ``MAX_STATIC_TRIANGLES`` (more: vertex clustering,
    with a warning), degenerate ones dropped; SceneError naming ``where`` if it has none."""
    vertices, faces = read_mesh(path, scale, where)
    most = MAX_STATIC_TRIANGLES
    triangles = vertices[faces] if len(faces) <= most else decimated(vertices, faces, most)
    if len(faces) > most:
        warnings.warn(SimulationWarning(
            f'{where}: collision mesh {path} has {len(faces)} triangles; contact uses '
            f'{len(triangles)} (vertex clustering: the outline stays, small detail goes)',
            REDUCED, len(faces) / max(len(triangles), 1),
            f'{Path(path).name} {len(faces)} → {len(triangles)} triangles',
            item=f'{where} {path}'), stacklevel=3)
    area = np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0],
                                   triangles[:, 2] - triangles[:, 0]), axis=1)
    triangles = triangles[area > 1e-12 * max(float(area.max(initial=0.0)), 1e-300)]
    if not len(triangles):
        raise SceneError(f'{where}: collision mesh {path} has no triangles (a static mesh '
                         'touches with its faces)')
    return triangles
