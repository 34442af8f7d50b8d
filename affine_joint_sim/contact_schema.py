"""Scene schema of contact (README.md#contact): the ``contact`` settings, the ``ground``
half-spaces and a body's ``collision`` geometry. Validated like the rest of a scene: an unknown
key, a non-positive d_hat or kappa, a negative friction or a degenerate normal is an error
naming its key path."""

import math
from typing import Annotated

from pydantic import BeforeValidator, Field, model_validator

from affine_joint_sim.schema_base import Number, OneOf, PositiveFloat, StrictModel, Vec3

__all__ = ['Contact', 'HalfSpace', 'Ground', 'Capsule', 'Collision', 'Origin',
           'COLLISION_KINDS']

NonNegative = Annotated[Number, Field(ge=0.0)]


class Contact(StrictModel):
    """Contact settings; a scene has contact only when it gives ``contact`` (or ``ground``).

    ``d_hat`` [m]: the barrier's activation distance (things rest less than d_hat apart);
    ``kappa``: the barrier stiffness (libuipc's convention, energy κ (d² − d̂²)² ln(d²/d̂²));
    ``friction``: Coulomb μ of a pair unless a body or half-space gives its own;
    ``eps_velocity`` [m/s]: the slip speed below which friction acts as a stiff viscous law;
    ``damping``: the ratio to critical of a viscous damping on each contact's approach speed
    (1: a bounce dies out at once, as MuJoCo's default; 0: the undamped IPC barrier);
    ``mesh_tolerance`` [m]: how far a moving mesh may reach beyond the convex hull contact
    gives it (its hull's corners are dropped only within it);
    ``self_collision``: bodies of one articulation touch each other (jointed pairs never);
    ``exclude``: pairs of body names that never touch each other (MuJoCo's ``<exclude>``; in
    a URDF scene link names, with the SRDF's ``<disable_collisions>`` added)."""

    d_hat: PositiveFloat = 1.0e-3
    kappa: PositiveFloat = 1.0e9
    friction: NonNegative = 0.5
    eps_velocity: PositiveFloat = 1.0e-3
    damping: NonNegative = 1.0
    mesh_tolerance: PositiveFloat = 1.0e-3
    self_collision: bool = False
    exclude: list[tuple[str, str]] = []


class HalfSpace(StrictModel):
    """A static half-space: ``height`` (z ≥ height) or ``point`` and ``normal`` (the side the
    normal points to is free), and its own ``friction`` μ (None: the scene's)."""

    height: Number | None = None
    point: Vec3 | None = None
    normal: Vec3 | None = None
    friction: NonNegative | None = None

    @model_validator(mode='after')
    def _one_form(self):
        plane = self.point is not None or self.normal is not None
        if (self.height is not None) == plane:
            raise ValueError('give height, or point and normal')
        if plane and (self.point is None or self.normal is None):
            raise ValueError('give both point and normal')
        if plane and math.sqrt(sum(c * c for c in self.normal)) < 1.0e-9:
            raise ValueError(f'normal {list(self.normal)} is degenerate (its length must be '
                             'above 1e-9; it need not be a unit vector)')
        return self




def _listed(value):
    """One half-space given alone is a list of one."""
    return [value] if isinstance(value, dict) else value


# one half-space or a list of them, held as a list
Ground = Annotated[list[HalfSpace], BeforeValidator(_listed), Field(min_length=1)]


class Capsule(StrictModel):
    """A capsule along the body z axis: ``radius`` and the ``length`` between its two sphere
    centres [m]."""

    radius: PositiveFloat
    length: PositiveFloat


class Origin(StrictModel):
    """A pose in the body's frame: ``xyz`` [m] and ``rpy`` [rad] (fixed-axis x-y-z)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


COLLISION_KINDS = ('box', 'sphere', 'capsule', 'cylinder', 'mesh')


class Collision(OneOf):
    """One collision geometry of a body, at ``origin`` in the body's frame: exactly one of
    ``box`` (full side lengths [m]), ``sphere``, ``capsule``, ``cylinder`` or ``mesh``."""

    box: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = None
    sphere: 'SphereGeometry | None' = None
    capsule: Capsule | None = None
    cylinder: 'CylinderGeometry | None' = None
    mesh: 'MeshGeometry | None' = None
    origin: Origin = Origin()

    KINDS = COLLISION_KINDS


class SphereGeometry(StrictModel):
    """A sphere [m]."""

    radius: PositiveFloat


class CylinderGeometry(StrictModel):
    """A cylinder along the body z axis [m]."""

    radius: PositiveFloat
    length: PositiveFloat


class MeshGeometry(StrictModel):
    """A mesh file: ``uri`` (a path relative to the scene file, ``file://`` or, in a URDF,
    ``package://``), ``path`` the file found for it (a URDF's collisions: by the package
    resolution of its visuals; None: ``uri`` itself) and ``scale`` per axis."""

    uri: str
    path: str | None = None
    scale: Vec3 = (1.0, 1.0, 1.0)


Collision.model_rebuild()
