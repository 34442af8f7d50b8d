"""Triangle meshes: reading a mesh file (``read_mesh``, for contact) and making one smaller
(vertex clustering, ``decimated``, shared by the renderer's drawings and contact's static
meshes)."""

import struct
import warnings
import zipfile

import numpy as np

from affine_joint_sim.scene import SceneError

__all__ = ['read_mesh', 'decimated']


def read_mesh(path: str, scale, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) [m, in the geometry's frame, scaled per axis by ``scale``], faces
    (k, 3)) of the mesh file at ``path``.

    SceneError naming ``where`` if the file cannot be read (what the reader raises) or has no
    finite vertices. The reader's own warnings (pycollada's NumPy deprecations) are not errors
    of the mesh: they are held while it reads and then raised again as they were, so the
    warning filters (``python -W``) treat them as the reader's.
    """
    import trimesh

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        try:
            mesh = trimesh.load(path, force='mesh', process=False)
            vertices = np.asarray(mesh.vertices, dtype=np.float64)
            faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        except _unreadable() as exc:
            problem = f'{where}: cannot read collision mesh {path} ({type(exc).__name__}: {exc})'
        else:
            problem = None
    for record in said:
        warnings.warn_explicit(record.message, record.category, record.filename, record.lineno,
                               source=record.source)
    if problem is not None:
        raise SceneError(problem)
    if vertices.ndim != 2 or len(vertices) == 0 or not np.isfinite(vertices).all():
        raise SceneError(f'{where}: collision mesh {path} has no finite vertices')
    return vertices * np.asarray(scale, dtype=np.float64), faces


def _unreadable() -> tuple[type[Exception], ...]:
    """What trimesh and its readers raise for a missing, bad or unknown file: OSError,
    ValueError (no such file, an unknown type, bad text), LookupError (a face indexing a missing
    vertex), struct.error (a short binary STL), zipfile.BadZipFile (3MF) and, when pycollada is
    installed, its DaeError (DAE)."""
    kinds = (OSError, ValueError, LookupError, struct.error, zipfile.BadZipFile)
    try:
        from collada.common import DaeError
    except ImportError:
        return kinds
    return (*kinds, DaeError)


def decimated(vertices: np.ndarray, faces: np.ndarray, most: int) -> np.ndarray:
    """The triangles (k, 3, 3) of a mesh with at most ``most`` faces (at least a tetrahedron's
    worth): vertices merged into the centroid of their cell of a grid, coarsened until few
    enough faces are left (vertex clustering; the outline stays, small detail goes)."""
    if len(faces) <= most:
        return vertices[faces]
    low = vertices.min(axis=0)
    extent = max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    cells = 64
    while True:
        keys = np.minimum(((vertices - low) / extent * cells).astype(np.int64), cells - 1)
        cell_ids, of_vertex = np.unique(keys, axis=0, return_inverse=True)
        of_vertex = of_vertex.ravel()
        centroids = np.zeros((len(cell_ids), 3))
        np.add.at(centroids, of_vertex, vertices)
        centroids /= np.bincount(of_vertex)[:, None]
        merged = of_vertex[faces]
        proper = (merged[:, 0] != merged[:, 1]) & (merged[:, 1] != merged[:, 2]) \
            & (merged[:, 0] != merged[:, 2])
        kept = np.unique(merged[proper], axis=0)
        if len(kept) <= most or cells <= 2:
            return centroids[kept]
        cells //= 2
