"""Rotation matrices of the scene's orientations, quaternions and axis-angle turns (NumPy only).

Every matrix R is 3×3 and maps a vector's coordinates in the rotated frame (a body, a link, a
visual) to its coordinates in the frame it is given in (the world, or the body it hangs on).
Quaternions are unit (x, y, z, w), angles in radians. Computed with ``portable_math``, so a
scene's poses are the same bits on every machine.
"""

import numpy as np

from affine_joint_sim import portable_math as pm

__all__ = ['rotation_matrix', 'rpy_matrix', 'rpy_from_matrix', 'pose_matrix',
           'quaternion_matrix', 'quaternion_from_matrix', 'axis_rotation']


def rotation_matrix(orientation) -> np.ndarray:
    """R of a scene ``Orientation`` (None = identity): ``rpy`` as fixed-axis roll, pitch, yaw
    about x, y, z (R = Rz(y) Ry(p) Rx(r), REP 103), or ``quat_xyzw``."""
    if orientation is None:
        return np.eye(3)
    if orientation.rpy is not None:
        return rpy_matrix(*orientation.rpy)
    return quaternion_matrix(*orientation.quat_xyzw)


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """R = Rz(y) Ry(p) Rx(r): fixed-axis roll, pitch, yaw about x, y, z (REP 103, URDF)."""
    cr, sr, cp, sp, cy, sy = pm.cos(r), pm.sin(r), pm.cos(p), pm.sin(p), pm.cos(y), pm.sin(y)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return pm.matmul(rz, pm.matmul(ry, rx))


def rpy_from_matrix(rot: np.ndarray) -> list[float]:
    """[roll, pitch, yaw] [rad] with rpy_matrix(roll, pitch, yaw) = ``rot`` (pitch in
    [−π/2, π/2]; at ±π/2, where only roll ∓ yaw is defined, roll is 0)."""
    m = rot
    across = float(np.sqrt(m[0, 0] * m[0, 0] + m[1, 0] * m[1, 0]))     # |cos pitch|
    pitch = pm.atan2(-m[2, 0], across)
    if across < 1.0e-12:
        return [0.0, pitch, pm.atan2(-m[0, 1], m[1, 1])]
    return [pm.atan2(m[2, 1], m[2, 2]), pitch, pm.atan2(m[1, 0], m[0, 0])]


def pose_matrix(xyz, rpy) -> np.ndarray:
    """The 4×4 pose [[R, xyz], [0, 1]] of a URDF ``<origin>`` (R = rpy_matrix(*rpy))."""
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rpy_matrix(*rpy), xyz
    return out


def quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """R of the quaternion (x, y, z, w), normalised first."""
    x, y, z, w = np.array([x, y, z, w]) / pm.norm([x, y, z, w])
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def quaternion_from_matrix(rot: np.ndarray) -> list[float]:
    """Unit quaternion [x, y, z, w] of a rotation matrix (Shepperd's method)."""
    m = rot
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + m[i, i] - m[j, j] - m[k, k], 0.0))
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = s / 4, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    norm = float(np.sqrt(sum(c * c for c in q)))
    return [float(c) / norm for c in q]


def axis_rotation(axis, angle: float) -> np.ndarray:
    """R of a turn by ``angle`` [rad] about the unit vector ``axis`` (Rodrigues' formula)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + pm.sin(angle) * k + (1.0 - pm.cos(angle)) * pm.matmul(k, k)
