"""Closed-form mass properties of primitives (physics_spec §1.5), COM-centred, body axes."""

import math

import numpy as np

__all__ = ['MassProperties', 'mass_properties']


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
        volume = 4.0 / 3.0 * math.pi * r ** 3
        unit_moment = np.full(3, r * r / 5.0)
        half = np.full(3, r)
    m = mass if mass is not None else density * volume
    return MassProperties(m, volume, m * unit_moment, half)
