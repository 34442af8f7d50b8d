"""Rigid poses of frames on affine bodies, for viewers and ``Stepper.link_transforms``: one
kernel, one thread per frame.

Frame i sits on body ``body[i]`` of environment ``env[i]`` with rotation ``rotation[i]`` and
offset ``offset[i]`` in the body's rest frame; its pose is in the world, or, where
``parent[i]`` ≥ 0, in the frame at ``parent_rotation[i]``, ``parent_offset[i]`` on body
``parent[i]`` (/tf's parent link). Its world pose uses the rotation R nearest to the body's A
(the polar decomposition's, R = U Vᵀ of A = U Σ Vᵀ; for the nearly rigid A of a running
simulation three Newton–Schulz steps R ← R (3 − RᵀR) / 2 reach it to rounding at a fraction of
an SVD's cost, an SVD is taken when ‖AᵀA − I‖_F ≥ 0.1): position p + R·offset and orientation
R·rotation (relative to a parent frame F: Fᵀ(p − p_F), Fᵀ R·rotation). A frame's row holds the
position, the orientation as a unit quaternion (x, y, z, w) with w ≥ 0, then the same pose as
the rigid 4×4 transform [[rotation, position], [0 0 0 1]], row-major, which
``Stepper.link_transforms`` copies out as it is.
Built per precision, in a Warp module of its own (only scenes that are viewed or whose links
are read compile it).
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build', 'FRAME_COLUMNS', 'POSE_COLUMNS']

POSE_COLUMNS = 7            # x y z, qx qy qz qw
FRAME_COLUMNS = 23          # and the 4×4 transform's t00 t01 t02 t03 t10 ... t33


def build(t) -> SimpleNamespace:
    scalar, vec3, mat33, vec12 = t.scalar, t.vec3, t.mat33, t.vec12
    zero, half, one, two, three = t.zero, t.half, t.one, t.two, t.three
    quarter, near_rigid = t.scalar(0.25), t.scalar(0.1)
    affine, svd = t.affine, t.svd

    @wp.func
    def quaternion(r: mat33):
        """(x, y, z, w), w ≥ 0, of a rotation matrix (branch on the largest component)."""
        trace = r[0, 0] + r[1, 1] + r[2, 2]
        x = zero
        y = zero
        z = zero
        w = zero
        if trace > zero:
            s = wp.sqrt(trace + one) * two
            w = s * quarter
            x = (r[2, 1] - r[1, 2]) / s
            y = (r[0, 2] - r[2, 0]) / s
            z = (r[1, 0] - r[0, 1]) / s
        elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
            s = wp.sqrt(one + r[0, 0] - r[1, 1] - r[2, 2]) * two
            w = (r[2, 1] - r[1, 2]) / s
            x = s * quarter
            y = (r[0, 1] + r[1, 0]) / s
            z = (r[0, 2] + r[2, 0]) / s
        elif r[1, 1] > r[2, 2]:
            s = wp.sqrt(one + r[1, 1] - r[0, 0] - r[2, 2]) * two
            w = (r[0, 2] - r[2, 0]) / s
            x = (r[0, 1] + r[1, 0]) / s
            y = s * quarter
            z = (r[1, 2] + r[2, 1]) / s
        else:
            s = wp.sqrt(one + r[2, 2] - r[0, 0] - r[1, 1]) * two
            w = (r[1, 0] - r[0, 1]) / s
            x = (r[0, 2] + r[2, 0]) / s
            y = (r[1, 2] + r[2, 1]) / s
            z = s * quarter
        norm = wp.sqrt(x * x + y * y + z * z + w * w)
        if w < zero:
            norm = -norm
        return x / norm, y / norm, z / norm, w / norm

    @wp.func
    def rigid(state: vec12):
        """(p, R): the body's position and the rotation nearest to its A."""
        a = affine(state)
        eye = wp.identity(n=3, dtype=scalar)
        gram = wp.transpose(a) * a - eye
        r = a
        if wp.sqrt(wp.ddot(gram, gram)) < near_rigid:
            for _ in range(3):
                r = r * (three * eye - wp.transpose(r) * r) * half
        else:
            u, sigma, v = svd(a)
            r = u * wp.transpose(v)
        return vec3(state[0], state[1], state[2]), r

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def frame_poses(q: wp.array2d(dtype=vec12), env: wp.array(dtype=int),
                    body: wp.array(dtype=int),
                    rotation: wp.array(dtype=mat33), offset: wp.array(dtype=vec3),
                    parent: wp.array(dtype=int), parent_rotation: wp.array(dtype=mat33),
                    parent_offset: wp.array(dtype=vec3), out: wp.array2d(dtype=wp.float64)):
        i = wp.tid()
        c, r = rigid(q[env[i], body[i]])
        p = c + r * offset[i]
        turn = r * rotation[i]
        if parent[i] >= 0:          # relative to a frame on another (or the same) body
            c_up, r_up = rigid(q[env[i], parent[i]])
            up = r_up * parent_rotation[i]
            p = wp.transpose(up) * (p - c_up - r_up * parent_offset[i])
            turn = wp.transpose(up) * turn
        x, y, z, w = quaternion(turn)
        out[i, 0] = wp.float64(p[0])
        out[i, 1] = wp.float64(p[1])
        out[i, 2] = wp.float64(p[2])
        out[i, 3] = wp.float64(x)
        out[i, 4] = wp.float64(y)
        out[i, 5] = wp.float64(z)
        out[i, 6] = wp.float64(w)
        for row in range(3):
            for column in range(3):
                out[i, 7 + 4 * row + column] = wp.float64(turn[row, column])
            out[i, 7 + 4 * row + 3] = wp.float64(p[row])
            out[i, 7 + 12 + row] = wp.float64(0.0)
        out[i, 7 + 15] = wp.float64(1.0)

    return SimpleNamespace(frame_poses=frame_poses, rigid=rigid, quaternion=quaternion)
