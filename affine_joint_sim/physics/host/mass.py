"""Mass properties of bodies, COM-centred, body axes: closed forms of primitives and bodies given
by mass and principal moments of inertia (URDF links); see docs/physics.md#mass."""

import math

import numpy as np

from affine_joint_sim import portable_math as pm

__all__ = ['MassProperties', 'mass_properties', 'inertia_mass_properties',
           'body_mass_properties', 'second_moments', 'MIN_SIDE_RATIO', 'DENSITY_RANGE']

# An equivalent box's sides are at least this fraction of its longest side (volume, extent) ...
MIN_SIDE_RATIO = 1.0e-2
# ... and its density m / v̄ lies in this range [kg/m³] (foam to beyond tungsten): a link whose
# URDF inertia is (nearly) zero, or a featherweight one, keeps a sensible rigidity κ v̄.
DENSITY_RANGE = (100.0, 20000.0)


class MassProperties:
    """Mass properties of one body about its centre of mass, in its body frame.

    Attributes:
        mass: m [kg].
        volume: v̄ [m^3], scales the orthogonality energy.
        second_moment: diagonal of S = ∫ρ x̄ x̄ᵀ dV [kg·m^2] (S is diagonal in body axes).
        half_extent: half side lengths of the bounding box [m]; its corners are the vertices of
            the Newton convergence test.
    """

    def __init__(self, mass, volume, second_moment, half_extent):
        self.mass = float(mass)
        self.volume = float(volume)
        self.second_moment = np.asarray(second_moment, dtype=np.float64)
        self.half_extent = np.asarray(half_extent, dtype=np.float64)

    @property
    def inertia(self) -> np.ndarray:
        """Rigid inertia tensor about the COM, I_cm = tr(S) I − S [kg·m^2]."""
        s = np.diag(self.second_moment)
        return np.trace(s) * np.eye(3) - s


def mass_properties(shape, density: float | None = None, mass: float | None = None):
    """Mass properties of a scene ``Shape`` from its density [kg/m^3] or total mass [kg]."""
    if shape.kind == 'box':
        a, b, c = shape.box
        volume = a * b * c
        unit_moment = np.array([a * a, b * b, c * c]) / 12.0
        half = np.array([a, b, c]) / 2.0
    elif shape.kind == 'cylinder':
        r, h = shape.cylinder.radius, shape.cylinder.length
        volume = math.pi * r * r * h
        unit_moment = np.array([r * r / 4.0, r * r / 4.0, h * h / 12.0])
        half = np.array([r, r, h / 2.0])
    else:
        r = shape.sphere.radius
        volume = 4.0 / 3.0 * math.pi * (r * r * r)
        unit_moment = np.full(3, r * r / 5.0)
        half = np.full(3, r)
    m = mass if mass is not None else density * volume
    return MassProperties(m, volume, m * unit_moment, half)


def second_moments(inertia) -> np.ndarray:
    """Principal second moments s_i = ½ tr(I) − I_i [kg·m²] of principal moments of inertia
    I_i (Σ = ½ tr(I)·1 − I, docs/physics.md#urdf-inertials)."""
    inertia = np.asarray(inertia, dtype=np.float64)
    return 0.5 * inertia.sum() - inertia


def inertia_mass_properties(mass: float, inertia) -> MassProperties:
    """Mass properties of a body of ``mass`` [kg] with principal moments of inertia ``inertia``
    [kg·m²] about its centre of mass (body axes = principal axes).

    The body's volume v̄ (which scales the orthogonality energy κ v̄) and its extent (the
    corners of the Newton convergence test) are those of the equivalent box: the uniform box
    of the same mass and principal moments, sides a_i = √(12 s_i / m), each side raised to at
    least ``MIN_SIDE_RATIO`` of the longest (a thin rod keeps a finite volume), then the box
    scaled evenly so that its density m / v̄ lies in ``DENSITY_RANGE``.
    """
    s = second_moments(inertia)
    sides = np.sqrt(12.0 * np.maximum(s, 0.0) / mass)
    sides = np.maximum(sides, MIN_SIDE_RATIO * sides.max())
    volume = float(sides[0] * sides[1] * sides[2])
    light, dense = DENSITY_RANGE
    target = min(max(volume, mass / dense), mass / light)
    if target != volume:
        sides = sides * pm.cbrt(target / volume) if volume > 0.0 else np.full(
            3, pm.cbrt(target))
    return MassProperties(mass, target, s, sides / 2.0)


def body_mass_properties(body) -> MassProperties:
    """Mass properties of a scene ``Body``: from its ``inertia`` and ``mass`` when given, else
    from its shape; a fixed body with neither has only its mass (nothing else is used)."""
    if body.inertia is not None:
        return inertia_mass_properties(body.mass, body.inertia)
    if body.shape is None:
        return MassProperties(body.mass, 0.0, np.zeros(3), np.zeros(3))
    return mass_properties(body.shape, body.density, body.mass)
