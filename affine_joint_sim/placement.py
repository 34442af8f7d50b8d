"""Placing a free body between steps (``Stepper.set_body_state``, README.md#placing-a-body):
the checks a placement passes, the ABD rows of a rigid pose and twist, and a placement as the
node records it (an event on ``~/events`` that replay applies again).

A free body is one that is not fixed and in no joint: a jointed body's pose follows from its
joints, and moving it alone would tear them. World frame, metres, seconds, radians.
"""

import numpy as np

from affine_joint_sim.rotations import quaternion_matrix

__all__ = ['PLACEMENT_EVENT', 'ROTATION_TOLERANCE', 'QUATERNION_TOLERANCE', 'free_body',
           'body_rows', 'placement_event', 'place']

ROTATION_TOLERANCE = 1e-6     # |RᵀR − I| (largest entry) of a pose's rotation block
QUATERNION_TOLERANCE = 1e-3   # | |q| − 1 | of an orientation: normalised within, refused beyond
PLACEMENT_EVENT = 'set_entity_state'


def free_body(scene, name: str) -> int:
    """Index of body ``name``; KeyError naming the valid ones if there is none, ValueError if
    it is fixed or in a joint."""
    b = scene.body_index(name)
    if scene.bodies[b].fixed:
        raise ValueError(f'body {name!r} is fixed: only a free body (not fixed, in no joint) '
                         'is placed')
    joints = [j.name for j in scene.joints if name in (j.parent, j.child)]
    if joints:
        raise ValueError(f'body {name!r} is in joints {", ".join(map(repr, joints))}: only a '
                         'free body (not fixed, in no joint) is placed; a jointed body moves '
                         'with its joints')
    return b


def body_rows(pose, local, linear_velocity, angular_velocity):
    """(q, q̇) rows (12 each) of a body whose frame at ``local`` (4×4, in the body) has world
    pose ``pose`` (4×4: a rotation and a position [m]), its origin moving at
    ``linear_velocity`` [m/s] and turning at ``angular_velocity`` ω [rad/s]: q = [p, A], A = R
    (no strain), q̇ = [ṗ, ω× R] with ṗ the body origin's velocity. ValueError naming what is
    wrong otherwise."""
    pose = np.asarray(pose, dtype=np.float64)
    velocity, omega = (np.asarray(x, dtype=np.float64) for x in (linear_velocity,
                                                                 angular_velocity))
    if pose.shape != (4, 4) or velocity.shape != (3,) or omega.shape != (3,):
        raise ValueError(f'pose must be 4×4 and the velocities 3-vectors, got shapes '
                         f'{pose.shape}, {velocity.shape}, {omega.shape}')
    if not (np.isfinite(pose).all() and np.isfinite(velocity).all()
            and np.isfinite(omega).all()):
        raise ValueError('pose and velocities must be finite')
    rotation = pose[:3, :3]
    strain = np.abs(rotation.T @ rotation - np.eye(3)).max()
    if strain > ROTATION_TOLERANCE or np.linalg.det(rotation) < 0.0:
        raise ValueError(f'the pose\'s rotation block is not a rotation (|RᵀR − I| = '
                         f'{strain:.3g}, det {np.linalg.det(rotation):.3g}; within '
                         f'{ROTATION_TOLERANCE:g} and det 1 expected)')
    body = pose @ np.linalg.inv(local)
    spin = np.array([[0.0, -omega[2], omega[1]], [omega[2], 0.0, -omega[0]],
                     [-omega[1], omega[0], 0.0]])
    q = np.concatenate([body[:3, 3], body[:3, :3].reshape(9)])
    # the body origin's velocity: the frame origin's plus ω × the offset between them
    v = np.concatenate([velocity + np.cross(omega, body[:3, 3] - pose[:3, 3]),
                        (spin @ body[:3, :3]).reshape(9)])
    return q, v


def placement_event(entity: str, position, orientation, linear_velocity,
                    angular_velocity) -> dict:
    """The event that records a placement (``~/events``): the body, its frame's position [m]
    and orientation (quaternion x, y, z, w), linear [m/s] and angular [rad/s] velocity, world
    frame, as plain floats. ValueError if the orientation is no unit quaternion (within
    QUATERNION_TOLERANCE; normalised then) or a value is not finite."""
    values = [float(x) for x in (*position, *orientation, *linear_velocity, *angular_velocity)]
    if len(values) != 13 or not np.isfinite(values).all():
        raise ValueError('position, orientation and velocities must be 3 + 4 + 3 + 3 finite '
                         'numbers')
    norm = float(np.linalg.norm(values[3:7]))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise ValueError(f'orientation {values[3:7]} is no unit quaternion (norm {norm:.6g}; '
                         f'1 ± {QUATERNION_TOLERANCE:g} expected, e.g. w = 1 for no turn)')
    return {'event': PLACEMENT_EVENT, 'entity': entity, 'position': values[:3],
            'orientation': values[3:7], 'linear_velocity': values[7:10],
            'angular_velocity': values[10:]}


def place(sim, event: dict, env: int = 0) -> None:
    """Apply a placement event (``placement_event``) to Stepper ``sim``; its errors as
    ``Stepper.set_body_state`` raises them."""
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = quaternion_matrix(*event['orientation']), event['position']
    sim.set_body_state(event['entity'], pose, event['linear_velocity'],
                       event['angular_velocity'], env)
