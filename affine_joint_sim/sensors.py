"""Sensors of a scene (its ``sensors`` list; README.md#sensors): IMU and contact readings
computed on the host from a Stepper's outputs (``Stepper.sensors``), when read.

A sensor sits on a *sensor frame*: the frame of the scene's ``frames`` its ``body`` names (a
URDF link, welded ones included), else the body's own frame (for a YAML scene: the body's
centre of mass and axes). Its pose in the world is rigid, as ``Stepper.link_transforms``
gives it: the body's position p and the rotation R nearest to its A (polar decomposition),
times the frame's pose in the body. Readings are expressed in the sensor frame:

- ``imu``: ``orientation`` (quaternion x, y, z, w of the sensor frame in the world, w ≥ 0),
  ``angular_velocity`` [rad/s] (ω from [ω]× = the skew part of Ȧ A⁻¹), ``linear_acceleration``
  [m/s²]: what an accelerometer reads, the specific force a − g with a the acceleration of the
  frame's origin (the finite difference (v_n − v_{n−1}) / dt of its velocity ṗ + Ȧ r̄ over the
  last step) and g the scene's gravity; at rest on the ground +9.81 m/s² along the world's up
  axis. Before the first step and right after a reset it reads −g (the reading at rest).
- ``contact``: ``force`` [N] and ``torque`` [N·m about the frame's origin]: the sum over the
  active contacts of the sensor's body (``Stepper.contacts``: normal_force·normal +
  friction_force at the contact point) and their moment. A sensor on a welded link reads every
  contact of the body it is welded into.

The arithmetic is plain Python floats, per sensor and environment: NumPy would spend about a
microsecond on each operation on a 3-vector (one IMU reads in about 30 µs on the shared 2-core
CPU, each further one about 10 µs, per environment; a contact sensor costs what
``Stepper.contacts`` does, computed once per state for all contact sensors and markers). Only
+ − × ÷ and √ (no LAPACK, no BLAS, no reordered sums): an IMU's readings of a state are the
same bits on every machine, like the state itself (README.md#reproducibility); a contact
sensor sums the forces of ``Stepper.contacts`` as they come (the report kernel's, with the
kernels' own log).
"""

import math
import operator
import warnings

import numpy as np

from affine_joint_sim.rotations import rotation_matrix
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['FIELDS', 'SensorSet', 'polar_rotation', 'quaternion_xyzw']

# The values of each type of sensor, with their sizes (Stepper.sensors keys)
FIELDS = {'imu': {'orientation': 4, 'angular_velocity': 3, 'linear_acceleration': 3},
          'contact': {'force': 3, 'torque': 3}}
_POLAR_ITERATIONS = 30      # at most, of Newton's polar iteration; a near-rotation needs 2 or 3

# 3-vectors are tuples of 3 floats, 3×3 matrices tuples of their 9 entries in row order (an
# ABD state's A = [a1; a2; a3] as it is stored): a few sensors of one environment cost
# microseconds in plain floats, where NumPy would spend about one per operation.


def _matmul(a, b) -> tuple:
    """a @ b of 3×3 matrices."""
    return (a[0] * b[0] + a[1] * b[3] + a[2] * b[6], a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
            a[0] * b[2] + a[1] * b[5] + a[2] * b[8], a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
            a[3] * b[1] + a[4] * b[4] + a[5] * b[7], a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
            a[6] * b[0] + a[7] * b[3] + a[8] * b[6], a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
            a[6] * b[2] + a[7] * b[5] + a[8] * b[8])


def _apply(a, x) -> tuple:
    """a x."""
    return (a[0] * x[0] + a[1] * x[1] + a[2] * x[2], a[3] * x[0] + a[4] * x[1] + a[5] * x[2],
            a[6] * x[0] + a[7] * x[1] + a[8] * x[2])


def _apply_transposed(a, x) -> tuple:
    """aᵀ x: a world vector in the frame whose axes are a's columns."""
    return (a[0] * x[0] + a[3] * x[1] + a[6] * x[2], a[1] * x[0] + a[4] * x[1] + a[7] * x[2],
            a[2] * x[0] + a[5] * x[1] + a[8] * x[2])


def _cross(a, b) -> tuple:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _transposed(a) -> tuple:
    return (a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8])


def _inverse_transposed(a) -> tuple:
    """A⁻ᵀ: the cofactor matrix (rows a1×a2, a2×a0, a0×a1 of A's rows a_i) over det A."""
    c0, c1, c2 = a[4] * a[8] - a[5] * a[7], a[5] * a[6] - a[3] * a[8], a[3] * a[7] - a[4] * a[6]
    det = a[0] * c0 + a[1] * c1 + a[2] * c2
    return (c0 / det, c1 / det, c2 / det,
            (a[7] * a[2] - a[8] * a[1]) / det, (a[8] * a[0] - a[6] * a[2]) / det,
            (a[6] * a[1] - a[7] * a[0]) / det,
            (a[1] * a[5] - a[2] * a[4]) / det, (a[2] * a[3] - a[0] * a[5]) / det,
            (a[0] * a[4] - a[1] * a[3]) / det)


def polar_rotation(a) -> tuple:
    """The rotation nearest to the 3×3 matrix ``a`` (9 entries in row order): the polar
    decomposition's orthogonal factor, as ``poses.rigid_transforms`` gives it, by Newton's
    iteration R ← (R + R⁻ᵀ)/2 from R = A. It converges quadratically: an update of size δ
    leaves an error of about δ²/2, so it stops after an update below 1e-8 (an affine body's A,
    a rotation up to a strain of 1e-6 to 1e-3, takes 2 or 3 iterations). 9 entries in row
    order."""
    r = tuple(map(float, a))
    for _ in range(_POLAR_ITERATIONS):
        following = tuple([0.5 * (x + y) for x, y in zip(r, _inverse_transposed(r))])
        change = max(map(abs, map(operator.sub, following, r)))
        r = following
        if not change > 1e-8:           # what is left is rounding (NaN stops too)
            break
    return r


def quaternion_xyzw(m) -> tuple:
    """The unit quaternion (x, y, z, w), w ≥ 0, of a rotation matrix (9 entries in row order;
    Shepperd's method: the largest of 4w², 4x², 4y², 4z² decides the formula, so no component
    is lost to rounding)."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    candidates = (1.0 + m00 + m11 + m22, 1.0 + m00 - m11 - m22, 1.0 - m00 + m11 - m22,
                  1.0 - m00 - m11 + m22)
    which = max(range(4), key=candidates.__getitem__)
    s = 2.0 * math.sqrt(max(candidates[which], 0.0))
    if which == 0:
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    elif which == 1:
        q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif which == 2:
        q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    else:
        q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        norm = -norm
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


class SensorSet:
    """The sensors of a scene, resolved once: each one's body, its frame's pose in that body,
    and its type. ``read`` computes every reading of every environment.

    Warns (a SimulationWarning, once) about a contact sensor that always reads zero: on a body
    of a scene without contact, a fixed body, or a body without collision geometry.
    """

    def __init__(self, scene):
        self.names = [s.name for s in scene.sensors]
        self.types = [s.type for s in scene.sensors]
        self.frame_ids = [s.body for s in scene.sensors]
        frames = {f.name: f for f in scene.frames}
        bodies = {b.name: i for i, b in enumerate(scene.bodies)}
        self.body = []          # each sensor's body index
        self.rotation = []      # its frame's axes in the body frame (3×3, row order)
        self.offset = []        # its frame's origin in the body frame [m]
        for sensor in scene.sensors:
            frame = frames.get(sensor.body)
            if frame is None:
                self.body.append(bodies[sensor.body])
                rotation, offset = np.eye(3), (0.0, 0.0, 0.0)
            else:
                self.body.append(bodies[frame.body])
                rotation, offset = rotation_matrix(frame.orientation), frame.position
            self.rotation.append(tuple(np.asarray(rotation, dtype=np.float64).ravel().tolist()))
            self.offset.append(tuple(float(x) for x in offset))
        self.body_names = [scene.bodies[b].name for b in self.body]
        self.gravity = tuple(float(g) for g in scene.gravity)
        self.dt = float(scene.dt)
        self.imu = [k for k, t in enumerate(self.types) if t == 'imu']
        self.contact = [k for k, t in enumerate(self.types) if t == 'contact']
        self._bodies = sorted(set(self.body))                       # the bodies read
        self._moving = sorted({self.body[k] for k in self.imu})     # their velocities too
        self._body_index = np.array(self._bodies, dtype=np.intp)
        self._moving_index = np.array(self._moving, dtype=np.intp)
        for k in self.contact:
            self._warn_if_untouchable(scene, k)

    def _warn_if_untouchable(self, scene, k: int) -> None:
        body = scene.bodies[self.body[k]]
        on = f'body {body.name!r}' if body.name == self.frame_ids[k] else \
            f'link {self.frame_ids[k]!r} (body {body.name!r})'
        if scene.contact is None and scene.ground is None:
            why = 'the scene has no contact (give contact or ground)'
        elif body.fixed:
            why = 'the body is fixed (contacts act on the moving bodies that touch it)'
        elif body.collision is None:
            why = 'the body has no collision geometry'
        else:
            return
        warnings.warn(f'contact sensor {self.names[k]!r} on {on} always reads zero: {why}',
                      SimulationWarning, stacklevel=4)

    def read(self, q: np.ndarray, v: np.ndarray | None, v_prev: np.ndarray | None,
             at_start: bool, contacts: list | None) -> dict[str, dict[str, np.ndarray]]:
        """Every sensor's readings, ``{name: {value: array (envs, size)}}`` (FIELDS).

        Args:
            q: body states (envs, bodies, 12) [m, -].
            v, v_prev: body velocities after the last step and after the one before
                (envs, bodies, 12) [m/s, 1/s] (needed by IMUs only; else None).
            at_start: no step since the start or the last reset: IMUs read −g.
            contacts: per environment, ``Stepper.contacts``'s list (needed by contact sensors
                only; else None).
        """
        envs = len(q)
        rows = [[] for _ in self.names]     # per sensor, per environment: its values
        bodies, moving = self._bodies, self._moving
        # plain floats from here on
        q = q[:, self._body_index].astype(np.float64).tolist()
        if moving:
            v = v[:, self._moving_index].astype(np.float64).tolist()
            v_prev = v_prev[:, self._moving_index].astype(np.float64).tolist()
        for e in range(envs):
            states = dict(zip(bodies, q[e]))
            poses = {b: polar_rotation(state[3:]) for b, state in states.items()}
            # body -> its velocity now and one step before
            moved = dict(zip(moving, zip(v[e], v_prev[e]))) if moving else {}
            for k in range(len(self.names)):
                b = self.body[k]
                body_rotation = poses[b]
                rotation = _matmul(body_rotation, self.rotation[k])   # the frame in the world
                if self.types[k] == 'imu':
                    rows[k].append(self._imu(k, states[b][3:], rotation, *moved[b], at_start))
                else:
                    p, r = states[b], _apply(body_rotation, self.offset[k])
                    origin = (p[0] + r[0], p[1] + r[1], p[2] + r[2])
                    rows[k].append(self._contact(k, rotation, origin, contacts[e]))
        out = {}
        for name, kind, values in zip(self.names, self.types, rows):
            array = np.array(values, dtype=np.float64).reshape(envs, -1)
            out[name], start = {}, 0
            for key, size in FIELDS[kind].items():
                out[name][key] = array[:, start:start + size]
                start += size
        return out

    def _imu(self, k: int, a, rotation, v: list, v_prev: list, at_start: bool) -> tuple:
        """One IMU's readings in FIELDS order, from the body's A, the frame's rotation in the
        world, the body's velocity now and one step before."""
        a_dot = v[3:]
        # W = Ȧ A⁻¹ = Ȧ (A⁻ᵀ)ᵀ; ω from its skew part (W − Wᵀ)/2 = [ω]×
        w = _matmul(a_dot, _transposed(_inverse_transposed(a)))
        omega = (0.5 * (w[7] - w[5]), 0.5 * (w[2] - w[6]), 0.5 * (w[3] - w[1]))
        if at_start:
            accel = (0.0, 0.0, 0.0)
        else:       # the frame origin's velocity ṗ + Ȧ r̄, now and one step before
            r = self.offset[k]
            now, before = _apply(a_dot, r), _apply(v_prev[3:], r)
            dt = self.dt
            accel = (((v[0] + now[0]) - (v_prev[0] + before[0])) / dt,
                     ((v[1] + now[1]) - (v_prev[1] + before[1])) / dt,
                     ((v[2] + now[2]) - (v_prev[2] + before[2])) / dt)
        g = self.gravity
        specific = (accel[0] - g[0], accel[1] - g[1], accel[2] - g[2])
        return (*quaternion_xyzw(rotation), *_apply_transposed(rotation, omega),
                *_apply_transposed(rotation, specific))

    def _contact(self, k: int, rotation, origin, contacts: list) -> tuple:
        """One contact sensor's readings in FIELDS order, from its environment's active
        contacts and its frame's pose (a contact of two moving bodies pushes the other one
        back: −f at the same point)."""
        force, torque = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        body = self.body_names[k]
        for contact in contacts:
            if contact['body'] == body:
                sign = 1.0
            elif contact['other'] == body:
                sign = -1.0
            else:
                continue
            push = float(contact['normal_force'])
            normal, friction, point = (np.asarray(contact[key], dtype=np.float64).tolist()
                                       for key in ('normal', 'friction_force', 'point'))
            f = tuple(sign * (push * normal[i] + friction[i]) for i in range(3))
            moment = _cross(tuple(point[i] - origin[i] for i in range(3)), f)
            for i in range(3):
                force[i] += f[i]
                torque[i] += moment[i]
        return (*_apply_transposed(rotation, force), *_apply_transposed(rotation, torque))
