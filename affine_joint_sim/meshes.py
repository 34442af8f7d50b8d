"""Triangle meshes made smaller: vertex clustering (``decimated``), shared by the renderer's
drawings and contact's static meshes."""

import numpy as np

__all__ = ['decimated']


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
