"""Sensors of a scene (its ``sensors`` list; README.md#sensors): where each one reads, resolved
once on the host, for the sensor kernel (``physics.stages.sensing``) that ``Stepper.sensors``
replays.

A sensor sits on a *sensor frame*: the frame of the scene's ``frames`` its ``body`` names (a
URDF link, welded ones included), else the body's own frame (for a YAML scene: the body's
centre of mass and axes). Its pose in the world is rigid, as ``Stepper.link_transforms``
gives it. Readings are expressed in the sensor frame:

- ``imu``: ``orientation`` (quaternion x, y, z, w of the sensor frame in the world, w ≥ 0),
  ``angular_velocity`` [rad/s] (ω from [ω]× = the skew part of Ȧ A⁻¹), ``linear_acceleration``
  [m/s²]: what an accelerometer reads, the specific force a − g with a the acceleration of the
  frame's origin (the finite difference (v_n − v_{n−1}) / dt of its velocity ṗ + Ȧ r̄ over the
  last step) and g the scene's gravity; at rest on the ground +9.81 m/s² along the world's up
  axis. Before the first step and right after a reset it reads −g (the reading at rest).
- ``contact``: ``force`` [N] and ``torque`` [N·m about the frame's origin]: the sum over the
  active contacts of the sensor's body (those ``Stepper.contacts`` lists: normal_force·normal +
  friction_force at the contact point) and their moment. A sensor on a welded link reads every
  contact of the body it is welded into.

Every reading of every environment is one row of one array (a sensor's values one after the
other, in FIELDS order), computed by one kernel launch per read: the kernels' own arithmetic,
the same bits on every machine as the state itself (README.md#reproducibility).
"""

from typing import NamedTuple
import warnings

import numpy as np

from affine_joint_sim.rotations import rotation_matrix
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['FIELDS', 'IMU', 'CONTACT', 'SensorSet']

# The values of each type of sensor, with their sizes (Stepper.sensors keys)
FIELDS = {'imu': {'orientation': 4, 'angular_velocity': 3, 'linear_acceleration': 3},
          'contact': {'force': 3, 'torque': 3}}
IMU, CONTACT = 0, 1         # a sensor's kind in the sensor kernel (physics.stages.sensing)
_KINDS = {'imu': IMU, 'contact': CONTACT}


class Mounts(NamedTuple):
    """Where the sensors read, one entry per sensor in scene order (the sensor kernel's
    inputs)."""

    kind: np.ndarray        # physics.stages.sensing.IMU or CONTACT (int32)
    body: np.ndarray        # its body's index (int32)
    rotation: np.ndarray    # its frame's axes in the body frame (3×3 each)
    offset: np.ndarray      # its frame's origin in the body frame [m]
    column: np.ndarray      # its first column in a row of readings (int32)


class SensorSet:
    """The sensors of a scene, resolved once: each one's body, its frame's pose in that body,
    its type and its columns in a row of readings (``mounts``, ``columns``); ``readings``
    names the values of the sensor kernel's rows.

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
        self.contact = [k for k, t in enumerate(self.types) if t == 'contact']
        self._fields = self._field_slices()
        self.columns = sum(FIELDS[kind][key] for kind in self.types for key in FIELDS[kind])
        placed = [(np.eye(3), (0.0, 0.0, 0.0)) if s.body not in frames else
                  (rotation_matrix(frames[s.body].orientation), frames[s.body].position)
                  for s in scene.sensors]
        self.mounts = Mounts(
            np.array([_KINDS[kind] for kind in self.types], dtype=np.int32),
            np.array(self.body, dtype=np.int32),
            np.array([rotation for rotation, _ in placed], dtype=np.float64).reshape(-1, 3, 3),
            np.array([offset for _, offset in placed], dtype=np.float64).reshape(-1, 3),
            np.array([columns[0][1].start for _, columns in self._fields], dtype=np.int32))
        for k in self.contact:
            self._warn_if_untouchable(scene, k)

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

    def readings(self, values: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
        """``{name: {value: array (envs, size)}}`` (FIELDS) of the rows ``values`` (envs,
        ``columns``): views of it."""
        return {name: {key: values[:, columns] for key, columns in fields}
                for name, fields in self._fields}
