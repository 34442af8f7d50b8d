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

The arithmetic is plain Python floats, per sensor and environment: one NumPy operation on a
3-vector costs more than Python's whole product. NumPy only takes the states in (a basic index
per body read: fancy indexing costs several times more) and gives the readings out (one array,
a view per value). Each body's rotation is computed once per read for all its sensors, and the
contacts are grouped by body once per read for all contact sensors (``Stepper.contacts`` itself
is computed once per state for the contact sensors and markers; README.md#sensors has the
costs). Only + − × ÷ and √ (no LAPACK, no BLAS, no reordered sums): an IMU's readings of a
state are the same bits on every machine, like the state itself (README.md#reproducibility); a
contact sensor sums the forces of ``Stepper.contacts`` as they come (the report kernel's, with
the kernels' own log).
"""

import math
import warnings
from typing import NamedTuple

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
    return _polar(a)[0]


def _polar(a) -> tuple[tuple, tuple]:
    """(``polar_rotation(a)``, A⁻ᵀ): the iteration's first step computes A⁻ᵀ, which an IMU
    needs too."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r = tuple(map(float, a))
    first = None
    for _ in range(_POLAR_ITERATIONS):
        inverse = _inverse_transposed(r)
        if first is None:
            first = inverse
        i0, i1, i2, i3, i4, i5, i6, i7, i8 = inverse
        f0, f1, f2, f3, f4, f5, f6, f7, f8 = r = (
            0.5 * (r0 + i0), 0.5 * (r1 + i1), 0.5 * (r2 + i2), 0.5 * (r3 + i3),
            0.5 * (r4 + i4), 0.5 * (r5 + i5), 0.5 * (r6 + i6), 0.5 * (r7 + i7), 0.5 * (r8 + i8))
        change = max(abs(f0 - r0), abs(f1 - r1), abs(f2 - r2), abs(f3 - r3), abs(f4 - r4),
                     abs(f5 - r5), abs(f6 - r6), abs(f7 - r7), abs(f8 - r8))
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
        if not change > 1e-8:           # what is left is rounding (NaN stops too)
            break
    return r, first


def _angular_velocity(a_dot, a_inverse_transposed) -> tuple:
    """ω [rad/s, world] from [ω]× = the skew part (W − Wᵀ)/2 of W = Ȧ A⁻¹, whose entry W_ij
    is row i of Ȧ times row j of A⁻ᵀ (only the six off the diagonal are computed)."""
    d, t = a_dot, a_inverse_transposed
    w01 = d[0] * t[3] + d[1] * t[4] + d[2] * t[5]
    w02 = d[0] * t[6] + d[1] * t[7] + d[2] * t[8]
    w10 = d[3] * t[0] + d[4] * t[1] + d[5] * t[2]
    w12 = d[3] * t[6] + d[4] * t[7] + d[5] * t[8]
    w20 = d[6] * t[0] + d[7] * t[1] + d[8] * t[2]
    w21 = d[6] * t[3] + d[7] * t[4] + d[8] * t[5]
    return (0.5 * (w21 - w12), 0.5 * (w02 - w20), 0.5 * (w10 - w01))


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


class _Mount(NamedTuple):
    """Where one sensor reads, resolved once (``SensorSet``)."""

    kind: str               # its type: 'imu' or 'contact'
    state: int              # its body's place among the bodies whose states are read
    velocity: int | None    # an IMU's body's place among those whose velocities are read
    rotation: tuple         # its frame's axes in the body frame (3×3, row order)
    offset: tuple           # its frame's origin in the body frame [m]
    body_name: str          # its body's name (the contacts name it)


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
        self.body = [bodies[frames[s.body].body if s.body in frames else s.body]
                     for s in scene.sensors]        # each sensor's body index
        self.body_names = [scene.bodies[b].name for b in self.body]
        self.gravity = tuple(float(g) for g in scene.gravity)
        self.dt = float(scene.dt)
        self.imu = [k for k, t in enumerate(self.types) if t == 'imu']
        self.contact = [k for k, t in enumerate(self.types) if t == 'contact']
        self._bodies_read = sorted(set(self.body))                  # their states are read
        self._moving = sorted({self.body[k] for k in self.imu})     # their velocities too
        self._mounts = [self._mount(k, frames.get(frame_id))
                        for k, frame_id in enumerate(self.frame_ids)]
        self._touched = sorted({self.body_names[k] for k in self.contact})
        self._fields = self._field_slices()
        for k in self.contact:
            self._warn_if_untouchable(scene, k)

    def _mount(self, k: int, frame) -> _Mount:
        """Sensor k's ``_Mount``; ``frame``: the scene frame its ``body`` names, or None (it
        names a body: the body's own frame)."""
        rotation, offset = (np.eye(3), (0.0, 0.0, 0.0)) if frame is None else (
            rotation_matrix(frame.orientation), frame.position)
        body = self.body[k]
        return _Mount(self.types[k], self._bodies_read.index(body),
                      self._moving.index(body) if body in self._moving else None,
                      tuple(np.asarray(rotation, dtype=np.float64).ravel().tolist()),
                      tuple(float(x) for x in offset), self.body_names[k])

    def _field_slices(self) -> list[tuple[str, list[tuple[str, slice]]]]:
        """(name, [(value key, its columns in a row of every reading)]) per sensor: a row
        holds the sensors' values one after the other, each in FIELDS order."""
        fields, start = [], 0
        for name, kind in zip(self.names, self.types):
            columns = []
            for key, size in FIELDS[kind].items():
                columns.append((key, slice(start, start + size)))
                start += size
            fields.append((name, columns))
        return fields

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
        """Every sensor's readings, ``{name: {value: array (envs, size)}}`` (FIELDS; the
        arrays are views of one array of every value).

        Args:
            q: body states (envs, bodies, 12) [m, -].
            v, v_prev: body velocities after the last step and after the one before
                (envs, bodies, 12) [m/s, 1/s] (needed by IMUs only; else None).
            at_start: no step since the start or the last reset: IMUs read −g.
            contacts: per environment, ``Stepper.contacts``'s list (needed by contact sensors
                only; else None).
        """
        states = _per_env(q, self._bodies_read)       # plain floats from here on
        if self.imu:
            velocities = [list(zip(now, before)) for now, before in zip(
                _per_env(v, self._moving), _per_env(v_prev, self._moving))]
        rows = [self._row(states[e], velocities[e] if self.imu else None, at_start,
                          self._touching(contacts[e]) if self.contact else None)
                for e in range(len(states))]
        values = np.array(rows, dtype=np.float64)
        return {name: {key: values[:, columns] for key, columns in fields}
                for name, fields in self._fields}

    def _row(self, states: list, velocities: list | None, at_start: bool,
             touching: dict | None) -> list[float]:
        """One environment's values of every sensor, one after the other, from the states of
        the bodies read, the IMU bodies' (velocity now, one step before) and ``_touching``."""
        poses = [_polar(state[3:]) for state in states]     # (R, A⁻ᵀ) of each body
        row = []
        for kind, slot, moving, frame_rotation, offset, body_name in self._mounts:
            body_rotation, a_inverse_transposed = poses[slot]
            rotation = _matmul(body_rotation, frame_rotation)   # the frame in the world
            if kind == 'imu':
                row += self._imu(a_inverse_transposed, rotation, offset, *velocities[moving],
                                 at_start)
            else:
                p, r = states[slot], _apply(body_rotation, offset)
                origin = (p[0] + r[0], p[1] + r[1], p[2] + r[2])
                row += _wrench(rotation, origin, touching[body_name])
        return row

    def _touching(self, contacts: list) -> dict[str, list]:
        """For each body a contact sensor is on (by name): its contacts among ``contacts`` (one
        environment's ``Stepper.contacts``), in their order, each with the sign of its force
        on that body (a contact of two moving bodies pushes the ``other`` one back: −1)."""
        touching = {name: [] for name in self._touched}
        for contact in contacts:
            mine = touching.get(contact['body'])
            if mine is not None:
                mine.append((1.0, contact))
            theirs = touching.get(contact['other'])
            if theirs is not None:
                theirs.append((-1.0, contact))
        return touching

    def _imu(self, a_inverse_transposed, rotation, offset, v: list, v_prev: list,
             at_start: bool) -> tuple:
        """One IMU's readings in FIELDS order, from its body's A⁻ᵀ, the frame's rotation in
        the world and origin in the body [m], the body's velocity now and one step before."""
        omega = _angular_velocity(v[3:], a_inverse_transposed)
        if at_start:
            accel = (0.0, 0.0, 0.0)
        else:       # the frame origin's velocity ṗ + Ȧ r̄, now and one step before
            now, before = _apply(v[3:], offset), _apply(v_prev[3:], offset)
            dt = self.dt
            accel = (((v[0] + now[0]) - (v_prev[0] + before[0])) / dt,
                     ((v[1] + now[1]) - (v_prev[1] + before[1])) / dt,
                     ((v[2] + now[2]) - (v_prev[2] + before[2])) / dt)
        g = self.gravity
        specific = (accel[0] - g[0], accel[1] - g[1], accel[2] - g[2])
        return (*quaternion_xyzw(rotation), *_apply_transposed(rotation, omega),
                *_apply_transposed(rotation, specific))


def _per_env(array: np.ndarray, bodies: list[int]) -> list[tuple]:
    """``array[e, b]`` (envs, bodies, ...) as lists of floats: per environment e, one for each
    body b of ``bodies``. One basic index per body: NumPy's fancy indexing costs several times
    more on arrays this small."""
    return list(zip(*[array[:, b].tolist() for b in bodies]))


def _wrench(rotation, origin, touching: list) -> tuple:
    """A contact sensor's readings in FIELDS order: the force [N] and moment [N·m about
    ``origin``] of the contacts ``touching`` it ((sign, contact) as ``SensorSet._touching``
    gives them: normal_force·normal + friction_force at the contact's point, times the sign),
    summed in their order and turned into the frame whose axes are ``rotation``'s columns."""
    fx = fy = fz = tx = ty = tz = 0.0
    for sign, contact in touching:
        push = float(contact['normal_force'])
        nx, ny, nz = contact['normal'].tolist()
        ux, uy, uz = contact['friction_force'].tolist()
        px, py, pz = contact['point'].tolist()
        f = (sign * (push * nx + ux), sign * (push * ny + uy), sign * (push * nz + uz))
        mx, my, mz = _cross((px - origin[0], py - origin[1], pz - origin[2]), f)
        fx, fy, fz = fx + f[0], fy + f[1], fz + f[2]
        tx, ty, tz = tx + mx, ty + my, tz + mz
    return (*_apply_transposed(rotation, (fx, fy, fz)),
            *_apply_transposed(rotation, (tx, ty, tz)))
