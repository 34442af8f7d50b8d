"""The messages of a scene's sensors (README.md#sensors): ``sensor_msgs/Imu`` for an ``imu``,
``geometry_msgs/WrenchStamped`` for a ``contact`` sensor, one topic ``sensors/<name>`` each.
One filler for the node, the bag replay and its ``--out`` bag, so all three publish and
compare the same thing.

The stamp is the step's simulated time, ``frame_id`` the sensor's ``body`` as the scene gives
it (a URDF link, or a body). The values are ``Stepper.sensors``'s, in the sensor's frame:
orientation (x, y, z, w), angular velocity [rad/s] and linear acceleration (the specific force
a − g [m/s²]); force [N] and torque [N·m about the frame's origin]. The covariances of an Imu
are left 0 ("unknown"): the readings are exact values of the simulated state. Each message is
serialized once and its numbers written into its bytes every step (``PatchedMessage``, as the
markers are): the same bytes are published and recorded.
"""

import numpy as np

from affine_joint_sim.ros.patched import PatchedMessage
from affine_joint_sim.ros.topics import SENSOR_KEYS
from affine_joint_sim.sensors import FIELDS

__all__ = ['SensorMessages', 'message_values', 'sensor_values', 'difference']


def sensor_values(kind: str, reading: dict) -> np.ndarray:
    """A sensor's reading (``Stepper.sensors[name]``) as one flat vector: an imu's orientation
    (x, y, z, w), angular velocity and linear acceleration; a contact sensor's force and
    torque (FIELDS order)."""
    return np.concatenate([reading[key] for key in FIELDS[kind]], dtype=np.float64)


def message_values(kind: str, msg) -> np.ndarray:
    """The flat vector (``sensor_values``'s layout) a sensor message carries."""
    if kind == 'imu':
        o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        return np.array([o.x, o.y, o.z, o.w, w.x, w.y, w.z, a.x, a.y, a.z])
    f, t = msg.wrench.force, msg.wrench.torque
    return np.array([f.x, f.y, f.z, t.x, t.y, t.z])


def difference(kind: str, a: np.ndarray, b: np.ndarray) -> float:
    """The largest |a − b| between two flat vectors of a sensor, each entry in its unit; an
    imu's quaternions compare up to their sign (q and −q are one orientation)."""
    d = np.abs(a - b)
    if kind == 'imu':
        d[:4] = min(np.abs(a[:4] - b[:4]).max(), np.abs(a[:4] + b[:4]).max())
    return float(d.max(initial=0.0))


class SensorMessages:
    """One serialized message per sensor of ``scene``, filled from ``Stepper.sensors``.

    Args:
        scene: the Scene (its ``sensors``).
        topics: ``load_topics()``.

    Attributes:
        sensors: (name, type, topic key) of each sensor, in scene order.
    """

    def __init__(self, scene, topics):
        self.sensors = [(s.name, s.type, SENSOR_KEYS[s.type]) for s in scene.sensors]
        self._msgs = []         # (name, its values (FIELDS), its PatchedMessage) per sensor
        for sensor, (name, kind, key) in zip(scene.sensors, self.sensors):
            msg = topics[key].msg_class()
            msg.header.frame_id = sensor.body
            # each value is the message field of its name (an Imu's, a WrenchStamped's wrench's)
            holder = msg if kind == 'imu' else msg.wrench
            floats = [(getattr(holder, value), axis) for value, size in FIELDS[kind].items()
                      for axis in 'xyzw'[:size]]
            self._msgs.append((name, FIELDS[kind], PatchedMessage(
                msg, floats, [msg.header], parts=list(FIELDS[kind].values()))))

    def __bool__(self) -> bool:
        return bool(self.sensors)

    def fill(self, readings: dict, stamp_ns: int) -> list[tuple[str, bytes]]:
        """(sensor name, its serialized message) of every sensor for ``readings``
        (``Stepper.sensors``) at stamp ``stamp_ns`` [ns]."""
        return [(name, msg.update([readings[name][key] for key in fields], stamp_ns))
                for name, fields, msg in self._msgs]
