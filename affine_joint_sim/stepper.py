"""Stepper: the simulator as a plain Python object (no ROS): docs/architecture.md#stepper.

Every state array has a leading environment axis; without ``num_envs`` the public properties
drop it. A step is one replay of a captured graph: on CPU Warp's graph of the kernel launch
(replayed in C++, far cheaper than a recorded launch: docs/architecture.md#measured-figures); on a
GPU a CUDA graph, with the command upload captured in it when a setter changed a command.
Commands are written and outputs read through NumPy views of host arrays (``mirrors``: on a
GPU outputs are downloaded when read, by group), so nothing in ``step()`` but the replay and a
look at one number, the count of environments that had a problem, runs per step.
"""

import math
import os
import warnings
import weakref
from concurrent.futures import ThreadPoolExecutor
from itertools import compress
from operator import itemgetter

import numpy as np
import warp as wp

from affine_joint_sim.physics.host.energy import mechanical_energy
from affine_joint_sim.physics.host.fields import (CONTACT_STATS, COUPLED_STATS, PROBLEM_COLUMNS,
                                                  STAT_FLOAT_NAMES, STAT_INT_NAMES, allocate,
                                                  array_sizes, device_model, fields_of,
                                                  held_structs)
from affine_joint_sim.physics.stages.frames import FRAME_COLUMNS, POSE_COLUMNS
from affine_joint_sim.physics.contact.report import REPORT_COLUMNS, REPORT_ROOM
from affine_joint_sim.physics.host.joint_kinds import joint_kind
from affine_joint_sim.physics.kernels import (frame_kernel, report_kernel, scalar_of,
                                              sensor_kernel, step_kernels)
from affine_joint_sim.mirrors import Downloads, Uploads, host_copy
from affine_joint_sim.physics.contact.model import refuse_touching
from affine_joint_sim.physics.host.model import (build_model, initial_states,
                                                 largest_step_efforts)
from affine_joint_sim.physics.solve.newton import HALVINGS
from affine_joint_sim.physics.contact.pairs import near_pairs, pair_gap
from affine_joint_sim.placement import body_rows, free_body
from affine_joint_sim.poses import LinkFrames
from affine_joint_sim.scene import Scene
from affine_joint_sim.sensors import SensorSet
from affine_joint_sim.sim_warnings import SimulationWarning, summarised

__all__ = ['Stepper', 'SimulationWarning']

_PROBLEMS = {      # by physics.host.fields.PROBLEM_NAMES
    'not_converged': 'Newton did not converge within newton_max_iter = {max_iter} iterations '
                     '(stats["converged"] is False; residual {residual:.3g} m/s); the step '
                     'keeps its last iterate',
    'non_finite': 'the step produced NaN/Inf: it was rejected and the last good state kept '
                  '(stats["step_rejected"]); {advice}',
    'angle_aliased': 'a joint turned more than 0.9π in one step, so its angle would alias: the '
                     'step was rejected and the last good state kept (stats["step_rejected"]); '
                     '{advice}',
    'torque_dropped': 'a body is nearly singular (|det A| < 1e-6 ∏|a_r|): its joint torque '
                      'was dropped this step',
    'line_search_failures': f'the line search found no decrease in {HALVINGS} halvings',
}
# the column of steps whose near list outgrew its room: taken again at once (Stepper._retake),
# not a problem a user sees
_NEAR_FULL = PROBLEM_COLUMNS.index('near_full')
# the Scratch arrays sized by the near lists' room (physics.host.fields ``near``): grown together
_NEAR_ARRAYS = tuple(f.name for f in fields_of('scratch') if 'near' in f.shape)
# What a rebuilt Stepper (spawn, delete) carries over, by the rows of State they are.
_BODY_ROWS = ('q', 'v', 'q_prev', 'v_prev', 'correction', 'correction_prev')
_JOINT_ROWS = ('joint_coordinate', 'joint_coordinate_prev', 'joint_position', 'joint_velocity',
               'joint_effort')
_ENV_ROWS = ('history_ready', 'nearest_seen', 'most_contacts')
_FLAGS = ('converged', 'angle_aliased', 'torque_dropped', 'non_finite', 'step_rejected')
# Outputs by download group (mirrors.Downloads): what one read moves to the host on a GPU
# (State arrays, and the Scratch ones the contact report needs).
_OUTPUT_GROUPS = {'joints': ('joint_position', 'joint_velocity', 'joint_effort'),
                  'contact_record': ('nearest_seen', 'most_contacts'),
                  'stats': ('stats_int', 'stats_float'), 'bodies': ('q', 'v'),
                  'coordinate': ('joint_coordinate',), 'history': ('v_prev',)}


def _columns(index: np.ndarray) -> slice | np.ndarray:
    """``index`` (ascending joint indices) as a slice where it is one run (writing through a
    slice is a plain copy, through an index array a gather), else itself."""
    if len(index) and index[-1] - index[0] == len(index) - 1:
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _stat_layout(host) -> tuple[list[str], itemgetter]:
    """The names of the statistics a scene reports (``Stepper.stats``: the contact ones only
    with contact, the coupled solve's only where bodies may touch each other) and what picks
    their values, in that order, from those of STAT_INT_NAMES + STAT_FLOAT_NAMES."""
    dropped = ((() if host.has_contact else CONTACT_STATS)
               + (() if host.has_body_pairs else COUPLED_STATS))
    every = STAT_INT_NAMES + STAT_FLOAT_NAMES
    columns = [c for c, name in enumerate(every) if name not in dropped]
    return [every[c] for c in columns], itemgetter(*columns)


def _commanded(joint) -> bool:
    """Whether a joint takes a torque or force command: not a weld, not a mimic."""
    return joint_kind(joint.type).command is not None and joint.mimic is None


def _has_drive(joint) -> bool:
    """Whether a scene joint has a drive (takes a position target)."""
    return joint.drive is not None


def _has_damping(joint) -> bool:
    """Whether a scene joint has damping (takes a velocity target)."""
    return joint.damping > 0.0


def _kept(items, before) -> tuple[np.ndarray, np.ndarray]:
    """(indices in ``items``, indices in ``before``) of the entries both have, by name."""
    index = {item.name: i for i, item in enumerate(before)}
    pairs = [(i, index[item.name]) for i, item in enumerate(items) if item.name in index]
    return (np.array([i for i, _ in pairs], dtype=np.intp),
            np.array([j for _, j in pairs], dtype=np.intp))


def _chunks(envs: int, threads: int | None) -> list[tuple[int, int]]:
    """(first environment, count) of each thread's share of ``envs`` (even shares, the first
    ones one larger); ``threads`` None: one per core the process may use."""
    if threads is None:
        threads = len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else (
            os.cpu_count() or 1)
    threads = max(1, min(threads, envs))
    size, extra = divmod(envs, threads)
    counts = [size + (k < extra) for k in range(threads)]
    return [(sum(counts[:k]), counts[k]) for k in range(threads)]


class Stepper:
    """Affine-body simulation of one scene, in one or ``num_envs`` independent environments.

    Args:
        scene: a ``Scene`` (or the path of a scene YAML or URDF file).
        device: Warp device, ``"cpu"`` (default), ``"cuda"`` or ``"cuda:N"``.
        num_envs: number of environments; ``None`` for a single one without the env axis.
        on_problem: called with the message of each problem a step reports (once per kind
            and reset); default: a ``SimulationWarning``.
        threads: CPU threads that step the environments, each its own share of them at once
            (default: one per core the process may use, at most one per environment; a GPU
            steps them all in one launch).
    """

    # Host mirrors on the CPU too: runs the GPU's upload/download path where CI can test it.
    _mirror_on_cpu = False

    def __init__(self, scene, device: str = 'cpu', num_envs: int | None = None,
                 on_problem=None, threads: int | None = None):
        if not isinstance(scene, Scene):
            scene = Scene.load(scene)
        if num_envs is not None and (int(num_envs) != num_envs or num_envs < 1):
            raise ValueError(f'num_envs must be a positive integer or None, got {num_envs!r}')
        self.scene = scene
        self._on_problem = on_problem
        self.device = wp.get_device(device)
        self._batched = num_envs is not None
        self._envs = 1 if num_envs is None else int(num_envs)
        if threads is not None and (int(threads) != threads or threads < 1):
            raise ValueError(f'threads must be a positive integer or None, got {threads!r}')
        cpu = self.device.is_cpu and not self._mirror_on_cpu
        self._chunks = _chunks(self._envs, threads if cpu else 1)
        self._pool = None
        if len(self._chunks) > 1:
            self._pool = ThreadPoolExecutor(len(self._chunks) - 1, 'affine-joint-sim-step')
            weakref.finalize(self, self._pool.shutdown, wait=False)
        with summarised(f'scene {scene.name!r}'):     # one line for its meshes reduced
            self._build(scene, build_model(scene))
        self.reset()
        self._record()

    def _build(self, scene, host) -> None:
        """Everything made from ``scene`` and its host model ``host``: the kernels (Warp's
        cache has them where the variant is the same), the lookups and the arrays, allocated
        but not set (``reset``)."""
        self.scene, self._host = scene, host
        self._k = step_kernels(scalar_of(scene.solver.precision), self._host.has_body_pairs,
                               contact=bool(self._host.has_contact),
                               shapes=self._host.has_static_shapes)
        self._effort_limit = np.array([j.effort_limit for j in scene.joints])
        # a joint's index by name, and the joints that take a command: a control loop sets
        # torques by name every step, so these are looked up, not searched
        self._index_of = {joint.name: k for k, joint in enumerate(scene.joints)}
        self._commanded = np.array([k for k, j in enumerate(scene.joints) if _commanded(j)],
                                   dtype=np.intp)
        self._command_columns = _columns(self._commanded)
        # finite bounds (an unlimited joint's the largest float), so that |±Inf| fails the
        # one comparison set_torques makes when every value is fine
        self._commanded_limit = np.minimum(self._effort_limit[self._commanded],
                                           np.finfo(np.float64).max)
        self._links = LinkFrames(scene)
        self._stat_layout = _stat_layout(self._host)
        self._link_read = None          # link_transforms' replay, captured on its first read
        self._report = None             # contacts' replay, captured on its first read
        self._sensor_read = None        # sensors' replay, captured on their first read
        self._pair_name_cache = {}
        # the scene's sensors (README.md#sensors); None without any: nothing to pay for
        self._sensors = SensorSet(scene) if scene.sensors else None
        self._near_room = self._host.near_room      # pairs a near list has room for
        self._graphs = None
        self._allocate()

    # ---- public API -----------------------------------------------------------------------

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.scene.joints]

    @property
    def body_names(self) -> list[str]:
        return [b.name for b in self.scene.bodies]

    @property
    def num_envs(self) -> int:
        return self._envs

    @property
    def dt(self) -> float:
        """Time step [s]."""
        return self.scene.dt

    @property
    def time(self) -> float:
        """Simulated time [s] (step count × dt)."""
        return self._steps * self.scene.dt

    @property
    def step_count(self) -> int:
        return self._steps

    @property
    def joint_types(self) -> list[str]:
        """Each joint's type (physics.host.joint_kinds): 'revolute' (angles [rad], torques [N·m]),
        'prismatic' (distances [m], forces [N]) or 'fixed' (no coordinate, no command;
        reported as 0)."""
        return [j.type for j in self.scene.joints]

    @property
    def problem_totals(self) -> dict[str, int]:
        """Environment-steps that had each kind of problem since the Stepper was made (a reset
        does not clear them): not_converged, non_finite and angle_aliased (both rejected, the
        last good state kept), torque_dropped, line_search_failures."""
        return {name: int(n) for name, n in zip(PROBLEM_COLUMNS[1:], self._problem_totals[1:])
                if name != 'near_full'}

    @property
    def near_room(self) -> int:
        """Contact pairs a near list holds per environment (the pairs a step evaluates: those
        within d̂ plus each body's margin at the step's start); it starts at twice the moving
        contact points, edges and faces (at least 64) and doubles, at once, when a step needs
        more (README.md#contact)."""
        return self._near_room

    @property
    def step_effort_bounds(self) -> np.ndarray:
        """Per joint, the largest |torque| [N·m] or |force| [N] a step of dt can represent
        (physics.host.model.largest_step_efforts): a command beyond it is not physical at this
        dt."""
        return largest_step_efforts(self._host)

    @property
    def command_joint_names(self) -> list[str]:
        """The joints that take a torque or force command (every joint but welds and mimic
        joints)."""
        return [self.scene.joints[k].name for k in self.command_joint_index]

    @property
    def command_joint_index(self) -> np.ndarray:
        """Scene indices of ``command_joint_names`` (to select them from per-joint arrays)."""
        return self._commanded.copy()

    @property
    def drive_joint_names(self) -> list[str]:
        """The joints that have a drive (take a target with ``set_target``)."""
        return [j.name for j in self.scene.joints if _has_drive(j)]

    @property
    def damped_joint_names(self) -> list[str]:
        """The joints with damping (take a speed with ``set_velocity_target``)."""
        return [j.name for j in self.scene.joints if _has_damping(j)]

    def set_torque(self, name: str, value) -> None:
        """Set joint ``name``'s external torque τ [N·m] (force [N] for a prismatic joint),
        held until changed.

        ``value`` is a scalar (every environment) or an array of shape (num_envs,). Values
        above the joint's effort_limit are clamped (``clamp_totals`` counts them; a warning
        says so once per joint until reset); NaN/Inf raise ValueError, and so does a fixed
        joint, which takes no command.
        """
        k = self._movable(name)
        limit = self._effort_limit[k]
        if isinstance(value, (int, float)):   # one command per message: NumPy is slow for one
            tau = value
            finite, over = math.isfinite(tau), abs(tau) > limit
        else:
            tau = self._per_env(name, value, np.float64)
            finite, over = np.all(np.isfinite(tau)), np.any(np.abs(tau) > limit)
        if not finite:
            raise ValueError(f'joint {name!r}: torque must be finite, got {value!r}')
        if over:
            slot = int(np.searchsorted(self._commanded, k))
            column = np.reshape(tau, (-1, 1))
            tau = self._clamp(column, np.abs(column), slice(slot, slot + 1), limit)[:, 0]
        self._torque[:, k] = tau
        self._uploads.written()

    def set_torques(self, values) -> None:
        """Set the torques [N·m] and forces [N] of every joint of ``command_joint_names`` at
        once, in that order: ``values`` of shape (n,) (every environment) or (num_envs, n).
        As ``set_torque``: held until changed, clamped to effort_limit (counted, said once per
        joint until reset), NaN/Inf raise ValueError (and so does another shape)."""
        index = self._commanded
        tau = np.asarray(values, dtype=np.float64)
        if tau.shape not in ((len(index),), (self._envs, len(index))):
            raise ValueError(f'set_torques: expected shape ({len(index)},) or ({self._envs}, '
                             f'{len(index)}) in command_joint_names order, got {tau.shape}')
        if not len(index):              # no joint takes a command (a lone box): nothing to set
            return
        limits, magnitude = self._commanded_limit, np.abs(tau)
        if not (magnitude <= limits).all():     # NaN, ±Inf or over a limit
            finite = np.isfinite(magnitude)
            if not finite.all():
                bad = ~finite.reshape(-1, len(index)).all(axis=0)
                raise ValueError('set_torques: torque must be finite for ' + ', '.join(
                    self.scene.joints[k].name for k in index[bad]))
            tau = self._clamp(tau, magnitude, slice(None), limits)
        self._torque[:, self._command_columns] = tau
        self._uploads.written()

    @property
    def clamp_totals(self) -> dict[str, int]:
        """Per joint of ``command_joint_names``, the values ``set_torque``/``set_torques``
        clamped to its effort_limit since the Stepper was made (a reset does not clear them; a
        value given for every environment counts once)."""
        return dict(zip(self.command_joint_names, self._clamp_totals.tolist()))

    def _clamp(self, tau: np.ndarray, magnitude: np.ndarray, slots: slice,
               limits) -> np.ndarray:
        """``tau`` [N·m | N] (finite, shape (..., n)) of the joints ``slots`` of
        command_joint_names (n of them), with ``magnitude`` |tau|, clipped to their effort
        ``limits``: each value clipped counted in ``clamp_totals``, each joint said once until
        reset (at set_torque(s)' caller's line)."""
        over = magnitude > limits
        counts = over if over.ndim == 1 else over.sum(axis=0)
        self._clamp_totals[slots] += counts
        new = [k for k, count in zip(self._commanded[slots].tolist(), counts.tolist())
               if count and ('clamped', k) not in self._warned]
        if new:
            self._warned.update(('clamped', k) for k in new)
            self._say('|torque| above effort_limit, clamped: ' + ', '.join(
                f'{self.scene.joints[k].name!r} (effort_limit {self._effort_limit[k]:g} N·m)'
                for k in new) + '; said once per joint until reset, clamp_totals counts every '
                'value', stacklevel=4)
        return np.copysign(np.minimum(magnitude, limits), tau)     # as np.clip, cheaper

    def set_enabled(self, name: str, enabled) -> None:
        """Enable (True) or disable joint ``name``'s torque (external_torque/is_constrained)."""
        k = self._movable(name)
        self._enabled[:, k] = self._per_env(name, enabled, np.bool_)
        self._torque_mask[:, k] = (self._enabled[:, k] != 0) & bool(self._host.joint_has_free[k])
        self._uploads.written()

    def set_target(self, name: str, value) -> None:
        """Set the drive target of joint ``name`` [rad | m], acting from the next step.

        ``value`` is a scalar or an array of shape (num_envs,); NaN/Inf raise ValueError, and
        so does a joint without a ``drive``."""
        self._set_joint_input(name, value, self._target, _has_drive, 'a drive', 'target')

    def set_velocity_target(self, name: str, value) -> None:
        """Set the speed [rad/s | m/s] joint ``name``'s damping pulls toward (a velocity
        drive: a torque c (v − ẋ) inside the implicit step, c its ``damping``; 0 is damping
        alone), acting from the next step.

        ``value`` is a scalar or an array of shape (num_envs,); NaN/Inf raise ValueError, and
        so does a joint without damping."""
        self._set_joint_input(name, value, self._velocity_target, _has_damping, 'damping',
                              'velocity target')

    def _set_joint_input(self, name: str, value, inputs: np.ndarray, takes, needs: str,
                         what: str) -> None:
        """``inputs[:, joint]`` = ``value`` (a scalar or (num_envs,)) for joint ``name``, which
        ``takes(joint)`` (those with ``needs``), finite; else ValueError saying which."""
        k = self._joint(name)
        if not takes(self.scene.joints[k]):
            able = [j.name for j in self.scene.joints if takes(j)]
            raise ValueError(f'joint {name!r} has no {needs.split()[-1]}; joints with '
                             f'{needs}: {", ".join(able) or "none"}')
        values = self._per_env(name, value, np.float64)
        if not np.all(np.isfinite(values)):
            raise ValueError(f'joint {name!r}: {what} must be finite, got {value!r}')
        inputs[:, k] = values
        self._uploads.written()

    def set_drive_enabled(self, name: str, enabled) -> None:
        """Switch joint ``name``'s drive on (True) or off (driving/is_constrained)."""
        k = self._joint(name)
        self._drive_enabled[:, k] = self._per_env(name, enabled, np.bool_)
        self._uploads.written()

    def step(self) -> None:
        """Advance every environment by one dt.

        An environment whose step is rejected (``stats['step_rejected']``) keeps its last good
        state while the time still advances; a SimulationWarning says why, once per reset."""
        if self._pool is None:
            wp.capture_launch(self._graphs[self._uploads.take()])
        else:                   # the CPU: one launch per share, at once (the GIL is released)
            self._problems.fill(0)
            shares = [self._pool.submit(launch.launch) for launch in self._launches[1:]]
            try:
                self._launches[0].launch()
            finally:            # every share ends before the next step or error
                for share in shares:
                    share.result()
        if not self.device.is_cpu:
            wp.synchronize_device(self.device)
        self._downloads.stale()
        self._contacts = None          # computed again when next asked for
        self._steps += 1
        counts = self._problems.sum(axis=0) if self._pool is not None else self._problems[0]
        if counts[_NEAR_FULL] != 0:
            counts = self._retake(counts.copy())
        if counts[0] != 0:
            self._problem_totals += counts
            self._check(counts)

    def reset(self) -> None:
        """Back to the scene's initial state, time 0 and the scene's initial commands."""
        h, n = self._host, self._envs
        q0 = np.broadcast_to(h.body_q0, (n, *h.body_q0.shape))
        v0 = np.broadcast_to(h.body_v0, (n, *h.body_v0.shape))
        # q_n too: a step writes the free bodies' rows only, so the fixed ones keep q0 (the
        # energy at q_n, which Newton's start compares, includes their joints)
        for array, value in ((self._state.q, q0), (self._state.v, v0), (self._state.q_prev, q0),
                             (self._state.v_prev, v0), (self._scratch.q_n, q0)):
            array.assign(np.ascontiguousarray(value))
        # and no lagged contact forces: the first step lags its own (sim.contacts reads them)
        for array in (self._state.history_ready, self._control.joint_target,
                      self._control.joint_drive_enabled, self._state.joint_velocity,
                      self._state.joint_effort, self._state.stats_int, self._state.stats_float,
                      self._scratch.friction_normal, self._scratch.normal_damping,
                      self._scratch.near_full):
            array.zero_()
        self._scratch.body_margin.fill_(-1.0)     # the first step gathers its near list
        self._list_near(h.body_q0)
        x0 = np.ascontiguousarray(np.broadcast_to(h.joint_initial_position,
                                                  (n, h.joint_count)))
        for array in (self._state.joint_coordinate, self._state.joint_coordinate_prev,
                      self._state.joint_position):
            array.assign(x0)
        self._warned = set()
        self._velocity_target[:] = 0.0     # no commanded speeds (uploaded below on a GPU)
        for k, joint in enumerate(self.scene.joints):
            if _commanded(joint):
                self.set_torque(joint.name, joint.torque)
                self.set_enabled(joint.name, joint.enabled)
            if joint.drive is not None:
                self._target[:, k] = joint.drive.target
                self._drive_enabled[:, k] = joint.drive.enabled
        self._uploads.written()
        self._downloads.stale()
        self._contacts = None          # computed again when next asked for
        self._steps = 0

    def _retake(self, counts: np.ndarray) -> np.ndarray:
        """Take again, with more room, the step of every environment whose near list outgrew
        its room (``scratch.near_full``: that step was rejected before it changed anything
        but its list and lagged values; grown and taken again until none does). Returns the
        step's problem counts (``counts``: those of the launch) with the steps taken again in
        place of the rejected ones. A step taken again has the bits it would have had with the
        room from the start (where its list outgrew the room in Newton's search, its lagging
        reads the last step's damping from ``damping_before``: test/test_near_list.py)."""
        while counts[_NEAR_FULL] != 0:
            full = self._scratch.near_full.numpy()
            self._grow_near(int(full.max()))
            counts[[0, _NEAR_FULL]] -= counts[_NEAR_FULL]
            problems = self._state.problem_counts
            problems.zero_()
            args = [self._model, self._state, self._control, self._scratch]
            for env in np.flatnonzero(full):
                wp.launch(self._k.step, dim=1, inputs=[*args, int(env), 0], device=self.device)
            if self._problems_host is not problems:
                wp.copy(self._problems_host, problems)
                wp.synchronize_device(self.device)
            counts += self._problems.sum(axis=0)
        return counts

    def _grow_near(self, needed: int) -> None:
        """Room for ``needed`` pairs in the two near lists together (twice the room of one):
        the room doubles until it holds them (at most every pair), the near arrays are made
        again with their lists and lagged values kept, and the step (and the replays that
        read them) recorded again."""
        room = self._near_room
        while 2 * room < needed:
            room *= 2
        room = min(room, self._host.pair_count)
        if room == self._near_room:
            return
        self._near_room = room
        scratch = self._scratch
        for name in _NEAR_ARRAYS:
            old = getattr(scratch, name)
            kept = old.numpy()
            rows = np.zeros((old.shape[0], 2 * room), dtype=kept.dtype)
            rows[:, :old.shape[1]] = kept
            setattr(scratch, name, wp.array(rows, dtype=old.dtype, device=self.device))
        self._held = held_structs(self._k, self.device, model=self._model, state=self._state,
                                  control=self._control, scratch=scratch)
        self._report = self._sensor_read = None     # their replays held the old arrays
        if self._graphs is not None:
            self._record()

    def _list_near(self, q: np.ndarray) -> None:
        """Every environment's near list (``scratch.near_pairs``, as a step gathers it) for
        the state ``q`` (n_bodies, 12) they all start from, or each its own (num_envs,
        n_bodies, 12): its pairs closer than d̂, so that ``contacts`` reads the start, a reset
        or an edited scene (``_rebuild``) before any step."""
        if not self._host.has_contact:
            return
        model, d_hat = vars(self._host), self._host.contact_d_hat
        states = np.broadcast_to(q, (self._envs, *np.shape(q)[-2:]))
        lists = [[p for p in near_pairs(model, state, d_hat)
                  if pair_gap(model, state, int(p)).distance < d_hat]
                 for state in (states[:1] if np.ndim(q) == 2 else states)]
        self._grow_near(2 * max(map(len, lists)))
        pairs, count = self._scratch.near_pairs.numpy(), self._scratch.near_count.numpy()
        for env in range(self._envs):
            near = lists[min(env, len(lists) - 1)]
            pairs[env, :len(near)] = near
            count[env] = len(near)
        self._store(self._scratch.near_pairs, pairs)
        self._store(self._scratch.near_count, count)

    def spawn(self, name: str, pose=None, body: dict | None = None, urdf: str | None = None,
              namespace: str | None = None, **options) -> None:
        """Add entity ``name`` between steps (README.md#spawning-and-deleting): ``body`` (a
        scene ``bodies`` entry without its name) or ``urdf`` (a URDF file's path or its text:
        a robot whose bodies, joints and links are named ``<name>/...``, its topics under
        ``namespace``, default ``name``; ``options``: a ``robots:`` entry's keys such as
        ``fixed_base`` and ``initial_positions``), its frame (a robot's root link) at world
        ``pose`` (4×4; default the identity), at rest unless ``body`` gives velocities. Every
        other body and joint goes on from its state and commands as if nothing was added
        (``_rebuild``). SceneError, KeyError or ValueError naming what is wrong (a name taken,
        a start inside something it may touch); nothing changes then."""
        from affine_joint_sim.spawning import with_body, with_robot

        pose = np.eye(4) if pose is None else np.asarray(pose, dtype=np.float64)
        body_rows(pose, np.eye(4), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))    # ValueError if bad
        if (body is None) == (urdf is None):
            raise ValueError('spawn: give exactly one of body (a scene body entry) or urdf')
        self._rebuild(with_body(self.scene, {**body, 'name': name}, pose) if urdf is None
                      else with_robot(self.scene, name, urdf, pose, namespace, **options))

    def delete(self, name: str) -> None:
        """Remove entity ``name`` between steps: a robot of ``scene.robots`` (its bodies and
        joints) or a body in no joint (``spawning.entity_names``); every other body and joint
        goes on as if nothing was removed. SceneError naming the entities if it is none."""
        from affine_joint_sim.spawning import without

        self._rebuild(without(self.scene, name))

    def _rebuild(self, scene) -> None:
        """Go on with ``scene``, an edit of this one (bodies and joints added at the end or
        removed): every body and joint it keeps, matched by name, keeps its state (q, q̇,
        BDF2's history and the correction Newton starts from; coordinates, velocities,
        efforts) and its commands; the step count, time and counts go on. What is new starts
        at the scene's initial state, its BDF2 history that of a constant velocity, its
        correction none; the lagged contact forces restart (the next step lags its
        own) and the near lists are gathered anew. The edited scene must touch nothing at the
        current state nor at its initial state, where a reset goes (SceneError, and nothing
        changes)."""
        old, envs = self.scene, self._envs
        new_b, old_b = _kept(scene.bodies, old.bodies)
        new_j, old_j = _kept(scene.joints, old.joints)
        state, scratch = self._state, self._scratch
        carried = {name: getattr(group, name).numpy().copy() for group, names in (
            (state, _BODY_ROWS + _JOINT_ROWS + _ENV_ROWS), (scratch, ('q_n',))) for name in names}
        inputs = [view.copy() for view in self._uploads.views.values()]
        q0 = initial_states(scene)
        starts = np.broadcast_to(q0, (envs, *q0.shape)).copy()
        starts[:, new_b] = carried['q'][:, old_b]
        with summarised(f'scene {scene.name!r}'):       # at q0 too: a reset goes there
            host = build_model(scene, [*starts, q0])       # SceneError: nothing changed yet
        steps, totals = self._steps, self._problem_totals
        clamped = dict(zip(self.command_joint_names, self._clamp_totals.tolist()))
        # what was said stays said, but a clamp's by joint index: said again if need be
        warned = {w for w in self._warned if not isinstance(w, tuple)}
        self._build(scene, host)
        self.reset()
        state, scratch = self._state, self._scratch
        for group, names, rows in ((state, _BODY_ROWS, (new_b, old_b)),
                                   (state, _JOINT_ROWS, (new_j, old_j)),
                                   (scratch, ('q_n',), (new_b, old_b))):
            for name in names:
                self._carry(getattr(group, name), carried[name], *rows)
        # a new free body's BDF2 history: the state a step earlier at its constant velocity
        fresh = np.setdiff1d(np.arange(len(scene.bodies)), new_b)
        if len(fresh):
            q_prev = state.q_prev.numpy()
            q_prev[:, fresh] -= scene.dt * state.v.numpy()[:, fresh]
            self._store(state.q_prev, q_prev)
        for name in _ENV_ROWS:
            getattr(state, name).assign(carried[name])
        self._list_near(state.q.numpy())       # as the carried states have them
        for view, before in zip(self._uploads.views.values(), inputs):
            view[:, new_j] = before[:, old_j]
        for k in self._commanded:
            self._torque_mask[:, k] = (self._enabled[:, k] != 0) & bool(host.joint_has_free[k])
        self._uploads.written()
        self._downloads.stale()
        self._steps, self._problem_totals, self._warned = steps, totals, warned
        self._clamp_totals[:] = [clamped.get(n, 0) for n in self.command_joint_names]
        self._record()

    def _carry(self, array, before: np.ndarray, new: np.ndarray, old: np.ndarray) -> None:
        """Rows ``new`` (axis 1) of ``array`` from rows ``old`` of ``before``."""
        rows = array.numpy()
        rows[:, new] = before[:, old]
        self._store(array, rows)

    def set_body_state(self, name: str, pose, linear_velocity=(0.0, 0.0, 0.0),
                       angular_velocity=(0.0, 0.0, 0.0), env: int = 0) -> None:
        """Place free body ``name`` (not fixed, in no joint) at once, between steps, in
        environment ``env``: ``pose`` the 4×4 world transform of its frame (as
        link_transforms gives it: the link of that name in a URDF scene, else the body's
        origin), ``linear_velocity`` [m/s] of that frame's origin and ``angular_velocity`` ω
        [rad/s], world frame. The environment's next step is a BDF1 start step, as after a
        reset (BDF2's history of the placed body is gone); the lagged contact forces of the
        body's pairs are dropped (the next step lags its own). Raises KeyError or ValueError
        naming what is wrong, SceneError if the body would be inside something it may touch;
        nothing changes then."""
        if int(env) != env or not 0 <= env < self._envs:
            raise ValueError(f'env must be an integer in [0, {self._envs}), got {env!r}')
        b = free_body(self.scene, name)
        links = self._links
        local = links.local[links.names.index(name)] if name in links.names else np.eye(4)
        q_row, v_row = body_rows(pose, local, linear_velocity, angular_velocity)
        q = self._read('q')[env].astype(np.float64)
        q[b] = q_row
        host = self._host
        if host.has_contact:
            refuse_touching(self.scene, q, vars(host), host.static_names, body=b,
                            verb='would be', rule='a body is placed where it touches nothing')
        state, scratch = self._state, self._scratch
        for array, row in ((state.q, q_row), (state.q_prev, q_row), (scratch.q_n, q_row),
                           (state.v, v_row), (state.v_prev, v_row)):
            rows = array.numpy()
            rows[env, b] = row
            self._store(array, rows)
        listed = scratch.near_pairs.numpy()[env, :scratch.near_count.numpy()[env]]
        for array in (scratch.friction_normal, scratch.normal_damping):
            lagged = array.numpy()
            for k in np.flatnonzero(lagged[env, :len(listed)]):    # none without contact
                gap = pair_gap(vars(host), q, int(listed[k]))
                if b in (gap.body, gap.other):
                    lagged[env, k] = 0.0
            self._store(array, lagged)
        margins = scratch.body_margin.numpy()
        margins[env] = -1.0         # the next step gathers its near list anew
        self._store(scratch.body_margin, margins)
        ready = state.history_ready.numpy()
        ready[env] = 0
        self._store(state.history_ready, ready)
        self._downloads.stale()
        self._contacts = None

    @property
    def angles(self) -> np.ndarray:
        """Joint coordinates: revolute angles [rad] per angle_mode, prismatic distances [m]
        (0 at t = 0), 0 for fixed joints; shape (n_joints,) or (num_envs, n_joints)."""
        return self._out(self._read('joint_position'))

    @property
    def velocities(self) -> np.ndarray:
        """Joint velocities Δx/dt [rad/s | m/s]."""
        return self._out(self._read('joint_velocity'))

    @property
    def efforts(self) -> np.ndarray:
        """Torque [N·m] or force [N] applied in the last step (0 if disabled or fixed)."""
        return self._out(self._read('joint_effort'))

    @property
    def torques(self) -> np.ndarray:
        """Commanded torques [N·m] / forces [N] after effort_limit clamping."""
        return self._out(self._torque)

    @property
    def targets(self) -> np.ndarray:
        """Drive targets [rad | m] (0 for joints without a drive)."""
        return self._out(self._target)

    @property
    def velocity_targets(self) -> np.ndarray:
        """Commanded speeds [rad/s | m/s] of the joints' damping (``set_velocity_target``)."""
        return self._out(self._velocity_target)

    @property
    def enabled(self) -> np.ndarray:
        """Enable flags of the joint torques."""
        return self._out(self._enabled.astype(bool))

    @property
    def body_q(self) -> np.ndarray:
        """ABD state q = [p, a1, a2, a3] per body, world frame [m, -]."""
        return self._out(self._read('q'))

    @property
    def body_qdot(self) -> np.ndarray:
        """ABD velocity q̇ = [ṗ, ȧ1, ȧ2, ȧ3] per body, world frame [m/s, 1/s]."""
        return self._out(self._read('v'))

    @property
    def body_transforms(self) -> np.ndarray:
        """World transforms [[A, p], [0, 1]] per body, shape (..., n_bodies, 4, 4)."""
        q = self._read('q')
        t = np.zeros((*q.shape[:2], 4, 4))
        t[..., :3, :3] = q[..., 3:].reshape(*q.shape[:2], 3, 3)
        t[..., :3, 3] = q[..., :3]
        t[..., 3, 3] = 1.0
        return t if self._batched else t[0]

    @property
    def link_names(self) -> list[str]:
        """Names of the link frames: a URDF scene's links (welded ones included), else the
        bodies."""
        return self._links.names

    @property
    def link_transforms(self) -> np.ndarray:
        """Rigid world transforms of the link frames, (..., n_links, 4, 4): each body's pose
        with A replaced by its nearest rotation (polar decomposition), times the link's pose
        in the body. One replay of a captured launch for every environment's links, which
        writes the 4×4 arrays themselves (the first read compiles and captures it), copied
        out. ``pose_reader`` gives chosen frames as positions and quaternions, without a copy."""
        if self._link_read is None:
            links, envs = self._links, self._envs
            replay, rows = self._frame_reader(
                np.tile(links.body, envs), np.tile(links.local, (envs, 1, 1)),
                np.repeat(np.arange(envs), len(links.names)))
            transforms = rows[:, POSE_COLUMNS:].reshape(envs, len(links.names), 4, 4)
            self._link_read = replay, transforms
        replay, transforms = self._link_read
        replay()
        return self._out(transforms)

    def pose_reader(self, body, local, env: int = 0, parent=None, parent_local=None):
        """A function that returns, each time it is called, the rigid world poses of frames on
        the bodies of environment ``env``: frame i on body ``body[i]`` at pose ``local[i]``
        (4×4) in that body's frame. It returns a (n, 7) float64 array (valid until the next
        call): position [m] and quaternion (x, y, z, w), w ≥ 0, of R·local with R the rotation
        nearest to the body's A (physics.stages.frames). With ``parent`` (a body per frame, −1: the
        world) and ``parent_local`` (4×4 each), each pose is in that parent frame instead (the
        transforms of /tf). One replay of a captured launch, no Python per frame."""
        local = np.asarray(local, dtype=np.float64).reshape(-1, 4, 4)
        replay, rows = self._frame_reader(body, local, np.full(len(local), env), parent,
                                          parent_local)
        view = rows[:, :POSE_COLUMNS]

        def poses() -> np.ndarray:
            replay()
            return view

        poses.keep = replay
        return poses

    def _frame_reader(self, body, local, env, parent=None, parent_local=None):
        """``pose_reader``'s replay, one environment per frame (``env``): (a function that
        replays it, the (n, FRAME_COLUMNS) host view of ``physics.stages.frames``' rows it fills:
        position, quaternion, 4×4 transform)."""
        k = self._k
        local = np.asarray(local, dtype=np.float64).reshape(-1, 4, 4)
        if parent is None:
            parent, parent_local = np.full(len(local), -1), np.tile(np.eye(4), (len(local), 1, 1))
        parent_local = np.asarray(parent_local, dtype=np.float64).reshape(-1, 4, 4)
        dtype = k.numpy_scalar
        inputs = [wp.array(np.asarray(env, dtype=np.int32), dtype=int, device=self.device),
                  wp.array(np.asarray(body, dtype=np.int32), dtype=int, device=self.device),
                  wp.array(local[:, :3, :3].astype(dtype), dtype=k.mat33, device=self.device),
                  wp.array(local[:, :3, 3].astype(dtype), dtype=k.vec3, device=self.device),
                  wp.array(np.asarray(parent, dtype=np.int32), dtype=int, device=self.device),
                  wp.array(parent_local[:, :3, :3].astype(dtype), dtype=k.mat33,
                           device=self.device),
                  wp.array(parent_local[:, :3, 3].astype(dtype), dtype=k.vec3,
                           device=self.device)]
        out = wp.zeros((len(local), FRAME_COLUMNS), dtype=wp.float64, device=self.device)
        replay = self._replay(frame_kernel(k.scalar), len(local), [self._state.q, *inputs],
                              [out])
        return replay, replay.views[0]

    def _replay(self, kernel, dim, inputs: list, outputs: list):
        """A function that launches ``kernel`` over ``dim`` with ``inputs`` then ``outputs``
        (Warp arrays) as one replay of a captured graph and returns the outputs' host views
        (copied from a GPU; the same arrays each call, also its ``views``), valid until the
        next call."""
        on_host = [host_copy(array, not self.device.is_cpu) for array in outputs]
        wp.load_module(kernel.module, device=self.device)
        with wp.ScopedCapture(device=self.device) as capture:
            wp.launch(kernel, dim=dim, inputs=[*inputs, *outputs], device=self.device)
            for array, host in zip(outputs, on_host):
                if host is not array:
                    wp.copy(host, array)
        graph, views = capture.graph, [host.numpy() for host in on_host]

        def read() -> list[np.ndarray]:
            wp.capture_launch(graph)
            if not self.device.is_cpu:
                wp.synchronize_device(self.device)
            return views

        read.keep = (inputs, outputs, on_host)      # the graph refers to these arrays
        read.views = views
        return read

    @property
    def sensor_names(self) -> list[str]:
        """The scene's sensors, in scene order (``sensors`` keys)."""
        return [s.name for s in self.scene.sensors]

    @property
    def sensors(self) -> dict[str, dict[str, np.ndarray]]:
        """The readings of the scene's sensors at the current state (affine_joint_sim.sensors;
        README.md#sensors), ``{name: {value: array}}`` in the sensor's frame (its link's, or
        its body's): an ``imu`` gives ``orientation`` (quaternion x, y, z, w of the frame in
        the world, w ≥ 0), ``angular_velocity`` [rad/s] and ``linear_acceleration`` [m/s²]:
        the specific force a − g over the last step (−g before the first step and right after
        a reset); a ``contact`` sensor ``force`` [N] and ``torque`` [N·m about the frame's
        origin], the sum over ``contacts`` of its body. Batched: each array gains a leading
        env axis. Computed when read (a scene without sensors gives {} and pays nothing)."""
        sensors = self._sensors
        if sensors is None:
            return {}
        if self._sensor_read is None:
            self._sensor_read = self._capture_sensors(sensors)
        values = sensors.readings(self._sensor_read()[0].copy())
        if not self._batched:
            values = {name: {key: array[0] for key, array in reading.items()}
                      for name, reading in values.items()}
        return values

    def _capture_sensors(self, sensors: SensorSet):
        """The sensor kernel's replay over every environment (``sensors`` its SensorSet): a
        function returning [its rows (envs, sensors.columns) float64], valid until the next
        call."""
        k, dev, mounts = self._k, self.device, sensors.mounts
        contact = bool(sensors.contact) and self._host.has_contact
        inputs = [wp.array(mounts.kind, dtype=int, device=dev),
                  wp.array(mounts.body, dtype=int, device=dev),
                  wp.array(mounts.rotation.astype(k.numpy_scalar), dtype=k.mat33, device=dev),
                  wp.array(mounts.offset.astype(k.numpy_scalar), dtype=k.vec3, device=dev),
                  wp.array(mounts.column, dtype=int, device=dev)]
        out = wp.zeros((self._envs, sensors.columns), dtype=wp.float64, device=dev)
        return self._replay(sensor_kernel(k.scalar, self._host.has_body_pairs, contact),
                            self._envs, [self._model, self._state, self._scratch, *inputs],
                            [out])

    @property
    def energy(self) -> np.ndarray | float:
        """Mechanical energy [J]: kinetic + gravity + orthogonality + joint springs (+ contact
        barriers) (per env).

        BDF steps dissipate it; a passive system must not gain it (physics.host.energy)."""
        energy = mechanical_energy(self._host, self._read('q'), self._read('v'),
                                   self._read('joint_coordinate'))
        return energy if self._batched else float(energy[0])

    @property
    def stats(self) -> dict:
        """Statistics of the last step: Newton iterations, residual [m/s] (largest vertex
        update / dt), line-search halvings and failures, joint gap [m], converged flag, ...,
        ``step_rejected`` (the step's state was non-finite, flag ``non_finite``, or a joint
        turned more than 0.9π, flag ``angle_aliased``: the environment kept its start-of-step
        state), and ``active_terms``: the terms the next step evaluates (``torque`` only while
        some joint has an enabled, non-zero torque)."""
        ints, floats = self._read('stats_int'), self._read('stats_float')
        names, pick = self._stat_layout
        if self._batched:
            values = pick([*ints.T, *floats.T.astype(np.float64)])
            stats = {name: value.copy() for name, value in zip(names, values)}
            for name in _FLAGS:
                stats[name] = stats[name].astype(bool)
        else:                   # Python scalars: a dict of NumPy scalars cost 40 µs a read
            stats = dict(zip(names, pick(ints[0].tolist() + floats[0].tolist())))
            for name in _FLAGS:
                stats[name] = bool(stats[name])
        stats['active_terms'] = self._active_terms()
        stats['launches_per_step'] = len(self._chunks)
        return stats

    # ---- internals --------------------------------------------------------------------------

    @property
    def contacts(self) -> list:
        """The active contacts (pairs closer than d̂) at the current state: a list of dicts
        (``body``, ``other``: the half-space or fixed body, ``point`` [m, world] on the other's
        surface, ``normal`` (unit, towards the body), ``distance`` [m], ``normal_force`` [N],
        ``friction_force`` [N, world, on the body]), one list per environment when batched;
        empty without contact. The pairs the last step evaluated, by pair number
        (``physics.contact.report``: one replay of a captured launch over every environment),
        computed once per state: the same lists until the next step or reset (read them, do
        not change them)."""
        if not self._host.has_contact:
            per_env = [[] for _ in range(self._envs)]
        else:
            if self._contacts is None:      # once per state: markers and users may both ask
                self._contacts = self._report_contacts()
            per_env = self._contacts
        return per_env if self._batched else per_env[0]

    def _report_contacts(self) -> list[list[dict]]:
        """Each environment's active contacts at the current state (``contacts``), by pair
        number."""
        if self._report is None:
            self._report = self._capture_report(REPORT_ROOM)
        counts, pairs, rows = self._report()
        if counts.max() > pairs.shape[1]:           # more than there was room for
            self._report = self._capture_report(int(counts.max()))
            counts, pairs, rows = self._report()
        out = []
        for env in range(self._envs):
            found = []
            for k in range(counts[env]):
                row = rows[env, k]
                body, other = self._pair_names(int(pairs[env, k]))
                found.append((int(pairs[env, k]), {
                    'body': body, 'other': other, 'point': row[4:7].copy(),
                    'normal': row[1:4].copy(), 'distance': float(row[0]),
                    'normal_force': float(row[7]), 'friction_force': row[8:11].copy()}))
            out.append([contact for _, contact in sorted(found, key=lambda item: item[0])])
        return out

    def _capture_report(self, room: int):
        """The contact report's replay with ``room`` rows per environment: a function
        returning (counts (envs,), pairs (envs, room), rows (envs, room, REPORT_COLUMNS)
        float64), valid until the next call."""
        arrays = [wp.zeros(self._envs, dtype=int, device=self.device),
                  wp.zeros((self._envs, room), dtype=int, device=self.device),
                  wp.zeros((self._envs, room, REPORT_COLUMNS), dtype=wp.float64,
                           device=self.device)]
        return self._replay(report_kernel(self._k.scalar, self._host.has_body_pairs),
                            self._envs, [self._model, self._state, self._scratch], arrays)

    def _pair_names(self, pair: int) -> tuple[str, str]:
        """(the moving body's name, the other side's: a half-space, a fixed body or a moving
        body) of a contact pair, looked up once per pair."""
        if pair not in self._pair_name_cache:
            gap = pair_gap(vars(self._host), self._read('q')[0], pair)
            other = (self._host.static_names[gap.static] if gap.other is None
                     else self.body_names[gap.other])
            self._pair_name_cache[pair] = (self.body_names[gap.body], other)
        return self._pair_name_cache[pair]

    @property
    def contact_record(self) -> dict | None:
        """In a scene with contact, ``min_distance``: the smallest distance of a body to the
        world (ground and fixed bodies' geometry) at the end of any step since this Stepper
        was made [m] (over every environment, resets included: +inf before a first step), and
        ``most_contacts``: the most contact pairs at once; None without contact."""
        if not self._host.has_contact:
            return None
        return {'min_distance': float(self._read('nearest_seen').min()),
                'most_contacts': int(self._read('most_contacts').max())}

    def _allocate(self):
        k, h, dev, n = self._k, self._host, self.device, self._envs
        sizes = array_sizes(h, n, len(self._chunks), self._near_room)
        self._model = device_model(k, k.structs.Model, h, dev)
        state, control, scratch = (allocate(k, getattr(k.structs, group.capitalize()), group,
                                            sizes, dev)
                                   for group in ('state', 'control', 'scratch'))
        # the step kernel's out-of-line functions take these from one-element arrays
        self._held = held_structs(k, dev, model=self._model, state=state, control=control,
                                  scratch=scratch)
        self._state, self._control, self._scratch = state, control, scratch

        separate = not self.device.is_cpu or self._mirror_on_cpu
        self._uploads = Uploads({'joint_torque': control.joint_torque,
                                 'joint_enabled': control.joint_enabled,
                                 'joint_target': control.joint_target,
                                 'joint_drive_enabled': control.joint_drive_enabled,
                                 'joint_velocity_target': control.joint_velocity_target},
                                separate)
        (self._torque, self._enabled, self._target, self._drive_enabled,
         self._velocity_target) = self._uploads.views.values()
        self._terms, self._terms_at = [], -1
        self._with_torque = [*self._host.active_terms, 'torque']
        # where a non-zero torque is a term of the step: enabled joints on a free body (kept
        # by set_enabled)
        self._torque_mask = np.zeros(self._torque.shape, dtype=bool)
        owner = {name: state if hasattr(state, name) else scratch
                 for names in _OUTPUT_GROUPS.values() for name in names}
        self._downloads = Downloads(dev, {group: {name: getattr(owner[name], name)
                                                  for name in names}
                                          for group, names in _OUTPUT_GROUPS.items()}, separate)
        # _read(name): host view of state output name, current (downloaded on a GPU if it was
        # not); bound once, as every read of an output goes through it
        self._read = self._downloads.read
        state.nearest_seen.fill_(float('inf'))
        self._problems_host = host_copy(state.problem_counts, separate)
        self._problems = self._problems_host.numpy()
        self._problem_totals = np.zeros(len(PROBLEM_COLUMNS), dtype=np.int64)
        self._clamp_totals = np.zeros(len(self._commanded), dtype=np.int64)
        self._warned = set()        # said since the reset: problem kinds, ('clamped', joint)

    def _active_terms(self) -> list[str]:
        """The terms the next step evaluates (``torque`` while some joint on a free body has an
        enabled, non-zero torque), derived again only after the commands were written."""
        if self._terms_at != self._uploads.writes:
            if self._batched:
                torqued = self._torque.any(where=self._torque_mask)
            else:           # one environment's joints: a Python scan costs less than NumPy's
                torqued = any(compress(self._torque[0].tolist(), self._torque_mask[0].tolist()))
            self._terms = self._with_torque if torqued else self._host.active_terms
            self._terms_at = self._uploads.writes
        return list(self._terms)

    def _record(self):
        """Capture the step graphs: without (False) and with (True) the command upload; with
        several CPU threads, one recorded launch per share of the environments instead."""
        args = [self._model, self._state, self._control, self._scratch]
        problems = self._state.problem_counts
        wp.load_module(self._k.step.module, device=self.device)
        self._graphs = {}
        if self._pool is not None:
            self._launches = [wp.launch(self._k.step, dim=count, inputs=[*args, first, chunk],
                                        device=self.device, record_cmd=True)
                              for chunk, (first, count) in enumerate(self._chunks)]
            return
        for upload in (False, True) if self._uploads.separate else (False,):
            with wp.ScopedCapture(device=self.device) as capture:
                if upload:
                    self._uploads.record()
                problems.zero_()
                wp.launch(self._k.step, dim=self._envs, inputs=[*args, 0, 0],
                          device=self.device)
                if self._problems_host is not problems:
                    wp.copy(self._problems_host, problems)
            self._graphs[upload] = capture.graph

    def _check(self, counts):
        """Warn once per kind of problem the last step had (``counts``: environments per
        column; the stats keep the per-step flags; they are read only for the message of a
        kind not warned about yet)."""
        for name, count in zip(PROBLEM_COLUMNS[1:], counts[1:]):
            if count == 0 or name in self._warned:
                continue
            self._warned.add(name)
            residual = (float(self._read('stats_float')[:, 0].max())
                        if name == 'not_converged' else 0.0)
            advice = (self._rejection_advice() if name in ('non_finite', 'angle_aliased')
                      else '')
            self._say(f't = {self.time:.6g} s: ' + _PROBLEMS[name].format(
                max_iter=self.scene.newton_max_iter, residual=residual, advice=advice),
                stacklevel=4)

    def _rejection_advice(self) -> str:
        """What can end rejected steps, from the state: joints beyond their limits (whose push
        grows as 1/dt², so a smaller dt does not help), commands above what a step of dt can
        represent, else a smaller dt or smaller commands."""
        h = self._host
        x = self._read('joint_coordinate')
        beyond = np.maximum(h.joint_limit_lower - x, x - h.joint_limit_upper)
        beyond = np.where(h.joint_limit_strength > 0, beyond, 0.0).max(axis=0)
        names = [j.name for j in self.scene.joints]
        deep = [f'{names[k]} ({beyond[k]:.3g} beyond)' for k in np.flatnonzero(beyond > 1e-3)]
        if deep:
            return ('joints beyond their limits: ' + ', '.join(deep) + '; a limit pushes back '
                    'harder the smaller dt is, so start joints inside their limits '
                    '(initial_positions) or lower the limit strength')
        bounds = largest_step_efforts(h)
        loud = np.abs(np.where(self._enabled != 0, self._torque, 0.0)).max(axis=0) > bounds
        if loud.any():
            return ('commands above what a step of dt can represent (step_effort_bounds): '
                    + ', '.join(names[k] for k in np.flatnonzero(loud))
                    + '; lower them (effort_limit clamps them) or dt')
        far = np.where((self._drive_enabled != 0) & (h.joint_drive_stiffness > 0),
                       np.abs(self._target - x), 0.0).max(axis=0)
        if (far > 0.5).any():
            return ('drives far from their targets: ' + ', '.join(
                f'{names[k]} ({far[k]:.3g} away)' for k in np.flatnonzero(far > 0.5))
                + '; a stiff drive pulls its joint most of the way in one step: move the '
                'target in smaller steps or lower the drive\'s strength_ratio')
        return 'reduce dt or the torques'

    def _store(self, array, rows: np.ndarray) -> None:
        """Store ``rows``, changed from ``array.numpy()`` (a view on the CPU, a copy on a GPU),
        back into ``array``."""
        if not self.device.is_cpu:
            array.assign(rows)

    def _say(self, message: str, stacklevel: int) -> None:
        """Report a problem: to ``on_problem``, else as a SimulationWarning attributed to the
        user's line ``stacklevel`` frames up."""
        if self._on_problem is not None:
            self._on_problem(message)
        else:
            warnings.warn(message, SimulationWarning, stacklevel=stacklevel)

    def _joint(self, name) -> int:
        """Joint ``name``'s index (KeyError naming the valid ones)."""
        k = self._index_of.get(name)
        return self.scene.joint_index(name) if k is None else k

    def _movable(self, name) -> int:
        k = self._joint(name)
        if k not in self._commanded:
            joint = self.scene.joints[k]
            what = (f'a mimic of {joint.mimic.joint!r}' if joint.mimic is not None
                    else joint.type)
            raise ValueError(f'joint {name!r} is {what}: it takes no torque or force')
        return k

    def _per_env(self, name, value, dtype) -> np.ndarray:
        array = np.asarray(value)
        if array.ndim == 0 or (self._batched and array.shape == (self._envs,)):
            return np.broadcast_to(array, (self._envs,)).astype(dtype)
        expected = f'a scalar or shape ({self._envs},)' if self._batched else 'a scalar'
        raise ValueError(f'joint {name!r}: expected {expected}, got shape {array.shape}')

    def _out(self, view) -> np.ndarray:
        """A copy of host view ``view`` (floats as float64), without its env axis unless
        batched."""
        return (view if self._batched else view[0]).astype(
            np.float64 if view.dtype.kind == 'f' else view.dtype)
