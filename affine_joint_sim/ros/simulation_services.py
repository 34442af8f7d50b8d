"""The ROS simulation standard (``simulation_interfaces``, README.md#the-simulation-standard)
on the node, where make venv built the package: services under the node's name
(``~/get_simulator_features``, ...), as Gazebo serves them under ``/gzserver``.

Served: GetSimulatorFeatures, GetSimulationState and SetSimulationState (playing, paused;
stopped = paused at the initial state; quitting ends the run as Ctrl-C does), ResetSimulation
(time and state together), StepSimulation and the SimulateSteps action (while paused, taken by
the node's loop as in play, ``ros.step_grant``: in lockstep each waits for the controllers;
each step published and recorded like any other; the action gives feedback after each step
and can be canceled), GetEntities (every body; ``filters.filter`` a regular expression on names),
GetEntityState (a body's pose and twist in ``frame_id``), SetEntityState (a free body's,
``placement``: recorded as an event that replay applies again), SpawnEntity (a URDF robot from
a file or a string, or a body of the scene schema as YAML, ``spawning``) and DeleteEntity
(a robot or a body in no joint), each recorded as an event that replay applies again. Not
served, and not listed in the features: worlds, named poses, bounds, tags, categories and
spawnables. Every answer fills the standard's ``Result`` (code and message).
"""

import re
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import yaml
from rclpy.callback_groups import ReentrantCallbackGroup

from affine_joint_sim.placement import place, placement_event
from affine_joint_sim.poses import rigid_transforms
from affine_joint_sim.rotations import quaternion_from_matrix
from affine_joint_sim.rotations import quaternion_matrix
from affine_joint_sim.scene import SceneError
from affine_joint_sim.spawning import DELETE_EVENT, entity_names, spawn_event

__all__ = ['SimulationServices']

_BUSY = 'another StepSimulation or SimulateSteps is running, or the node stops'


class SimulationServices:
    """The standard's services on ``node`` (an affine_joint_sim node)."""

    def __init__(self, node):
        from simulation_interfaces import srv
        from simulation_interfaces.msg import SimulationState, SimulatorFeatures

        self.node = node
        self.states = SimulationState
        self.stopped = False        # STATE_STOPPED: paused at the initial state
        self._granted = None        # the step the SimulateSteps action awaits
        f = SimulatorFeatures
        self.features = [f.SIMULATION_RESET, f.SIMULATION_RESET_TIME, f.SIMULATION_RESET_STATE,
                         f.SIMULATION_STATE_GETTING, f.SIMULATION_STATE_SETTING,
                         f.SIMULATION_STATE_PAUSE, f.STEP_SIMULATION_SINGLE,
                         f.STEP_SIMULATION_MULTIPLE, f.STEP_SIMULATION_ACTION,
                         f.ENTITY_STATE_GETTING, f.ENTITY_STATE_SETTING, f.SPAWNING,
                         f.DELETING, f.SPAWNING_RESOURCE_STRING]
        # their own group: while a step request awaits its steps, the node's other callbacks
        # (the commands a lockstep step waits for) and these services go on in the one thread
        group = ReentrantCallbackGroup()
        for name, kind, handler in (
                ('get_simulator_features', srv.GetSimulatorFeatures, self._features),
                ('get_simulation_state', srv.GetSimulationState, self._get_state),
                ('set_simulation_state', srv.SetSimulationState, self._set_state),
                ('reset_simulation', srv.ResetSimulation, self._reset),
                ('step_simulation', srv.StepSimulation, self._step),
                ('get_entities', srv.GetEntities, self._entities),
                ('get_entity_state', srv.GetEntityState, self._entity_state),
                ('set_entity_state', srv.SetEntityState, self._set_entity_state),
                ('spawn_entity', srv.SpawnEntity, self._spawn),
                ('delete_entity', srv.DeleteEntity, self._delete)):
            node.create_service(kind, f'~/{name}', handler, callback_group=group)
        from rclpy.action import ActionServer
        from simulation_interfaces.action import SimulateSteps
        self._action = ActionServer(node, SimulateSteps, '~/simulate_steps', self._simulate,
                                    cancel_callback=self._cancel, callback_group=group)

    @staticmethod
    def _result(response, code: int, message: str = ''):
        response.result.result, response.result.error_message = code, message
        return response

    def _features(self, request, response):
        response.features.features = self.features
        response.features.spawn_formats = ['urdf', 'yaml']
        response.features.custom_info = ('affine_joint_sim: entities are the scene\'s bodies '
                                         '(robots too for spawning and deleting); a reset '
                                         'restores time and state together')
        return response

    def _state_code(self) -> int:
        states = self.states
        if self.stopped and self.node.paused:
            return states.STATE_STOPPED
        return states.STATE_PAUSED if self.node.paused else states.STATE_PLAYING

    def _between_steps(self, action) -> bool:
        """Run ``action()`` in the node's stepping thread between two steps; False if the node
        stops first."""
        return self.node._in_stepping_thread(lambda: action() or True) is not None

    def _get_state(self, request, response):
        response.state.state = self._state_code()
        return self._result(response, response.result.RESULT_OK)

    def _set_state(self, request, response):
        states, target = self.states, request.state.state
        if target == self._state_code():
            return self._result(response, response.ALREADY_IN_TARGET_STATE, 'already there')
        if target == states.STATE_QUITTING:
            self.node.stop_requested.set()
            return self._result(response, response.result.RESULT_OK, 'the run ends')
        if target not in (states.STATE_PLAYING, states.STATE_PAUSED, states.STATE_STOPPED):
            return self._result(response, response.result.RESULT_FEATURE_UNSUPPORTED,
                                f'state {target}: worlds are not loaded or unloaded here')
        self.node.set_paused(target != states.STATE_PLAYING)
        if target == states.STATE_STOPPED and not self._between_steps(self.node.reset):
            return self._result(response, response.result.RESULT_OPERATION_FAILED,
                                'node stopping')
        self.stopped = target == states.STATE_STOPPED
        return self._result(response, response.result.RESULT_OK)

    def _reset(self, request, response):
        both = request.SCOPE_TIME | request.SCOPE_STATE
        if request.scope not in (request.SCOPE_DEFAULT, request.SCOPE_ALL) \
                and request.scope & both != both:
            return self._result(response, response.result.RESULT_FEATURE_UNSUPPORTED,
                                'time and state reset together only (SCOPE_TIME | SCOPE_STATE, '
                                'SCOPE_ALL or SCOPE_DEFAULT)')
        if not self._between_steps(self.node.reset):
            return self._result(response, response.result.RESULT_OPERATION_FAILED,
                                'node stopping')
        return self._result(response, response.result.RESULT_OK)

    async def _step(self, request, response):
        """``steps`` steps while paused, taken by the node's loop (``ros.step_grant``: in
        lockstep each waits for the controllers); answered after the last."""
        results = response.result
        if not self.node.paused:
            return self._result(response, results.RESULT_OPERATION_FAILED,
                                'not paused: set STATE_PAUSED first')
        done = self.node.grant_steps(request.steps)
        if done is None:
            return self._result(response, results.RESULT_OPERATION_FAILED, _BUSY)
        self.stopped = False
        ended = await self._taken(done)
        if ended is not None:
            return self._result(response, results.RESULT_OPERATION_FAILED, ended)
        return self._result(response, results.RESULT_OK)

    async def _taken(self, granted):
        """Await granted steps: None once taken, else why the grant ended first; says so to
        the node, which waits for this answer before it stops."""
        ended = await granted
        self.node.grant.answered.set()
        return ended

    def _cancel(self, goal):
        """Accept a cancel request; a step the action waits for (lockstep awaiting answers)
        is not waited for any longer."""
        from rclpy.action import CancelResponse

        if self._granted is not None:
            self.node.end_grant(self._granted, 'canceled')
        return CancelResponse.ACCEPT

    async def _simulate(self, goal):
        """The SimulateSteps action: ``steps`` steps while paused, granted one at a time
        (as ``_step``), feedback after each; cancellable between two."""
        from simulation_interfaces.action import SimulateSteps

        result, total = SimulateSteps.Result(), goal.request.steps
        if not self.node.paused:
            goal.abort()
            return self._result(result, result.result.RESULT_OPERATION_FAILED,
                                'not paused: set STATE_PAUSED first')
        self.stopped = False
        feedback, completed = SimulateSteps.Feedback(), 0
        while True:
            if goal.is_cancel_requested:
                goal.canceled()
                return self._result(result, result.result.RESULT_OK,
                                    f'canceled after {completed} steps')
            if completed == total:
                goal.succeed()
                return self._result(result, result.result.RESULT_OK)
            self._granted = granted = self.node.grant_steps(1)
            ended = _BUSY if granted is None else await self._taken(granted)
            self._granted = None
            if ended is None:
                completed += 1
                feedback.completed_steps, feedback.remaining_steps = completed, total - completed
                goal.publish_feedback(feedback)
            elif not goal.is_cancel_requested:
                goal.abort()
                return self._result(result, result.result.RESULT_OPERATION_FAILED, ended)

    def _entities(self, request, response):
        filters = request.filters
        if filters.categories or filters.tags.tags or filters.bounds.points:
            return self._result(response, response.result.RESULT_FEATURE_UNSUPPORTED,
                                'only filters.filter (a regular expression on names)')
        try:
            pattern = re.compile(filters.filter)
        except re.error as exc:
            return self._result(response, response.result.RESULT_OPERATION_FAILED,
                                f'filters.filter {filters.filter!r}: {exc}')
        response.entities = [name for name in self.node.sim.body_names if pattern.search(name)]
        return self._result(response, response.result.RESULT_OK)

    def _entity_state(self, request, response):
        sim = self.node.sim
        if request.entity not in sim.body_names:
            return self._result(response, response.result.RESULT_NOT_FOUND,
                                f'no body {request.entity!r} (GetEntities lists them)')

        def read():
            b = sim.body_names.index(request.entity)
            q, qdot = sim.body_q, sim.body_qdot
            q, qdot = (q[0], qdot[0]) if q.ndim == 3 else (q, qdot)
            transforms = sim.link_transforms
            transforms = transforms[0] if transforms.ndim == 4 else transforms
            names = sim.link_names
            pose = transforms[names.index(request.entity)] if request.entity in names \
                else rigid_transforms(q[b])
            a, a_dot = q[b, 3:].reshape(3, 3), qdot[b, 3:].reshape(3, 3)
            spin = a_dot @ np.linalg.inv(a)            # ω× = Ȧ A⁻¹ (its skew part)
            omega = 0.5 * np.array([spin[2, 1] - spin[1, 2], spin[0, 2] - spin[2, 0],
                                    spin[1, 0] - spin[0, 1]])
            # the link frame's velocity: the centre of mass's plus ω × its offset
            velocity = qdot[b, :3] + np.cross(omega, pose[:3, 3] - q[b, :3])
            return pose, velocity, omega, self.node.loop.sim_time_ns

        read_out = self.node._in_stepping_thread(read)
        if read_out is None:
            return self._result(response, response.result.RESULT_OPERATION_FAILED,
                                'node stopping')
        pose, velocity, omega, stamp = read_out
        state = response.state
        state.header.frame_id = self.node.config['frame_id']
        state.header.stamp.sec, state.header.stamp.nanosec = divmod(int(stamp), 10 ** 9)
        p, o = state.pose.position, state.pose.orientation
        p.x, p.y, p.z = map(float, pose[:3, 3])
        o.x, o.y, o.z, o.w = map(float, quaternion_from_matrix(pose[:3, :3]))
        t = state.twist
        t.linear.x, t.linear.y, t.linear.z = map(float, velocity)
        t.angular.x, t.angular.y, t.angular.z = map(float, omega)
        return self._result(response, response.result.RESULT_OK)

    def _set_entity_state(self, request, response):
        """Place a free body (``placement``): pose and twist in ``frame_id`` (or ''), the
        acceleration ignored; recorded as an event; published with the next step."""
        results, state = response.result, request.state
        if request.entity not in self.node.sim.body_names:
            return self._result(response, results.RESULT_NOT_FOUND,
                                f'no body {request.entity!r} (GetEntities lists them)')
        world = self.node.config['frame_id']
        if state.header.frame_id not in ('', world):
            return self._result(response, results.RESULT_FEATURE_UNSUPPORTED,
                                f'header.frame_id {state.header.frame_id!r}: states are set in '
                                f'{world!r} (or \'\', the same) only')
        p, o, t = state.pose.position, state.pose.orientation, state.twist
        try:
            event = placement_event(request.entity, (p.x, p.y, p.z), (o.x, o.y, o.z, o.w),
                                    (t.linear.x, t.linear.y, t.linear.z),
                                    (t.angular.x, t.angular.y, t.angular.z))
        except ValueError as exc:
            return self._result(response, response.INVALID_POSE, f'state: {exc}')

        def apply():
            try:
                place(self.node.sim, event)
            except SceneError as exc:           # it would be inside something
                return response.INVALID_POSE, str(exc)
            except ValueError as exc:           # a fixed or jointed body
                return results.RESULT_OPERATION_FAILED, str(exc)
            self.node._event(event)
            self.stopped = False
            return results.RESULT_OK, ''

        outcome = self.node._in_stepping_thread(apply)
        if outcome is None:
            return self._result(response, results.RESULT_OPERATION_FAILED, 'node stopping')
        return self._result(response, *outcome)

    def _spawn(self, request, response):
        """SpawnEntity: a URDF robot (``uri`` a file, or ``resource_string`` starting with
        ``<``) under ``entity_namespace``, or a body (a ``.yaml`` file or a YAML mapping: a
        scene ``bodies`` entry), at ``initial_pose`` in ``frame_id``; ``name`` required
        (``allow_renaming`` gives a taken one a number). Recorded as an event."""
        results = response.result
        spawn = self._spawn_request(request, response)
        if isinstance(spawn, type(response)):
            return spawn
        event = spawn_event(**spawn)

        def apply():
            try:
                self.node.edit_scene(event)
            except (SceneError, ValueError, KeyError) as exc:
                return _spawn_code(response, str(exc)), str(exc)
            self.stopped = False
            return results.RESULT_OK, ''

        outcome = self.node._in_stepping_thread(apply)
        if outcome is None:
            return self._result(response, results.RESULT_OPERATION_FAILED, 'node stopping')
        response.entity_name = event['entity'] if outcome[0] == results.RESULT_OK else ''
        return self._result(response, *outcome)

    def _spawn_request(self, request, response):
        """The ``spawn_event`` arguments of a SpawnEntity request, or the response saying why
        it is refused."""
        name, world = request.name, self.node.config['frame_id']
        taken = set(self.node.sim.body_names) | set(entity_names(self.node.sim.scene))
        if request.allow_renaming and (not name or name in taken):
            base, number = name or 'entity', 1
            while f'{base}_{number}' in taken:
                number += 1
            name = f'{base}_{number}'
        if not re.fullmatch(r'[A-Za-z][A-Za-z0-9_]{0,63}', name):
            return self._result(response, response.NAME_INVALID, f'name {name!r}: letters, '
                                'digits and _, starting with a letter, at most 64 (it prefixes '
                                'a robot\'s links and topics)')
        if name in taken:
            return self._result(response, response.NAME_NOT_UNIQUE, f'name {name!r} is taken')
        namespace = request.entity_namespace.strip('/') or None
        if namespace and (len(namespace) > 128 or not re.fullmatch(
                r'[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*', namespace)):
            return self._result(response, response.NAMESPACE_INVALID,
                                f'entity_namespace {request.entity_namespace!r}')
        pose = request.initial_pose
        if pose.header.frame_id not in ('', world):
            return self._result(response, response.result.RESULT_FEATURE_UNSUPPORTED,
                                f'initial_pose.header.frame_id {pose.header.frame_id!r}: poses '
                                f'are in {world!r} (or \'\', the same) only')
        p, o = pose.pose.position, pose.pose.orientation
        norm = float(np.linalg.norm([o.x, o.y, o.z, o.w]))
        if not np.isfinite([p.x, p.y, p.z, norm]).all() or abs(norm - 1.0) > 1e-6:
            return self._result(response, response.INVALID_POSE, f'initial_pose: a finite '
                                f'position and a unit quaternion (norm {norm:.6g})')
        matrix = np.eye(4)
        matrix[:3, :3], matrix[:3, 3] = quaternion_matrix(o.x, o.y, o.z, o.w), (p.x, p.y, p.z)
        resource = _resource(request)
        if resource is None:
            return self._result(response, response.NO_RESOURCE, 'give uri or resource_string')
        if isinstance(resource, tuple):
            return self._result(response, *resource)
        return {'name': name, 'pose': matrix, 'namespace': namespace, **resource}

    def _delete(self, request, response):
        """DeleteEntity: a robot or a body in no joint (GetEntities lists the bodies).
        Recorded as an event."""
        results = response.result
        if request.entity not in entity_names(self.node.sim.scene):
            return self._result(response, results.RESULT_NOT_FOUND, f'no entity '
                                f'{request.entity!r} to delete (robots and bodies in no '
                                f'joint: {", ".join(entity_names(self.node.sim.scene))})')

        def apply():
            try:
                self.node.edit_scene({'event': DELETE_EVENT, 'entity': request.entity})
            except SceneError as exc:           # a sensor sits on it
                return results.RESULT_OPERATION_FAILED, str(exc)
            return results.RESULT_OK, ''

        outcome = self.node._in_stepping_thread(apply)
        if outcome is None:
            return self._result(response, results.RESULT_OPERATION_FAILED, 'node stopping')
        return self._result(response, *outcome)


def _resource(request):
    """A SpawnEntity request's entity: {'urdf': path or text} or {'body': entry}; None without
    any; (code, message) when it cannot be read."""
    from simulation_interfaces.srv import SpawnEntity

    codes = SpawnEntity.Response
    if request.uri:
        uri = request.uri
        path = Path(unquote(uri[len('file://'):]) if uri.startswith('file://') else uri)
        if not path.is_file():
            return codes.RESOURCE_PARSE_ERROR, f'uri {uri!r}: no such file here'
        if path.suffix in ('.yaml', '.yml'):
            text = path.read_text(encoding='utf-8', errors='replace')
        else:
            return {'urdf': str(path.resolve())}
    elif request.resource_string.strip():
        text = request.resource_string
        if text.lstrip().startswith('<'):
            return {'urdf': text}
    else:
        return None
    try:
        body = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        return codes.RESOURCE_PARSE_ERROR, f'not YAML: {exc}'
    if not isinstance(body, dict):
        return codes.UNSUPPORTED_FORMAT, ('a URDF (starting with <) or a YAML mapping: a '
                                          'scene bodies entry')
    return {'body': {k: v for k, v in body.items() if k != 'name'}}


def _spawn_code(response, message: str) -> int:
    """The SpawnEntity result code of a refused spawn's message."""
    if ' inside ' in message:
        return response.INVALID_POSE
    if 'not found' in message:
        return response.MISSING_ASSETS
    return response.RESOURCE_PARSE_ERROR
