"""The joint types: one descriptor each, the only list of them (no Warp, no NumPy).

A type's descriptor names what the rest of the project asks of it (its code in
``model.joint_type``, its coordinate and command units); its functions live in
``physics/joints/<name>.py``, a module named after the type that provides every function of
``physics.joints.PROTOCOL``. The kernels' dispatchers, the model build, the scene schema and
the ROS topics all iterate over ``JOINT_KINDS``, so a new type is a module and one entry here
(docs/architecture.md#adding-a-joint-type).
"""

from dataclasses import dataclass

__all__ = ['JointKind', 'JOINT_KINDS', 'JOINT_KIND_NAMES', 'joint_kind', 'REVOLUTE',
           'PRISMATIC', 'FIXED']


@dataclass(frozen=True)
class JointKind:
    """What a joint type is, as the host and the kernels see it."""

    name: str                     # joints[].type in a scene; also the module's name
    code: int                     # its value in model.joint_type (codes are 0, 1, 2, ...)
    uid: int                      # libuipc's constitution UID
    takes_axis: bool              # the scene gives x0, x1 (a weld has no axis)
    linear: bool                  # its constraint residuals are linear in q: constant Hessian
    periodic: bool                # its coordinate is an angle: wrapped, unwrapped across ±π
    coordinate_unit: str | None   # 'rad' | 'm'; None: no coordinate (reported as 0)
    command: str | None           # 'torque' [N·m] | 'force' [N]; None: takes no command


REVOLUTE = JointKind('revolute', 0, 18, takes_axis=True, linear=True, periodic=True,
                     coordinate_unit='rad', command='torque')
PRISMATIC = JointKind('prismatic', 1, 20, takes_axis=True, linear=False, periodic=False,
                      coordinate_unit='m', command='force')
FIXED = JointKind('fixed', 2, 25, takes_axis=False, linear=True, periodic=False,
                  coordinate_unit=None, command=None)

JOINT_KINDS = (REVOLUTE, PRISMATIC, FIXED)     # in code order: JOINT_KINDS[k.code] is k
JOINT_KIND_NAMES = tuple(kind.name for kind in JOINT_KINDS)
_BY_NAME = {kind.name: kind for kind in JOINT_KINDS}


def joint_kind(name: str) -> JointKind:
    """The descriptor of joint type ``name``; ValueError naming the valid ones otherwise."""
    if name not in _BY_NAME:
        raise ValueError(f'unknown joint type {name!r} (valid: {", ".join(JOINT_KIND_NAMES)})')
    return _BY_NAME[name]
