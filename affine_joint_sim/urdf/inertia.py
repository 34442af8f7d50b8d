"""Mass properties of URDF links as affine bodies (docs/physics.md#urdf-inertials).

A link's ``<inertial>`` gives its mass m, its centre of mass and its inertia tensor I about the
centre of mass in the inertial frame. Links welded together combine by the parallel-axis rule.
The affine body's rest frame is the principal frame of the combined inertia (the eigenvectors
of Σ = ½ tr(I)·1 − I, which are those of I), at the centre of mass. All tensors here are in the
world frame at t = 0 unless said otherwise; NumPy float64.
"""

import numpy as np

from affine_joint_sim import portable_math as pm

__all__ = ['LinkInertia', 'combine', 'principal_frame', 'physical_moments', 'MIN_MOMENT_RATIO',
           'MIN_RADIUS']

# The smallest principal second moment s_i a body keeps, relative to its largest (a rigid body
# needs S ≻ 0: s_i = 0 would leave a rotation without inertia) ...
MIN_MOMENT_RATIO = 1.0e-6
# ... and at least m·r² with this radius [m] (a point mass gets the inertia of a ~2 mm ball).
MIN_RADIUS = 1.0e-3


class LinkInertia:
    """Mass [kg], centre of mass [m] and inertia about it [kg·m²], world frame."""

    def __init__(self, mass: float, com, inertia):
        self.mass = float(mass)
        self.com = np.asarray(com, dtype=np.float64)
        self.inertia = np.asarray(inertia, dtype=np.float64)

    @classmethod
    def of_link(cls, inertial, link_pose: np.ndarray) -> 'LinkInertia':
        """The world mass properties of a URDF ``<inertial>`` (yourdfpy's) on a link whose
        world pose is the 4×4 ``link_pose``; a link without one has none (mass 0)."""
        if inertial is None or not inertial.mass:
            return cls(0.0, link_pose[:3, 3], np.zeros((3, 3)))
        origin = np.eye(4) if inertial.origin is None else inertial.origin
        pose = pm.matmul(link_pose, origin)
        tensor = np.zeros((3, 3)) if inertial.inertia is None else inertial.inertia
        rot = pose[:3, :3]
        return cls(inertial.mass, pose[:3, 3], pm.matmul(pm.matmul(rot, tensor), rot.T))


def combine(parts: list[LinkInertia]) -> LinkInertia:
    """Welded parts as one: total mass, mass-weighted COM, and the inertia about that COM by
    the parallel-axis rule I = Σ I_k + m_k (|d_k|² 1 − d_k d_kᵀ), d_k = c_k − c."""
    mass = sum(p.mass for p in parts)
    if mass <= 0.0:
        return LinkInertia(0.0, parts[0].com, np.zeros((3, 3)))
    com = sum(p.mass * p.com for p in parts) / mass
    inertia = np.zeros((3, 3))
    for part in parts:
        d = part.com - com
        inertia += part.inertia + part.mass * (pm.dot(d, d) * np.eye(3) - np.outer(d, d))
    return LinkInertia(mass, com, inertia)


def principal_frame(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and the world←principal rotation (columns = axes,
    det +1, one definite choice where moments are equal: ``portable_math.symmetric_eigen``)
    of a symmetric inertia tensor."""
    return pm.symmetric_eigen(0.5 * (inertia + inertia.T))


def physical_moments(mass: float, moments: np.ndarray) -> tuple[np.ndarray, str | None]:
    """Principal moments a body can have, and what was changed (None when nothing was).

    The second moments s_i = ½ Σ I − I_i must be positive (the triangle inequality I_i ≤
    I_j + I_k, strictly). The smallest change that restores it: each s_i is raised to
    max(MIN_MOMENT_RATIO · max s, m · MIN_RADIUS²) where it is below, and I is rebuilt from s
    (I_i = Σ s − s_i). Negative moments are not an inertia at all: ValueError.
    """
    if moments.min() < -1e-12 * max(1.0, moments.max()):
        raise ValueError(f'negative principal moment of inertia ({moments.min():.6g} kg·m²)')
    s = 0.5 * moments.sum() - moments
    floor = max(MIN_MOMENT_RATIO * s.max(), mass * (MIN_RADIUS * MIN_RADIUS))
    if s.min() >= floor:
        return moments, None
    fixed_s = np.maximum(s, floor)
    fixed = fixed_s.sum() - fixed_s
    roundoff = 1e-9 * max(moments.max(), mass * (MIN_RADIUS * MIN_RADIUS))
    what = ('violates the triangle inequality (I_i > I_j + I_k)' if s.min() < -roundoff else
            'is (nearly) degenerate: a rotation without inertia')
    return fixed, (f'inertia {_fmt(moments)} {what}; using {_fmt(fixed)} kg·m² (second moments '
                   f'raised to at least {floor:.3g} kg·m²)')


def _fmt(values) -> str:
    return '[' + ', '.join(f'{v:.6g}' for v in values) + ']'
