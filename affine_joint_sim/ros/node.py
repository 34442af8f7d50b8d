"""The ``affine_joint_sim`` node: the Stepper behind topics and services (README.md#the-ros-2-node).

Two threads: an executor thread runs the subscription, service and parameter callbacks; the
main thread steps. They share one lock, so a command whose callback ran before step n is
computed applies to step n, and a service never lands in the middle of a step. In lockstep
mode a ``LockstepGate`` decides when the next step may go: it counts the answers to the
published state, drops stale ones, has the waiting state published again for controllers that
join late, and has the node say what it waits for. Each step publishes ``joint_states`` (and
``/clock``, then each sensor's ``sensors/<name>``) stamped with the step counter's simulated
time. (Running the callbacks between steps in one thread would slow every step: rclpy builds
its wait set in Python.) The
node does no physics itself: its stepping is a ``SimLoop``, its bag a ``RunRecording``, and
``run_node`` is its process (signals, exit status, summary).
"""

import math
import threading
import time
import warnings

import yaml
from rclpy.duration import Duration
from rclpy.exceptions import InvalidParameterTypeException, InvalidTopicNameException
from rclpy.executors import ExternalShutdownException, ShutdownException
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSCompatibility, qos_check_compatible
from rclpy.serialization import deserialize_message, serialize_message
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from std_srvs.srv import SetBool, Trigger

from affine_joint_sim.resources import scene_path
from affine_joint_sim.ros.collector import CollectorPauses, settle
from affine_joint_sim.ros.joint_state import JointStateFiller
from affine_joint_sim.ros.lockstep import LockstepGate
from affine_joint_sim.ros.loop import SimLoop
from affine_joint_sim.ros.pacing import Pacer
from affine_joint_sim.ros.recorder import BagRecorder, BagTopic
from affine_joint_sim.ros.recording import RunRecording
from affine_joint_sim.ros.robot_topics import RobotTopics
from affine_joint_sim.ros.robots import RobotCommands
from affine_joint_sim.ros.parameters import PARAMETERS, ConfigError, check, command_joints
from affine_joint_sim.ros.sensor_messages import SensorMessages
from affine_joint_sim.ros.simulation_services import SimulationServices
from affine_joint_sim.ros.step_grant import StepGrant
from affine_joint_sim.ros.topics import (ANSWER_KEYS, SENSOR_KEYS,
                                         interfaces_built, load_topics)
from affine_joint_sim.ros.viz import VizPublisher
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.spawning import DELETE_EVENT, SPAWN_EVENT, apply_edit
from affine_joint_sim.stepper import SimulationWarning, Stepper
from affine_joint_sim.viz.description import robot_description

__all__ = ['SimNode']

NODE_NAME = 'affine_joint_sim'
_WARN_EVERY = 2.0       # wall seconds between two warnings about the same topic
_RATE_WINDOW = 2.0      # wall seconds over which the realtime factor is checked
_YIELD_EVERY = 0.0005   # wall seconds of stepping after which the callback thread gets the GIL


def _as_declared_type(parameter: Parameter) -> Parameter:
    """An integer for a float parameter as the float it means (`ros2 param set ... 2` keeps
    real_time_factor a double); any other parameter as it is."""
    spec = PARAMETERS.get(parameter.name)
    if spec is not None and isinstance(spec.default, float) \
            and parameter.type_ == Parameter.Type.INTEGER:
        return Parameter(parameter.name, Parameter.Type.DOUBLE, float(parameter.value))
    return parameter


def _base_note(scene: Scene) -> str:
    """For a URDF robot, how its root link is held: welded to the world (fixed_base, the
    default: an arm on its mount) or floating."""
    if scene.robot_description is None or not scene.bodies:
        return ''
    root = scene.bodies[0]
    if root.fixed:
        return (f'; base: URDF root link {root.name!r} welded to the world (fixed_base: true, '
                'the default; fixed_base: false makes the robot float)')
    return f'; base: floating (fixed_base: false): root link {root.name!r} is free'


def _sensor_note(publishers: dict, scene: Scene) -> str:
    """The sensors' topics, for the start line: ``sensors: /sensors/imu (imu on trunk)``."""
    if not scene.sensors:
        return ''
    return '; sensors: ' + ', '.join(f'{publishers[s.name].topic_name} ({s.type} on {s.body})'
                                     for s in scene.sensors)


class SimNode(Node):
    """The simulator node.

    Args:
        parameter_overrides: node parameters (``Parameter`` list) that beat a params file.
        **node_kwargs: passed to ``rclpy.node.Node`` (e.g. ``context=`` in tests).

    Raises:
        ConfigError: a parameter is invalid (the message names it and its valid range).
        SceneError: the scene file is invalid (the message gives the key path).
    """

    def __init__(self, parameter_overrides=None, **node_kwargs):
        super().__init__(NODE_NAME, parameter_overrides=parameter_overrides or [],
                         **node_kwargs)
        self.config = self._declare_parameters()
        try:
            ground = self.config['ground']
            self.scene = Scene.load(scene_path(self.config['scene']), **(
                {} if math.isnan(ground) else {'ground': {'height': ground}}))
        except FileNotFoundError as exc:
            raise ConfigError(f"parameter 'scene': {exc}") from None
        try:
            with warnings.catch_warnings(record=True) as loading:   # the scene's, at load
                warnings.simplefilter('always', SimulationWarning)
                self.sim = Stepper(self.scene, device=self.config['device'],
                                   on_problem=self.get_logger().warning)
        except SceneError:
            raise                       # the scene's own line (e.g. it starts touching)
        except (ValueError, RuntimeError) as exc:
            raise ConfigError(f"parameter 'device': {exc}") from None
        for warning in loading:
            self.get_logger().warning(str(warning.message))
        self.commands = RobotCommands(
            self.sim, self.config['command_timeout'],
            array_joints=command_joints(self.config['command_joints'], self.sim))
        self.pacer = Pacer(self.config['real_time_factor'])
        self.topics = load_topics()
        self.paused = False
        self.gate = LockstepGate(self.config['lockstep_publishers'],
                                 robots=self._answering())
        self._answer_subs = {}          # resolved answer topic name -> its subscription
        self._warned_publishers = None  # matched publisher count last warned about (lockstep)
        self.oversized = 0              # command messages dropped for max_command_bytes
        self.malformed = 0              # command messages dropped whole (array lengths)
        self.taken = 0                  # command messages taken (decoded and queued)
        self._wake = threading.Condition()     # guards everything below; notified by callbacks
        self._requests: list[dict] = []        # work for the stepping thread (services, params)
        self._stepping_thread = None
        self._stopping = False                 # the run is over: requests are refused
        self.grant = StepGrant()               # steps granted while paused (the standard)
        self.stop_requested = threading.Event()    # set by SIGINT/SIGTERM (see main)
        self._last_warning: dict[str, float] = {}
        self._bag_topics: list[BagTopic] = []      # every topic published or taken
        self.collector = CollectorPauses()         # garbage collections while stepping
        self._make_interfaces()
        self.loop = SimLoop(self.sim, self.commands, self.pacer, self.gate)
        self.recording = RunRecording(self._open_bag(), self.get_logger().error,
                                      self.get_logger().warning)
        try:
            scene_msg = self.topics['scene'].msg_class(data=self.scene.to_yaml())
            self._publish_and_record(self.scene_pub, scene_msg, 0)
            self._publish_and_record(self.description_pub, self.topics[
                'robot_description'].msg_class(data=robot_description(self.scene)), 0)
            for topics in self.robot_topics:
                topics.publish_description(0)
            self.viz.publish_static(0)
            self._event({'event': 'start', **{k: self.config[k] for k in
                                              ('mode', 'device', 'command_timeout')},
                         'command_joints': self.commands.array_joints})
            self.recording.flush()      # the scene's split goes to the writer thread to list
        except BaseException:       # e.g. SIGTERM now: the bag is still closed readable
            self.close_bag()
            raise
        self.add_pre_set_parameters_callback(
            lambda parameters: [_as_declared_type(p) for p in parameters])
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._started = time.monotonic()        # the run's start (summary), kept at resets
        self._last_step_wall = self._started
        self._run_steps = 0
        self.get_logger().info(
            f'scene {self.scene.name!r} ({len(self.sim.body_names)} bodies, joints '
            f'{", ".join(self.sim.joint_names)}), dt {self.scene.dt} s, device '
            f'{self.sim.device}, mode {self.config["mode"]}{_base_note(self.scene)}'
            f'{_sensor_note(self.sensor_pubs, self.scene)}')

    # ---- setup ------------------------------------------------------------------------------

    def _declare_parameters(self) -> dict:
        """Declare every parameter with what ``ros2 param describe`` shows: its help, and
        read-only unless it may change while the node runs (rclpy refuses a change to it).
        Dynamic typing: ``-p duration:=5`` (an integer) is a valid float; ``check`` says what is
        valid for every parameter. A float given as an integer is declared a float; a name this
        node does not know (a typo in a params file) is warned about, not refused: a shared
        params file (``/**:``) may hold other nodes' parameters."""
        overrides = self._parameter_overrides      # rclpy's: from -p and --params-file
        unknown = sorted(set(overrides) - set(PARAMETERS) - set(self._parameters))
        if unknown:
            self.get_logger().warning(
                f'unknown parameter {", ".join(map(repr, unknown))} (from -p or --params-file) '
                f'ignored; this node\'s parameters: {", ".join(PARAMETERS)}')
        for name, parameter in list(overrides.items()):
            overrides[name] = _as_declared_type(parameter)
        config = {}
        for name, spec in PARAMETERS.items():
            descriptor = ParameterDescriptor(description=spec.help, read_only=not spec.live,
                                             dynamic_typing=True)
            try:
                value = self.declare_parameter(name, spec.default, descriptor).value
            except InvalidParameterTypeException as exc:
                raise ConfigError(f'parameter {name!r}: expected a '
                                  f'{type(spec.default).__name__} ({exc})') from None
            config[name] = check(name, value)
        return config

    def _make_interfaces(self):
        self.clock_pub = self._publisher('clock')
        self._clock_msg = self.topics['clock'].msg_class()
        # per sensor of the scene: sensors/<name>, just before joint_states (none: no cost)
        self._sensor_msgs = SensorMessages(self.scene, self.topics)
        self.sensor_pubs = {name: self._sensor_publisher(name, kind)
                            for name, kind, _ in self._sensor_msgs.sensors}
        # Latched: the scene as run, every default spelled out, for late joiners and bags.
        self.scene_pub = self._publisher('scene')
        self.events_pub = self._publisher('events')
        # Latched: the scene as a URDF (its own, or generated), for URDF viewers.
        self.description_pub = self._publisher('robot_description')
        self.viz = VizPublisher(self._publisher, self.sim, self.config['viz_rate'],
                                self.config['frame_id'], self._publish_and_record,
                                lambda: self.recording.active)
        if self.viz.publishers and self.viz.tree is None:
            self.get_logger().warning('no /tf or /tf_static: tf2_msgs is not built in this '
                                      'environment (make venv builds it where cmake and a C++ '
                                      'compiler are)')
        # per robot (one for a scene without robots): joint_states, commands, its URDF
        self.robot_topics = [RobotTopics(self, face, buffer, face.key in self.gate.robots)
                             for face, buffer in zip(self.commands.faces, self.commands.buffers)]
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        if interfaces_built('simulation_interfaces'):
            self.simulation_services = SimulationServices(self)
        else:
            self.get_logger().warning('no simulation_interfaces services: the package is not '
                                      'built in this environment (make venv builds it where '
                                      'cmake and a C++ compiler are)')

    def _publisher(self, key: str, item: str | None = None, on_matched=None,
                   namespace: str = ''):
        """The publisher of topic ``key`` (topics.yaml; ``item``: the sensor of a per-sensor
        topic; ``namespace``: a robot's, ``RobotFace.namespace``), listed for the bag: every
        topic the node publishes is created here, so the recorder knows it before its first
        message. ``on_matched(status)``: called (in the callback thread) when a subscription
        matches or goes (``status.current_count``)."""
        topic = self.topics[key]
        events = None if on_matched is None else PublisherEventCallbacks(matched=on_matched)
        publisher = self.create_publisher(topic.msg_class, namespace + topic.name(item),
                                          topic.qos, event_callbacks=events)
        self._bag_topics.append(BagTopic(publisher.topic_name, topic.type, topic.qos))
        return publisher

    def _sensor_publisher(self, name: str, kind: str):
        """The publisher of sensor ``name`` (sensors/<name>); ConfigError if its name makes no
        valid topic name here (too long)."""
        key = SENSOR_KEYS[kind]
        try:
            return self._publisher(key, name)
        except (InvalidTopicNameException, _rclpy.RCLError) as exc:
            raise ConfigError(f'sensor {name!r}: its topic {self.topics[key].name(name)!r} is not '
                              f'a valid ROS topic name in namespace {self.get_namespace()!r} '
                              f'({str(exc).splitlines()[0]}); use a shorter sensor name') from None

    def _answering(self) -> tuple:
        """The robots (``RobotFace.key``) whose controllers answer in lockstep: those with
        joints to command (the first robot's where none has any)."""
        faces = self.commands.faces
        return tuple(f.key for f, b in zip(faces, self.commands.buffers) if b.joint_names) or \
            (faces[0].key,)

    def _subscribe(self, key, joint, robot=None):
        """Subscribe raw (CDR bytes, as the bag keeps them) and queue the decoded command in
        the buffer of robot ``robot`` (``RobotFace.key``; ``joint``: named as there); in
        lockstep, a message on an ANSWER_KEYS topic answers the state its stamp names for that
        robot (stale ones are dropped before they are recorded or applied). Returns the
        subscription."""
        topic = self.topics[key]
        namespace = next(f.namespace for f in self.commands.faces if f.key == robot)
        try:
            name = self.resolve_topic_name(namespace + topic.name(joint))
        except _rclpy.RCLError as exc:     # e.g. longer than ROS allows (247 characters)
            raise ConfigError(f'joint {joint!r}: its topic {topic.name(joint)!r} is not a valid '
                              f'ROS topic name in namespace {self.get_namespace()!r} ({exc}); '
                              'use a shorter joint name') from None
        msg_class = topic.msg_class
        answers = key in ANSWER_KEYS

        def receive(raw):
            if len(raw) > self.config['max_command_bytes']:
                with self._wake:
                    self.oversized += 1
                    self._reject(name, f'a message of {len(raw)} bytes is over max_command_bytes'
                                 f' ({self.config["max_command_bytes"]}): dropped undecoded '
                                 f'({self.oversized} so far)', kind='size')
                return
            msg = deserialize_message(raw, msg_class)
            with self._wake:
                commands = self.commands.buffer_of(robot)
                problem = commands.malformed(key, msg)
                if problem is not None:       # answers no state, commands nothing
                    self.malformed += 1
                    self._reject(name, f'{problem} ({self.malformed} so far)', kind='malformed')
                    return
                if answers and self.config['mode'] == 'lockstep':
                    header = getattr(msg, 'header', None)    # arrays carry no stamp
                    stamp = header.stamp.sec * 1_000_000_000 + header.stamp.nanosec \
                        if header is not None else 0
                    joints = getattr(msg, 'name', None)      # arrays command every joint
                    source = (name, None if joints is None else frozenset(joints))
                    verdict = self.gate.answer(stamp, source, robot)
                    if verdict == 'stale':
                        self._reject(name, f'a command stamped t = {stamp * 1e-9:.6f} s answers '
                                     f'no waiting state (the node waits on t = '
                                     f'{self.gate.stamp_ns * 1e-9:.6f} s): dropped '
                                     f'({self.gate.stale} so far)', kind='stale')
                        return
                    if verdict == 'surplus':
                        self._reject(name, f'answer {self.gate.answers} to the state at t = '
                                     f'{self.gate.stamp_ns * 1e-9:.6f} s, lockstep_publishers '
                                     f'is {self.gate.publishers}: it applies to that step '
                                     '(latest per joint wins) and answers no later state '
                                     f'({self.gate.surplus} so far)', kind='surplus')
                    if verdict == 'repeat':
                        self._reject(name, 'a second answer for the same joints to the state '
                                     f'at t = {self.gate.stamp_ns * 1e-9:.6f} s: it applies '
                                     'to that step (latest per joint wins) and counts once '
                                     f'({self.gate.repeats} so far)', kind='repeat')
                    if self.gate.released:
                        self._wake.notify()
                self.taken += 1
                if name in self._recorded:
                    self.recording.take(name, raw)
                for problem in commands.take(key, joint, msg):
                    self._reject(name, problem)

        subscription = self.create_subscription(msg_class, name, receive, topic.qos, raw=True)
        if answers:
            self._answer_subs[name] = subscription
        self._bag_topics.append(BagTopic(name, topic.type, topic.qos))
        return subscription

    def _open_bag(self):
        """The recorder (``record`` set), with every topic the node publishes or takes."""
        # what the bag records: the topics known when it opens, and a spawned robot's
        self._recorded = {t.name for t in self._bag_topics}
        if not self.config['record']:
            return None
        try:
            return BagRecorder(self.config['record'], self.config['storage'], self._bag_topics)
        except (FileExistsError, OSError) as exc:
            raise ConfigError(f"parameter 'record': {exc}") from None

    def _publish_and_record(self, publisher, msg, t_ns):
        """Record first: the bag keeps every computed step even if a shutdown stops the publish.
        ``msg`` is a message or its serialized bytes."""
        if self.recording.active and publisher.topic_name in self._recorded:
            raw = msg if isinstance(msg, bytes) else serialize_message(msg)
            self.recording.write(publisher.topic_name, t_ns, raw)
        publisher.publish(msg)

    def _event(self, event: dict):
        """Publish (and record) an event of the run, e.g. a reset, at the current bag time."""
        msg = self.topics['events'].msg_class(data=yaml.safe_dump(event, sort_keys=False))
        self._publish_and_record(self.events_pub, msg, self.loop.bag_ns)

    # ---- commands ---------------------------------------------------------------------------

    def _reject(self, topic, problem, kind='invalid'):
        """Warn about a dropped command, at most once per ``_WARN_EVERY`` s per topic and
        kind of problem."""
        now = time.monotonic()
        if now - self._last_warning.get((topic, kind), -_WARN_EVERY) >= _WARN_EVERY:
            self._last_warning[(topic, kind)] = now
            self.get_logger().warning(f'{topic}: {problem}')

    # ---- services ---------------------------------------------------------------------------

    def _in_stepping_thread(self, action):
        """Run ``action()`` in the stepping thread between two steps; return its result.

        The stepper and the bag writer stay in one thread (a CUDA context and an SQLite
        connection belong to the thread that made them). Returns None if the node stops first.
        """
        if self._stepping_thread in (None, threading.current_thread()):
            return action()
        request = {'action': action, 'done': threading.Event()}
        with self._wake:
            if self._stopping:
                return None
            self._requests.append(request)
            self._wake.notify()
        while not request['done'].wait(0.1):
            if not self.context.ok():
                return None
        return request.get('result')

    def _serve_requests(self, stopping: bool = False):
        """Run (or, when stopping, cancel for good) the queued requests; with the lock held."""
        self._stopping = stopping
        for request in self._requests:
            if not stopping:
                request['result'] = request['action']()
            request['done'].set()
        self._requests.clear()

    def _on_reset(self, request, response):
        def reset():
            self.reset()
            return 'reset to the initial state, t = 0'

        message = self._in_stepping_thread(reset)
        response.success, response.message = message is not None, message or 'node stopping'
        return response

    def set_paused(self, paused: bool) -> None:
        """Pause or resume stepping (``~/pause``, the standard's SetSimulationState)."""
        with self._wake:
            self.paused = paused
            if not self.paused:
                self.grant.end('the simulation was resumed before the steps were taken')
                self.pacer.anchor(self.sim.time)
                self.pacer.restart_window(self.sim.time)
            self._wake.notify()

    def _on_pause(self, request, response):
        self.set_paused(request.data)
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at t = {self.sim.time:g} s'
        return response

    def _on_step(self, request, response):
        def step():
            if not self.paused:
                return False, 'not paused: call ~/pause first'
            self.step()
            return True, f'step {self.sim.step_count}, t = {self.sim.time:.6f} s'

        response.success, response.message = self._in_stepping_thread(step) or \
            (False, 'node stopping')
        return response

    def _check_parameters(self, parameters):
        """Refuse an invalid value (rclpy has refused a read-only parameter already)."""
        if self._stopping:
            return SetParametersResult(successful=False, reason='the node is stopping')
        for p in parameters:
            if p.name not in PARAMETERS:
                continue
            try:
                check(p.name, p.value)
            except ConfigError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters):
        """Apply accepted changes between two steps (after they are set: the post-set
        callback), and record them as an event."""
        changed = {p.name: check(p.name, p.value) for p in parameters if p.name in PARAMETERS}

        def apply():
            self.config.update(changed)
            self._event({'event': 'parameters', **changed})
            self.commands.command_timeout = self.config['command_timeout']
            self.gate.publishers = self.config['lockstep_publishers']
            self.pacer.real_time_factor = self.config['real_time_factor']
            self.pacer.anchor(self.sim.time)
            return True

        if changed:
            self._in_stepping_thread(apply)

    # ---- stepping ---------------------------------------------------------------------------

    def reset(self):
        """Back to the scene's initial state at t = 0; publishes that state."""
        self.recording.record_taken(self.loop.bag_ns)   # taken before the reset: recorded
        self.grant.end('the simulation was reset before the steps were taken')
        self.loop.reset()
        self._event({'event': 'reset'})
        self.viz.reset(self.loop.bag_ns)
        self.publish_state()

    def edit_scene(self, event: dict) -> None:
        """Apply a spawn or delete event (``spawning.apply_edit``) between two steps and follow
        it (``_follow_scene``); the event is recorded, ``~/scene`` and ``/robot_description``
        republished, the views rebuilt and the waiting state published again (a new robot's
        controller answers it). Raises as ``apply_edit`` (a refused edit changes nothing), or
        ValueError if a spawned robot's topics cannot be made (the spawn is undone)."""
        self.recording.record_taken(self.loop.bag_ns)
        apply_edit(self.sim, event)
        try:
            self._follow_scene()
        except Exception as exc:        # e.g. a topic name ROS refuses: undone
            if event['event'] != SPAWN_EVENT:
                raise
            undo = {'event': DELETE_EVENT, 'entity': event['entity']}
            apply_edit(self.sim, undo)
            self._follow_scene()
            self._event(event)          # both rebuilt the Stepper: replay does so too
            self._event(undo)
            raise ValueError(f'entity {event["entity"]!r}: its topics cannot be made '
                             f'({str(exc).splitlines()[0]}); not spawned') from None
        t_ns = self.loop.bag_ns
        self._event(event)
        self._publish_and_record(self.scene_pub, self.topics['scene'].msg_class(
            data=self.scene.to_yaml()), t_ns)
        self._publish_and_record(self.description_pub, self.topics['robot_description']
                                 .msg_class(data=robot_description(self.scene)), t_ns)
        self.viz.rebuild(self.sim, self.config['frame_id'], t_ns)
        self.publish_state(again=True)

    def _follow_scene(self) -> None:
        """After an edit of the Stepper's scene: each new robot gets its topics (recorded from
        now on, its URDF published), a deleted one's go, and so do the answer subscriptions
        of a robot that no longer answers in lockstep (or gets them); the gate waits for the
        robots there are now."""
        self.scene = self.sim.scene
        added, removed = self.commands.refresh(self.sim)
        self.gate.robots = self._answering()
        kept = {}
        for topics in self.robot_topics:
            if topics.face.key in removed or topics.answers != (topics.face.key in
                                                                 self.gate.robots):
                topics.destroy()
            else:
                kept[topics.face.key] = topics
        self.robot_topics = list(kept.values())
        t_ns, known, made = self.loop.bag_ns, len(self._bag_topics), []
        try:
            for face, buffer in zip(self.commands.faces, self.commands.buffers):
                topics = kept.get(face.key)
                if topics is None:
                    topics = RobotTopics(self, face, buffer, face.key in self.gate.robots)
                    made.append(topics)
                else:       # its joints' places in the scene may have moved
                    topics.face = face
                    topics.states = JointStateFiller(self.sim, self.topics['joint_states']
                                                     .msg_class, face.robot)
        except Exception:
            for topics in made:
                topics.destroy()
            raise
        for topic in self._bag_topics[known:]:      # recorded from now on
            self._recorded.add(topic.name)
            self.recording.add_topic(topic)
        for topics in made:
            topics.publish_description(t_ns)
        self.robot_topics = [kept.get(face.key) or next(t for t in made if t.face.key == face.key)
                             for face in self.commands.faces]

    def step(self):
        """Record and apply the queued commands, advance one dt, publish the new state."""
        self.recording.record_taken(self.loop.bag_ns)
        for notice in self.loop.step():
            self.get_logger().warning(notice)
        self._last_step_wall = time.monotonic()
        self._run_steps += 1
        self.publish_state()

    def close_bag(self):
        """Finish the bag (if recording): the last split and metadata.yaml."""
        self.recording.record_taken(self.loop.bag_ns)
        self.recording.close()

    def publish_state(self, again: bool = False):
        """Publish the sensors, then joint_states and /clock, for the current step (a
        controller that answers joint_states has the same step's sensor readings already:
        lockstep stays deterministic); ``again``: the state the lockstep gate waits on, once
        more and not recorded (it is in the bag already; its sensors are not published
        again)."""
        if not again:
            self.gate.expect(self.loop.sim_time_ns, self._matched_counts()
                             if self.config['mode'] == 'lockstep' else None)
        messages = [(t.state_pub, t.states.fill(self.sim, self.loop.sim_time_ns))
                    for t in self.robot_topics]
        if again:
            for publisher, msg in messages:
                publisher.publish(msg)
            return
        t_ns = self.loop.bag_ns
        if self._sensor_msgs:
            for name, raw in self._sensor_msgs.fill(self.sim.sensors, self.loop.sim_time_ns):
                self._publish_and_record(self.sensor_pubs[name], raw, t_ns)
        for publisher, msg in messages:
            self._publish_and_record(publisher, msg, t_ns)
        if self.config['publish_clock']:
            clock = self._clock_msg.clock
            clock.sec, clock.nanosec = divmod(self.loop.sim_time_ns, 1_000_000_000)
            self._publish_and_record(self.clock_pub, self._clock_msg, t_ns)
        self.viz.publish(self.loop.sim_time_ns, t_ns)
        self.recording.flush_if_due()

    def _wait_before_step(self) -> float:
        """Wall seconds until the next step is due (inf while paused without granted steps or
        awaiting lockstep; granted steps are not paced)."""
        held = self.paused and not self.grant.active
        mode = self.config['mode']
        wait = self.loop.wait_before_step('fast' if mode == 'realtime' and self.paused else mode,
                                          held)
        if wait == float('inf') and not held:
            self._keep_lockstep_alive()
        return wait

    def grant_steps(self, count: int):
        """Let the loop take ``count`` steps while paused (``ros.step_grant``): the future
        of their end (None; else why the grant ended first), or None while another grant
        runs or the node stops."""
        with self._wake:
            if self._stopping:
                return None
            done = self.grant.open(count, self.executor)
            self._wake.notify()
        return done

    def end_grant(self, future, reason: str) -> None:
        """End the grant of ``future`` (``grant_steps``) if it still runs."""
        with self._wake:
            self.grant.end(reason, future)

    def _matched_counts(self) -> tuple[int, int]:
        """(subscriptions matched on joint_states, publishers matched on the answer topics):
        DDS's counts now (~3 µs)."""
        return (sum(t.state_pub.get_subscription_count() for t in self.robot_topics),
                sum(sub.get_publisher_count() for sub in self._answer_subs.values()))

    def _keep_lockstep_alive(self):
        """While lockstep waits: publish the waiting state again for a controller that does
        not have it (``LockstepGate.republish_due``: joined late with volatile QoS, restarted,
        or its answer lost) and say, now and then, who it waits on."""
        if self.gate.republish_due(self._matched_counts()):
            self.publish_state(again=True)
        waited = self.gate.report_due()
        if waited is None:
            return
        publishers = self._answer_publishers()
        matched, names, mismatched = publishers
        why = (f'{matched} publisher(s) matched (nodes: {names}), ' if matched else
               'no publisher is matched, ') + (
            f"{self.gate.answers} of {self.gate.publishers * len(self.gate.robots)} answers so "
            "far")
        self.get_logger().warning(
            f'lockstep: waiting {waited:.1f} s for an answer on {", ".join(self._answer_subs)} '
            f'to the state at t = {self.gate.stamp_ns * 1e-9:.6f} s: {why}{mismatched}')
        self._check_publishers(publishers)

    def _answer_publishers(self) -> tuple[int, str, str]:
        """(publishers matched on the answer topics, the nodes that publish there, and a note
        on publishers that DDS will not match: their QoS, and what the node's is)."""
        matched = sum(sub.get_publisher_count() for sub in self._answer_subs.values())
        qos = self.topics['joint_commands'].qos
        nodes, incompatible = set(), []
        for name in self._answer_subs:
            for info in self.get_publishers_info_by_topic(name):
                nodes.add(info.node_name)
                compatibility, _ = qos_check_compatible(info.qos_profile, qos)
                if compatibility == QoSCompatibility.ERROR:
                    incompatible.append(f'{info.node_name} on {name} '
                                        f'({info.qos_profile.reliability.name.lower()})')
        note = '' if not incompatible else (
            f'; QoS-incompatible publishers, never matched: {", ".join(incompatible)}: '
            f'commands must be published {qos.reliability.name.lower()} (the default QoS)')
        return matched, ', '.join(sorted(nodes)) or 'none', note

    def _finished(self) -> bool:
        return self.loop.finished(self.config['duration'])

    def _check_publishers(self, publishers=None):
        """Lockstep: warn (once per count) when the matched controllers are more than the gate
        waits for (which of them drives a step then depends on timing) or, once some are
        matched, fewer (each step then waits for answers that do not come: it goes on only
        when the node publishes the state again, ``republish_every`` without answers).
        ``publishers``: ``_answer_publishers()`` if the caller has it already."""
        count, names, mismatched = publishers or self._answer_publishers()
        gate = self.gate
        robots = len(gate.robots)
        expected = gate.publishers * robots
        if count == expected or count == self._warned_publishers or (count == 0 and expected):
            return
        self._warned_publishers = count
        topics = ', '.join(self._answer_subs)
        setting = f'lockstep_publishers is {gate.publishers}' + (
            f' per robot ({robots} robots)' if robots > 1 else '')
        if count > expected:
            self.get_logger().warning(
                f'lockstep: {count} publishers on {topics} (nodes: {names}) but '
                f'{setting}: a step goes on the first {expected} '
                'answer(s); set lockstep_publishers to the number of controllers for a '
                'deterministic loop')
        else:
            self.get_logger().warning(
                f'lockstep: {setting} but {count} publisher(s) are '
                f'matched on {topics} (nodes: {names}){mismatched}: each step waits for answers '
                f'that may not come and crawls at the {self.gate.republish_every:g} s republish; '
                'set lockstep_publishers to the number of controllers')

    def _check_rate(self):
        now = time.monotonic()
        if now - self._window_start < _RATE_WINDOW:
            return
        self._window_start = now
        if self.config['mode'] == 'lockstep':
            self._check_publishers()
        if self.config['mode'] == 'realtime' and not self.paused:
            achieved, wanted = self.pacer.achieved(self.sim.time), self.config['real_time_factor']
            if achieved < 0.95 * wanted:
                self.get_logger().warning(
                    f'cannot keep up with real_time_factor {wanted:g}: achieved {achieved:.3g}')
        self.pacer.restart_window(self.sim.time)

    def run(self, executor):
        """Publish the initial state, then step until ``duration`` or shutdown.

        The executor spins in a second thread meanwhile; it is shut down on return.
        """
        failure = []

        def spin():
            try:
                executor.spin()
            except (ExternalShutdownException, ShutdownException):
                pass
            except BaseException as exc:        # re-raised in this thread below
                failure.append(exc)
                with self._wake:
                    self._wake.notify()

        spinner = threading.Thread(target=spin, name='ros_callbacks', daemon=True)
        self._stepping_thread = threading.current_thread()
        # before the first state (it takes ~0.1 s): a full collection walks the set-up's
        # objects no more
        settle()
        with self._wake:
            self.reset()
        self.collector.install()
        self._window_start = time.monotonic()
        spinner.start()
        yielded = time.monotonic()
        try:
            while not self.stop_requested.is_set() and not failure and not self._finished():
                with self._wake:
                    self._serve_requests()
                    wait = self._wait_before_step()
                    if wait > 0.0:
                        # a long pause or wait keeps what is computed
                        self.recording.flush_if_due()
                        self._wake.wait(min(wait, 0.1))
                        continue
                    self.step()
                    if self.paused:
                        self.grant.took_step()
                self._check_rate()
                now = time.monotonic()
                if now - yielded > _YIELD_EVERY:
                    # let the callback thread take the GIL: commands keep up with fast stepping
                    time.sleep(0)
                    yielded = now
        finally:
            self.collector.remove()
            with self._wake:
                self._serve_requests(stopping=True)
                waiting = self.grant.active
                self.grant.end('node stopping')
            if waiting:     # the service awaiting it answers before the executor goes
                self.grant.answered.wait(timeout=1.0)
            executor.shutdown(timeout_sec=1.0)
            spinner.join(timeout=1.0)
        if failure:
            raise failure[0]
        if not self.stop_requested.is_set():
            # A run that ends by itself delivers its last state before the node goes.
            for topics in self.robot_topics:
                topics.state_pub.wait_for_all_acked(Duration(seconds=1.0))

    def summary(self) -> dict:
        """Figures of the whole run, resets included: steps, simulated and wall time, steps/s,
        real-time factor, commands, the steps that did not converge or were rejected, and with
        contact the smallest distance seen and the most contacts at once, and the garbage
        collections while stepping (count, full ones, longest [s], objects frozen)."""
        wall = self._last_step_wall - self._started
        steps, sim_time = self._run_steps, self._run_steps * self.sim.scene.dt
        return {'steps': steps, 'sim_time': sim_time, 'wall_time': wall,
                'steps_per_second': steps / wall if wall > 0 else 0.0,
                'real_time_factor': sim_time / wall if wall > 0 else 0.0,
                'problems': self.sim.problem_totals,
                'fell_behind': self.pacer.fell_behind, 'mode': self.config['mode'],
                'angles': dict(zip(self.sim.joint_names, self.sim.angles.tolist())),
                'taken': self.taken,
                'dropped': {'stale answers': self.gate.stale, 'oversized': self.oversized,
                            'malformed': self.malformed},
                'surplus_answers': self.gate.surplus,
                'repeated_answers': self.gate.repeats,
                'bag': self.config['record'] or None,
                'rotation_strain': float(self.sim.stats['rotation_strain']),
                'contact': self.sim.contact_record,
                'recording_stopped': self.recording.stopped,
                'garbage_collection': self.collector.summary()}
