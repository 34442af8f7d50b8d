"""Offline replay of a recorded bag: re-simulate, compare, what-if, or re-publish on ROS.

A bag from the node holds the scene (``~/scene``), the run's events (``~/events``: start with
its parameters, resets, parameter changes), every command as received at the bag time of the
step it applied to, ``joint_states`` and the scene's sensors (``sensors/<name>``), which are
compared too. Replay applies the commands through the node's own ``CommandBuffer`` (same
latest-wins, non-finite rejection and command timeout) before the same steps, so a replay on
the same device and precision reproduces the run bit for bit.
With another scene (another dt, integrator, torque_model, ...) a command recorded at time t
applies from the first step starting at or after t, and the recorded states are compared with
the re-simulated trajectory interpolated linearly at their stamps: the offline what-if tool.
"""

import itertools
import math
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from rclpy.duration import Duration
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.rosbag2 import Reader

from affine_joint_sim.placement import PLACEMENT_EVENT, place
from affine_joint_sim.quiet_warp import quiet_warp
from affine_joint_sim.resources import scene_path as packaged_scene_path
from affine_joint_sim.ros.bag_metadata import UNLISTED_BAG, unlisted_bag
from affine_joint_sim.ros.joint_state import JointStateFiller
from affine_joint_sim.ros.lockstep import LockstepGate
from affine_joint_sim.ros.loop import SimLoop
from affine_joint_sim.ros.pacing import Pacer
from affine_joint_sim.ros.recorder import BagRecorder, BagTopic
from affine_joint_sim.ros.robots import RobotCommands, RobotFace, robot_faces
from affine_joint_sim.ros.sensor_messages import (SensorMessages, difference, message_values,
                                                  sensor_values)
from affine_joint_sim.ros.topics import (COMMAND_KEYS, SENSOR_KEYS, interfaces_built,
                                         load_topics, message_class)
from affine_joint_sim.ros.transforms import TransformTree
from affine_joint_sim.scene import Scene, SceneError, topic_token
from affine_joint_sim.spawning import DELETE_EVENT, SPAWN_EVENT, apply_edit

__all__ = ['ReplayError', 'Divergence', 'read_bag', 'replay', 'publish']

_EPS_NS = 1000          # [ns]: times closer than this are the same step
_SENSOR_TYPE = {key: kind for kind, key in SENSOR_KEYS.items()}     # topic key -> sensor type
_TOPICS = load_topics()


class ReplayError(Exception):
    """The bag cannot be replayed; the message says why (for the command line, exit 2)."""


@dataclass
class Divergence:
    """Largest differences between recorded and re-simulated joint states.

    Attributes:
        joint_names: joints, in scene order.
        max_angle: max |Δθ| per joint [rad] (wrapped joints compare modulo 2π).
        max_velocity: max |Δω| per joint [rad/s].
        states: number of recorded states compared.
        dropped: recorded commands the command buffer refused (as the node did), and
            recorded placements the scene refused (a what-if with another scene).
        sensors: per sensor compared, the largest |Δ| of its values, each in its unit
            (orientation quaternion, rad/s, m/s²; N, N·m).
        sensor_messages: number of recorded sensor messages compared.
        uncompared: sensors recorded in the bag that the re-simulated scene does not have (a
            what-if with another scene).
    """

    joint_names: list[str]
    max_angle: np.ndarray
    max_velocity: np.ndarray
    states: int = 0
    dropped: list[str] = field(default_factory=list)
    sensors: dict[str, float] = field(default_factory=dict)
    sensor_messages: int = 0
    uncompared: list[str] = field(default_factory=list)

    def worst(self) -> float:
        return float(max(self.max_angle.max(initial=0.0), self.max_velocity.max(initial=0.0),
                         *self.sensors.values()))

    def table(self) -> str:
        width = max([5] + [len(n) for n in self.joint_names])
        lines = [f'{"joint":<{width}}  {"max |Δθ| [rad]":>15}  {"max |Δω| [rad/s]":>17}']
        lines += [f'{n:<{width}}  {a:15.3e}  {w:17.3e}'
                  for n, a, w in zip(self.joint_names, self.max_angle, self.max_velocity)]
        if self.sensors:
            width = max([6] + [len(n) for n in self.sensors])
            lines.append(f'{"sensor":<{width}}  {"max |Δ|":>15}   ({self.sensor_messages} '
                         'messages; each value in its unit)')
            lines += [f'{n:<{width}}  {d:15.3e}' for n, d in self.sensors.items()]
        if self.uncompared:
            lines.append('sensors recorded but not in the scene, not compared: '
                         + ', '.join(self.uncompared))
        if self.dropped:
            lines.append(f'{len(self.dropped)} recorded commands or placements refused, '
                         f'first: {self.dropped[0]}')
        return '\n'.join(lines)


@dataclass
class _Message:
    kind: str           # a command key, 'joint_states', a sensor key, 'scene', 'events' or ''
    topic: str
    t_ns: int
    raw: bytes
    msgtype: str
    joint: str | None = None    # the joint of a per-joint topic, the sensor of a sensor topic

    def decode(self):
        """The message; ReplayError (a damaged bag) if its bytes do not decode."""
        try:
            return deserialize_message(self.raw, message_class(self.msgtype))
        except Exception as exc:       # rclpy raises RMWError and others for bad CDR
            raise ReplayError(f'damaged bag: the message on {self.topic} at bag time '
                              f'{self.t_ns * 1e-9:.6f} s does not decode as {self.msgtype} '
                              f'({type(exc).__name__})') from None


@dataclass
class RecordedBag:
    """What replay needs from a bag, in bag order."""

    path: Path
    messages: list[_Message] = field(default_factory=list)
    scene_yaml: str | None = None
    command_topics: dict[str, str] = field(default_factory=dict)     # topic name -> msgtype
    span_ns: tuple[int, int] = (0, 0)       # the bag's first and last message time [ns]


def _classifier():
    """Map a bag topic name and its message type to (kind, joint or sensor) using the
    patterns of topics.yaml (the sensors' topics share one pattern: their type tells them
    apart)."""
    topics = load_topics()
    patterns = []
    for key, topic in topics.items():
        body = re.escape(topic.template.lstrip('~/'))
        for placeholder in ('{joint}', '{sensor}'):
            body = body.replace(re.escape(placeholder), r'(?P<item>[A-Za-z_]\w*)')
        patterns.append((key, re.compile(rf'^(.*/)?{body}$'), topic.type))

    def classify(name: str, msgtype: str | None = None):
        for key, pattern, type_name in patterns:
            if key in _SENSOR_TYPE and msgtype is not None and msgtype != type_name:
                continue
            match = pattern.match(name)
            if match:
                return key, match.groupdict().get('item')
        return '', None

    return classify


def read_bag(path, kinds=None, start_ns: int | None = None,
             stop_ns: int | None = None) -> RecordedBag:
    """Read a bag (rosbag2 directory, or a single .mcap/.db3 file): every message, or only
    those of the topic ``kinds`` (keys of topics.yaml) between bag times ``start_ns`` and
    ``stop_ns`` [ns] (the scene is always read). The storage's indexes skip the rest.

    Raises:
        ReplayError: missing path, not a bag, or a damaged one.
    """
    path = Path(path)
    _check_bag_path(path)
    classify = _classifier()
    bag = RecordedBag(path)
    try:
        with Reader(path) as reader:
            bag.span_ns = (reader.start_time, reader.end_time)
            if kinds is not None:
                wanted = [c for c in reader.connections
                          if classify(c.topic, c.msgtype)[0] in kinds]
                scenes = [c for c in reader.connections
                          if classify(c.topic, c.msgtype)[0] == 'scene']
                messages = itertools.chain(reader.messages(scenes),
                                           reader.messages(wanted, start_ns, stop_ns)
                                           if wanted else ())
            else:
                messages = reader.messages()
            for connection, t_ns, raw in messages:
                kind, joint = classify(connection.topic, connection.msgtype)
                message = _Message(kind, connection.topic, t_ns, bytes(raw), connection.msgtype,
                                   joint)
                if kind == 'scene' and bag.scene_yaml is None:
                    bag.scene_yaml = message.decode().data
                if kind in COMMAND_KEYS:
                    bag.command_topics[connection.topic] = connection.msgtype
                bag.messages.append(message)
    except ReplayError:
        raise
    except Exception as exc:       # rosbags raises several types for foreign or damaged files
        raise ReplayError(f'{path}: not a readable rosbag2 bag ({type(exc).__name__}: '
                          f'{exc})') from None
    return bag


def _check_bag_path(path: Path) -> None:
    """ReplayError saying why ``path`` is no bag to read: missing, an empty directory, a
    directory with split files but no metadata.yaml, or one split of a bag of several (whose
    other splits hold the rest of the run)."""
    if not path.exists():
        raise ReplayError(f'{path}: no such file or directory')
    if path.is_dir() and not any(path.iterdir()):
        raise ReplayError(f'{path}: an empty directory: no bag in it')
    if unlisted_bag(path):
        raise ReplayError(f'{path}: {UNLISTED_BAG}')
    metadata = path.parent / 'metadata.yaml'
    if path.is_file() and metadata.is_file():
        try:
            info = yaml.safe_load(metadata.read_text())['rosbag2_bagfile_information']
            splits = info['relative_file_paths']
        except (OSError, yaml.YAMLError, KeyError, TypeError):
            return
        if len(splits) > 1 and path.name in splits:
            raise ReplayError(f'{path}: one of the {len(splits)} split files of the bag '
                              f'{path.parent}: replay the bag directory (a split alone lacks '
                              'the rest of the run)')


def _scene_of(bag: RecordedBag, scene_path) -> Scene:
    if scene_path is not None:
        try:
            return Scene.load(packaged_scene_path(scene_path))
        except FileNotFoundError as exc:
            raise ReplayError(f'--scene: {exc}') from None
    if bag.scene_yaml is None:
        raise ReplayError(f'{bag.path}: the bag holds no scene (~/scene); give one with --scene')
    return Scene.from_yaml_text(bag.scene_yaml, source=f'{bag.path} (~/scene)',
                                solver_defaults=SOLVER_KEYS_BEFORE)


# The recorder writes the scene with every default spelled out, so a solver key missing from a
# bag's scene was added after the bag was recorded: it replays with the behaviour of its time.
SOLVER_KEYS_BEFORE = {'warm_start': False}


class _Resimulation:
    """The stepper driven by recorded commands, sampled at recorded stamps.

    ``on_state(bag_ns, stamp_ns, sim)`` is called for the initial state and after every step.
    ``sensors``: sample the scene's sensors too (the bag has sensor messages to compare).
    """

    def __init__(self, scene: Scene, device: str, on_state=None, sensors: bool = False):
        from affine_joint_sim.stepper import Stepper

        try:
            self.sim = Stepper(scene, device=device)
        except (ValueError, RuntimeError) as exc:
            raise ReplayError(f'--device {device}: {exc}') from None
        # every robot's joints, scene names (a robot's joint_states name them as in its URDF)
        self.states = JointStateFiller(self.sim, message_class('sensor_msgs/msg/JointState'),
                                       every=True)
        self.wrapped = self.states.wrapped
        self.buffer = RobotCommands(self.sim)
        # per-joint topics carry the joint's topic token, each robot's buffer takes its name
        self.joint_of_token = [{topic_token(name): name for name in b.joint_names}
                               for b in self.buffer.buffers]
        self.dropped: list[str] = []
        # the node's own loop; its pacer and lockstep gate stay idle: replay runs flat out
        self.loop = SimLoop(self.sim, self.buffer, Pacer(), LockstepGate())
        self.on_state = on_state
        # sensor name -> its type, when sampled
        self.sensor_types = {s.name: s.type for s in scene.sensors} if sensors else {}
        self.reset(0)

    @property
    def epoch_ns(self) -> int:
        return self.loop.epoch_ns

    def reset(self, epoch_ns: int):
        """Initial state; bag time ``epoch_ns`` [ns] is its t = 0 (the bag's reset event, which
        the node's bag-time rule put there). Pending commands are dropped."""
        self.loop.reset()
        self.loop.epoch_ns = epoch_ns
        self.pending: list[_Message] = []
        self.placed = False     # a placement since: a reset before any step undoes it
        self.previous = self.current = self._sample()

    def _sample(self):
        sensors = {}
        if self.sensor_types:
            readings = self.sim.sensors
            sensors = {name: sensor_values(kind, readings[name])
                       for name, kind in self.sensor_types.items()}
        sample = (self.loop.sim_time_ns, self.states.select(self.sim.angles),
                  self.states.select(self.sim.velocities), sensors)
        if self.on_state is not None:
            self.on_state(self.loop.bag_ns, sample[0], self.sim)
        return sample

    def step(self):
        """Apply the commands due at the current time, then advance one dt."""
        now = self.loop.bag_ns
        due = [m for m in self.pending if m.t_ns <= now + _EPS_NS]
        self.pending = [m for m in self.pending if m.t_ns > now + _EPS_NS]
        for m in due:
            robot = self.robot_of(m)
            if robot is None:
                self.dropped.append(f'{m.topic}: no robot of the scene has this namespace')
                continue
            joint = None if m.joint is None else self.joint_of_token[robot].get(m.joint, m.joint)
            self.dropped += self.buffer.buffers[robot].take(m.kind, joint, m.decode())
        self.loop.step()
        self.previous, self.current = self.current, self._sample()

    def edit(self, bag_ns: int, event: dict):
        """Apply a recorded spawn or delete (``spawning.apply_edit``) after the step at or
        after its time; one the scene refuses (a what-if with another scene) is counted in
        ``dropped``."""
        self._reach(bag_ns - self.epoch_ns)
        faces = self.buffer.faces
        try:
            apply_edit(self.sim, event)
        except (SceneError, KeyError, ValueError) as exc:
            self.dropped.append(f'{event["event"]} of {event["entity"]!r} at '
                                f'{(bag_ns - self.epoch_ns) * 1e-9:.6f} s: {exc}')
            return
        # the node dropped a deleted robot's commands with its buffer (taken before the delete,
        # recorded at its time): they command nothing here either
        gone = [f.key for f in faces if f.key == event['entity']]
        self.pending = [m for m in self.pending if not gone or _robot_of(faces, m) is None
                        or faces[_robot_of(faces, m)].key not in gone]
        self.buffer.refresh(self.sim)
        self.joint_of_token = [{topic_token(name): name for name in b.joint_names}
                               for b in self.buffer.buffers]
        self.states = JointStateFiller(self.sim, message_class('sensor_msgs/msg/JointState'),
                                       every=True)
        self.wrapped = self.states.wrapped
        self.previous = self.current = self._sample()

    def robot_of(self, m) -> int | None:
        """The robot (index of ``buffer.faces``) of a recorded message's topic."""
        return _robot_of(self.buffer.faces, m)

    def place(self, bag_ns: int, event: dict):
        """Apply a recorded placement (SetEntityState) after the step at or after its time; one
        the scene refuses (a what-if with another scene) is counted in ``dropped``."""
        self._reach(bag_ns - self.epoch_ns)
        try:
            place(self.sim, event)
            self.placed = True
        except (KeyError, ValueError) as exc:
            self.dropped.append(f'placement of {event["entity"]!r} at '
                                f'{(bag_ns - self.epoch_ns) * 1e-9:.6f} s: {exc}')

    def _reach(self, stamp_ns: int) -> float | None:
        """Step until the current sample is at or after ``stamp_ns`` (since the last reset);
        the fraction of the way from the previous sample to the current one, None at it."""
        while self.current[0] < stamp_ns - _EPS_NS:
            self.step()
        t0, t1 = self.previous[0], self.current[0]
        if abs(t1 - stamp_ns) <= _EPS_NS or t1 == t0:
            return None
        return (stamp_ns - t0) / (t1 - t0)

    def at(self, stamp_ns: int):
        """Angles and velocities at ``stamp_ns`` (since the last reset), stepping as needed."""
        s = self._reach(stamp_ns)
        (_, a0, w0, _), (_, a1, w1, _) = self.previous, self.current
        if s is None:
            return a1, w1
        da = np.where(self.wrapped, _wrap(a1 - a0), a1 - a0)
        return a0 + s * da, w0 + s * (w1 - w0)

    def sensor_at(self, name: str, stamp_ns: int) -> np.ndarray:
        """Sensor ``name``'s values (``sensor_values``) at ``stamp_ns``, stepping as needed
        (between two steps: interpolated linearly, a what-if with another dt)."""
        s = self._reach(stamp_ns)
        now = self.current[3][name]
        return now if s is None else self.previous[3][name] + s * (now - self.previous[3][name])


def _robot_of(faces, m) -> int | None:
    """The robot (index of ``faces``, ``ros.robots.robot_faces``) of recorded message ``m``:
    the one whose namespace its topic ends in before the name topics.yaml gives its kind
    (``/left/`` of ``/sim/left/joints/elbow/external_torque``), the longest that does; the
    node's own ('') for a topic in no robot's namespace where the scene has one, else None."""
    name = _TOPICS[m.kind].name(m.joint).lstrip('~/')
    head = m.topic[:len(m.topic) - len(name)] if m.topic.endswith(name) else m.topic
    found = [(len(f.namespace), k) for k, f in enumerate(faces)
             if ('/' + head.lstrip('/')).endswith('/' + f.namespace)]
    return max(found)[1] if found else None


def _wrap(angle):
    return (angle + math.pi) % (2 * math.pi) - math.pi


def replay(bag: RecordedBag, scene_path=None, device: str = 'cpu', out=None,
           storage: str = 'mcap', on_state=None) -> Divergence:
    """Re-simulate ``bag`` (with its own scene, or ``scene_path``) and compare joint states
    and the sensors' messages it holds (those of sensors the scene has).

    ``out``: a bag directory to write the re-simulated run into (scene, commands, states,
    sensors).
    ``on_state(bag_ns, stamp_ns, sim)``: called for the initial state and after every step.
    """
    scene = _scene_of(bag, scene_path)
    writer = _OutBag(out, storage, bag, scene) if out is not None else None
    hooks = [h for h in (writer.state if writer else None, on_state) if h is not None]

    def each_state(*args):
        for hook in hooks:
            hook(*args)

    recorded = any(m.kind in _SENSOR_TYPE for m in bag.messages)
    run = _Resimulation(scene, device, each_state if hooks else None, sensors=recorded)
    names = list(run.states.names)
    divergence = Divergence(names, np.zeros(len(names)), np.zeros(len(names)))
    try:
        _replay_messages(bag, run, writer, divergence, scene)
    finally:
        if writer:
            writer.recorder.close()     # a readable bag even when the replay stops early
    return divergence


def _replay_messages(bag, run, writer, divergence, scene):
    """Feed the bag's messages to ``run`` in order; accumulate ``divergence``."""
    started = False
    for m in bag.messages:
        if m.kind in COMMAND_KEYS:
            run.pending.append(m)
            if writer:
                writer.recorder.write(m.topic, m.t_ns, m.raw)
        elif m.kind == 'events':
            if writer:
                writer.recorder.write(m.topic, m.t_ns, m.raw)
            event = yaml.safe_load(m.decode().data)
            started = started or event.get('event') == 'start'
            if event.get('event') == 'reset' and (run.sim.step_count or run.placed
                                                  or m.t_ns != run.epoch_ns):
                run.reset(m.t_ns)
            if event.get('event') == PLACEMENT_EVENT:
                run.place(m.t_ns, event)
            if event.get('event') in (SPAWN_EVENT, DELETE_EVENT):
                run.edit(m.t_ns, event)
            if 'command_timeout' in event:
                run.buffer.command_timeout = float(event['command_timeout'])
            if 'command_joints' in event:
                run.buffer.array_joints = list(event['command_joints'])
        elif m.kind == 'joint_states':
            _compare_states(m, run, divergence, bag, scene)
        elif m.kind in _SENSOR_TYPE:
            _compare_sensor(m, run, divergence)
    divergence.dropped = run.dropped
    if not started:
        raise ReplayError(f'{bag.path}: no start event on ~/events, so not a bag of the '
                          'affine_joint_sim node (its bag time must be sim time)')
    if divergence.states == 0:
        raise ReplayError(f'{bag.path}: the bag holds no joint_states to compare')


def _compare_states(m: _Message, run: _Resimulation, divergence: Divergence, bag,
                    scene) -> None:
    """Compare a recorded joint_states message (of the robot its topic names) with the
    re-simulated joints of its names; a joint spawned since the start joins ``divergence``."""
    msg = m.decode()
    names = run.states.names
    robot = run.robot_of(m)
    if robot is None:
        raise ReplayError(f'{bag.path}: {m.topic}: no robot of the scene {scene.name!r} has '
                          'this namespace')
    prefix = run.buffer.buffers[robot].prefix
    scene_names = [prefix + name for name in msg.name]
    if not set(scene_names) <= set(names) or len(set(scene_names)) < len(scene_names):
        raise ReplayError(f'{bag.path}: {m.topic} names {list(msg.name)}, but the scene '
                          f'{scene.name!r} has moving joints {names}')
    for name in scene_names:
        if name not in divergence.joint_names:
            divergence.joint_names.append(name)
            divergence.max_angle = np.append(divergence.max_angle, 0.0)
            divergence.max_velocity = np.append(divergence.max_velocity, 0.0)
    index = [names.index(name) for name in scene_names]
    into = [divergence.joint_names.index(name) for name in scene_names]
    angle, velocity = run.at(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
    d_angle = angle[index] - np.asarray(msg.position)
    d_angle = np.abs(np.where(run.wrapped[index], _wrap(d_angle), d_angle))
    d_velocity = np.abs(velocity[index] - np.asarray(msg.velocity))
    divergence.max_angle[into] = np.maximum(divergence.max_angle[into], d_angle)
    divergence.max_velocity[into] = np.maximum(divergence.max_velocity[into], d_velocity)
    divergence.states += 1


def _compare_sensor(m: _Message, run: _Resimulation, divergence: Divergence) -> None:
    """Compare a recorded sensor message with the re-simulated sensor of its name (one the
    scene does not have, or has of another type, is listed as not compared)."""
    kind = _SENSOR_TYPE[m.kind]
    if run.sensor_types.get(m.joint) != kind:
        if m.joint not in divergence.uncompared:
            divergence.uncompared.append(m.joint)
        return
    msg = m.decode()
    stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
    d = difference(kind, run.sensor_at(m.joint, stamp), message_values(kind, msg))
    divergence.sensors[m.joint] = max(divergence.sensors.get(m.joint, 0.0), d)
    divergence.sensor_messages += 1


class _OutBag:
    """The re-simulated run as a bag: its scene, the recorded commands and events, every new
    state and its sensors' messages, and where the recorded bag has /tf (and tf2_msgs is
    built here): /tf_static once and /tf at the first state at or after each recorded one."""

    def __init__(self, path, storage, bag: RecordedBag, scene: Scene):
        topics = load_topics()
        scene_topic, events_topic = (self._name(bag, key, topics) for key in ('scene', 'events'))
        # each robot's joint_states on its recorded topic (else its namespace's)
        self.faces = robot_faces(scene)
        recorded = {}
        for m in bag.messages:
            if m.kind == 'joint_states':
                recorded.setdefault(_robot_of(self.faces, m), m.topic)
        self.states_topics = [recorded.get(k, '/' + face.namespace + 'joint_states')
                              for k, face in enumerate(self.faces)]
        bag_topics = [BagTopic(name, msgtype, topics['joint_commands'].qos)
                      for name, msgtype in bag.command_topics.items()]
        bag_topics += [BagTopic(name, topics['joint_states'].type, topics['joint_states'].qos)
                       for name in self.states_topics]
        bag_topics += [BagTopic(name, topics[key].type, topics[key].qos) for key, name in (
            ('scene', scene_topic), ('events', events_topic))]
        # the scene's sensors, on their recorded topics (else beside joint_states)
        self.sensors = SensorMessages(scene, topics)
        recorded = {m.joint: m.topic for m in bag.messages if m.kind in _SENSOR_TYPE}
        tail = self.faces[0].namespace + 'joint_states'
        first = self.states_topics[0]
        prefix = first[:len(first) - len(tail)] if first.endswith(tail) else '/'
        self.sensor_topics = {name: recorded.get(name, prefix + topics[key].name(name))
                              for name, _, key in self.sensors.sensors}
        bag_topics += [BagTopic(self.sensor_topics[name], topics[key].type, topics[key].qos)
                       for name, _, key in self.sensors.sensors]
        self.tf_times = [m.t_ns for m in bag.messages if m.kind == 'tf']
        self.tf_due = 0         # the first recorded /tf not yet written again
        self.tf_frame = _root_frame(bag) if self.tf_times else None
        if self.tf_frame is not None:
            self.tf_topics = {key: self._name(bag, key, topics) for key in ('tf', 'tf_static')}
            bag_topics += [BagTopic(name, topics[key].type, topics[key].qos)
                           for key, name in self.tf_topics.items()]
        self.tree = None
        try:
            self.recorder = BagRecorder(path, storage, bag_topics)
        except (FileExistsError, OSError) as exc:
            raise ReplayError(f'--out: {exc}') from None
        self.recorder.write(scene_topic, 0, serialize_message(
            topics['scene'].msg_class(data=scene.to_yaml())))
        self._scene = None      # the scene the fillers and the tree were made for

    @staticmethod
    def _name(bag, key, topics):
        recorded = [m.topic for m in bag.messages if m.kind == key]
        return recorded[0] if recorded else '/' + topics[key].name().lstrip('~/')

    def state(self, bag_ns, stamp_ns, sim):
        """Write the stepper's current joint state (``stamp_ns`` since the last reset)."""
        if self._scene is not sim.scene:     # the start, or a spawn or delete since
            self._scene, self.tree = sim.scene, None
            robots = {face.key: face.robot for face in robot_faces(sim.scene)}
            self.states = [(topic, JointStateFiller(sim, message_class(
                'sensor_msgs/msg/JointState'), robots[face.key]))
                for topic, face in zip(self.states_topics, self.faces) if face.key in robots]
        for topic, filler in self.states:
            self.recorder.write(topic, bag_ns, serialize_message(filler.fill(sim, stamp_ns)))
        if self.sensors:
            for name, raw in self.sensors.fill(sim.sensors, stamp_ns):
                self.recorder.write(self.sensor_topics[name], bag_ns, raw)
        if self.tf_frame is not None:
            self._transforms(bag_ns, stamp_ns, sim)

    def _transforms(self, bag_ns, stamp_ns, sim):
        """/tf_static with the first state, /tf when a recorded one is due."""
        if self.tree is None:
            self.tree = TransformTree(sim, self.tf_frame)
            self.recorder.write(self.tf_topics['tf_static'], bag_ns, self.tree.static_message(0))
        # every recorded one before this state, and one at its time: after a reset before
        # any step two states share a bag time, and so do their /tf
        times, due = self.tf_times, self.tf_due
        while self.tf_due < len(times) and times[self.tf_due] < bag_ns - _EPS_NS:
            self.tf_due += 1
        if self.tf_due < len(times) and times[self.tf_due] <= bag_ns + _EPS_NS:
            self.tf_due += 1
        if self.tf_due > due:
            self.recorder.write(self.tf_topics['tf'], bag_ns,
                                self.tree.moving_message(stamp_ns))


def _root_frame(bag: RecordedBag) -> str | None:
    """The frame the recorded transforms hang from (in the first /tf and /tf_static: the
    parent that is no child), or None where tf2_msgs is not built here (a note says so)."""
    if not interfaces_built('tf2_msgs'):
        print('note: the bag has /tf but tf2_msgs is not built here (make venv builds it): '
              'the re-simulated bag has none', file=sys.stderr)
        return None
    firsts = {}
    for m in bag.messages:
        if m.kind in ('tf', 'tf_static'):
            firsts.setdefault(m.kind, m)
    recorded = [t for m in firsts.values() for t in m.decode().transforms]
    children = {t.child_frame_id for t in recorded}
    return next((t.header.frame_id for t in recorded if t.header.frame_id not in children),
                'world')


def publish(bag: RecordedBag, rate: float = 1.0, namespace: str = '',
            wait: float = 10.0) -> int:
    """Re-publish the bag's commands on ROS at recorded timing / ``rate``, like ros2 bag play.

    Waits up to ``wait`` [s] for a subscriber to any command topic first. Returns the number
    of messages published.
    """
    import rclpy

    commands = [m for m in bag.messages if m.kind in COMMAND_KEYS]
    if not commands:
        raise ReplayError(f'{bag.path}: the bag holds no commands to publish')
    topics = load_topics()
    rclpy.init()
    node = rclpy.create_node('affine_joint_sim_replay', namespace=namespace)
    faces = _recorded_robots(bag)
    try:
        # Relative names (as in topics.yaml, a robot's under its namespace), so --namespace
        # decides where they go.
        publishers = {m.topic: node.create_publisher(
            message_class(m.msgtype), faces[_robot_of(faces, m) or 0].topic(
                topics[m.kind].name(m.joint)), topics[m.kind].qos) for m in commands}
        deadline = time.monotonic() + wait
        while not any(p.get_subscription_count() for p in publishers.values()):
            if time.monotonic() > deadline:
                names = ', '.join(p.topic_name for p in publishers.values())
                raise ReplayError(f'nothing subscribes to {names} after {wait:g} s')
            time.sleep(0.01)
        start_wall, start_bag = time.monotonic(), commands[0].t_ns
        for m in commands:
            delay = start_wall + (m.t_ns - start_bag) * 1e-9 / rate - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            publishers[m.topic].publish(m.raw)
        for p in publishers.values():
            if not p.wait_for_all_acked(Duration(seconds=wait)):
                raise ReplayError(f'{p.topic_name}: not acknowledged within {wait:g} s')
        return len(commands)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def _recorded_robots(bag: RecordedBag) -> list[RobotFace]:
    """The robots of the bag's scene and of its spawn events as faces (their namespaces
    only), after the scene's own."""
    data = yaml.safe_load(bag.scene_yaml) if bag.scene_yaml else None
    robots = data.get('robots') if isinstance(data, dict) else None
    namespaces = [r['namespace'] for r in robots or []]
    for m in bag.messages:
        event = yaml.safe_load(m.decode().data) if m.kind == 'events' else None
        if isinstance(event, dict) and event.get('event') == SPAWN_EVENT and 'urdf' in event:
            namespaces.append(event.get('namespace') or event['entity'])
    return [RobotFace(None, '', None)] + [RobotFace(None, ns + '/', None) for ns in namespaces]


def main(args) -> int:
    """``affine-joint-sim replay``: exit 0 within --tol, 1 above, 2 on errors."""
    quiet_warp()
    try:
        bag = read_bag(args.bag)
        if Path(args.bag).is_dir():
            for leftover in sorted(Path(args.bag).glob('.split_*')):
                print(f'note: {leftover.name} is a split the recorder had not listed when it was '
                      'killed (being written, opened ahead or being closed): not part of the '
                      'bag (metadata.yaml does not list it); delete it when you no longer need '
                      'it', file=sys.stderr)
        if args.publish:
            count = publish(bag, args.rate, args.namespace)
            print(f'published {count} commands from {bag.path}')
            return 0
        divergence = replay(bag, args.scene, args.device, args.out, args.storage)
    except (ReplayError, SceneError, FileNotFoundError) as exc:
        print(f'affine-joint-sim replay: error: {exc}', file=sys.stderr)
        return 2
    what = f'against {args.scene}' if args.scene else 'with its own scene'
    print(f'{bag.path}: {divergence.states} recorded states re-simulated {what}')
    print(divergence.table())
    if args.out:
        print(f're-simulated run written to {Path(args.out).resolve()}')
    worst = divergence.worst()
    verdict = 'within' if worst <= args.tol else 'ABOVE'
    print(f'largest difference {worst:.3e}: {verdict} --tol {args.tol:g}')
    return 0 if worst <= args.tol else 1
