"""The separating-axis test of two boxes under affine maps: an oracle of "never interpenetrate"
independent of the simulator's own distances."""

import numpy as np

__all__ = ['separation']


def separation(qa, qb, half_a, half_b) -> float:
    """The largest gap [m] between two parallelepipeds (boxes of half sides ``half_*`` under
    the affine maps of states q) along the separating axes of the separating-axis theorem:
    face normals of both and the cross products of their edges; ≤ 0 where they overlap."""
    def corners(q, half):
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return q[:3] + (signs * half) @ q[3:].reshape(3, 3).T

    ca, cb = corners(qa, np.asarray(half_a)), corners(qb, np.asarray(half_b))
    ea, eb = qa[3:].reshape(3, 3).T, qb[3:].reshape(3, 3).T      # edge directions (rows)
    axes = [np.cross(ea[(i + 1) % 3], ea[(i + 2) % 3]) for i in range(3)]
    axes += [np.cross(eb[(i + 1) % 3], eb[(i + 2) % 3]) for i in range(3)]
    axes += [np.cross(u, v) for u in ea for v in eb]
    best = -np.inf
    for axis in axes:
        length = np.linalg.norm(axis)
        if length < 1e-9:
            continue
        pa, pb = ca @ axis / length, cb @ axis / length
        best = max(best, pb.min() - pa.max(), pa.min() - pb.max())
    return best
