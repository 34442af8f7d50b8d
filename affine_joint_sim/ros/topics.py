"""Topic names, message types and QoS profiles from ``msg_configs/topics.yaml``.

The node, the CLI tools, the demo controller and the bag recorder all take their topics from
here, so they agree by construction.
"""

import importlib
from dataclasses import dataclass
from pathlib import Path

import yaml
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from affine_joint_sim.resources import config_dir
from affine_joint_sim.scene import topic_token

__all__ = ['Topic', 'TOPIC_KEYS', 'COMMAND_KEYS', 'ANSWER_KEYS', 'JOINT_COMMAND_KEYS',
           'SENSOR_KEYS', 'load_topics', 'message_class', 'interfaces_built']

TOPIC_KEYS = ('joint_torque', 'joint_enable', 'joint_force', 'joint_force_enable',
              'joint_commands', 'effort_commands', 'position_commands', 'joint_states', 'clock',
              'scene', 'robot_description', 'events', 'markers', 'body_poses', 'tf',
              'tf_static', 'sensor_imu', 'sensor_contact')
# Commands that answer a lockstep state (several joints at once).
ANSWER_KEYS = ('joint_commands', 'effort_commands', 'position_commands')
COMMAND_KEYS = ('joint_torque', 'joint_enable', 'joint_force', 'joint_force_enable',
                *ANSWER_KEYS)
# The per-joint command topics of each kind of command (JointKind.command): (value [N·m | N],
# on/off switch).
JOINT_COMMAND_KEYS = {'torque': ('joint_torque', 'joint_enable'),
                      'force': ('joint_force', 'joint_force_enable')}
# The topic of each type of sensor (scene.SENSOR_TYPES), one per sensor: sensors/{sensor}.
SENSOR_KEYS = {'imu': 'sensor_imu', 'contact': 'sensor_contact'}

_RELIABILITY = {'reliable': ReliabilityPolicy.RELIABLE,
                'best_effort': ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {'volatile': DurabilityPolicy.VOLATILE,
               'transient_local': DurabilityPolicy.TRANSIENT_LOCAL}


@dataclass(frozen=True)
class Topic:
    """One entry of topics.yaml.

    Attributes:
        key: the entry's key (``joint_torque``, ``joint_states``, ...).
        template: topic name, relative to the node namespace unless absolute; ``{joint}``
            stands for a joint name (as ``scene.topic_token`` makes it a valid token),
            ``{sensor}`` for a sensor's name (a token already).
        type: message type, ``package/msg/Name``.
        qos: the QoS profile publishers and subscribers of this topic use.
    """

    key: str
    template: str
    type: str
    qos: QoSProfile

    def name(self, joint: str | None = None) -> str:
        """The topic name, with ``{joint}`` (``{sensor}``) replaced by ``joint`` made a topic
        token for per-joint (per-sensor) topics."""
        if joint is None:
            return self.template
        token = topic_token(joint)
        return self.template.format(joint=token, sensor=token)

    @property
    def msg_class(self):
        return message_class(self.type)


def interfaces_built(package: str) -> bool:
    """Whether the interface ``package`` can be imported: tf2_msgs and simulation_interfaces
    have no wheel, and make venv builds them only where cmake and a compiler are."""
    try:
        importlib.import_module(f'{package}.msg')
    except ImportError:
        return False
    return True


def message_class(type_name: str):
    """The Python class of a message type written ``package/msg/Name``."""
    package, _, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)


def _qos(where: str, spec: dict) -> QoSProfile:
    try:
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(spec['depth']),
                          reliability=_RELIABILITY[spec['reliability']],
                          durability=_DURABILITY[spec['durability']])
    except KeyError as exc:
        raise ValueError(f'{where}: missing or invalid {exc}; reliability is one of '
                         f'{", ".join(_RELIABILITY)}, durability one of '
                         f'{", ".join(_DURABILITY)}, depth a positive integer') from None


def load_topics(path: Path | None = None) -> dict[str, Topic]:
    """Read topics.yaml (default: the packaged one) into ``{key: Topic}``."""
    path = Path(path) if path is not None else config_dir() / 'topics.yaml'
    data = yaml.safe_load(path.read_text())
    profiles = {name: _qos(f'{path}: qos.{name}', spec) for name, spec in data['qos'].items()}
    topics = {}
    for key in TOPIC_KEYS:
        entry = data['topics'].get(key)
        if entry is None:
            raise ValueError(f'{path}: topics.{key} is missing')
        if entry['qos'] not in profiles:
            raise ValueError(f'{path}: topics.{key}.qos {entry["qos"]!r} is not one of '
                             f'{", ".join(profiles)}')
        topics[key] = Topic(key, entry['name'], entry['type'], profiles[entry['qos']])
    return topics
