"""Rigid poses of affine bodies and of the frames attached to them (URDF links).

An affine body's A is a rotation up to the small strain the orthogonality energy allows; a
viewer or a user wants the nearest rotation, R = U Vᵀ of A = U S Vᵀ (the polar decomposition's
rotation factor). World frame, homogeneous 4×4 transforms [[R, p], [0, 1]] in metres.
"""

import numpy as np

from affine_joint_sim.rotations import rotation_matrix

__all__ = ['rigid_transforms', 'LinkFrames']


def rigid_transforms(q: np.ndarray) -> np.ndarray:
    """World transforms [[R, p], [0, 1]] of ABD states q = [p, a1, a2, a3], shape
    (..., 12) → (..., 4, 4), with R the rotation nearest to A (polar decomposition)."""
    a = q[..., 3:].reshape(*q.shape[:-1], 3, 3)
    u, _, vt = np.linalg.svd(a)
    flip = np.linalg.det(u @ vt) < 0.0          # never for a body that is not inverted
    u[..., :, 2] = np.where(flip[..., None], -u[..., :, 2], u[..., :, 2])
    out = np.zeros((*q.shape[:-1], 4, 4))
    out[..., :3, :3] = u @ vt
    out[..., :3, 3] = q[..., :3]
    out[..., 3, 3] = 1.0
    return out


class LinkFrames:
    """The named frames of a scene: its ``frames`` (URDF links) or, for a scene without any,
    one frame per body at the body's origin.

    Attributes:
        names: frame names.
        body: index of the body each frame is attached to.
        local: each frame's pose in its body's frame, (n_frames, 4, 4).
    """

    def __init__(self, scene):
        if scene.frames:
            self.names = [f.name for f in scene.frames]
            self.body = np.array([scene.body_index(f.body) for f in scene.frames])
            self.local = np.tile(np.eye(4), (len(scene.frames), 1, 1))
            for i, frame in enumerate(scene.frames):
                self.local[i, :3, :3] = rotation_matrix(frame.orientation)
                self.local[i, :3, 3] = frame.position
        else:
            self.names = [b.name for b in scene.bodies]
            self.body = np.arange(len(scene.bodies))
            self.local = np.tile(np.eye(4), (len(scene.bodies), 1, 1))
