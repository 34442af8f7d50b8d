"""Joint commands between steps: latest wins, non-finite values rejected, silent joints time out.

No ROS here: the node hands over decoded values and logs what comes back. A command taken
before step n is computed applies to step n (the step from sim time t to t + dt).
"""

import math

import numpy as np

__all__ = ['CommandBuffer']

_TIME_EPS = 1e-9    # [s]: sim times are step counts × dt, so 0.8 - 0.6 must not exceed 0.2


class CommandBuffer:
    """Pending torques, enables and drive targets for the next step, and the command timeout.

    Args:
        joint_names: the joints that take commands (the scene's moving joints), in order.
        command_timeout: seconds of simulated time [s] after a joint's last torque command
            at which its torque falls to 0; 0 holds the last command forever.
        array_joints: the joints of ``effort_commands``/``position_commands`` arrays, in
            order (ros2_control's ``joints`` of a group controller); default ``joint_names``.
        drive_joints: the joints that have a drive (take a position command).
        damped_joints: the joints with damping (take a velocity command).
        effort_bounds: per joint of ``joint_names``, the largest |torque| [N·m] or |force| [N]
            a step can represent (Stepper.step_effort_bounds); larger commands are clamped to
            it, with a notice.
        enabled: per joint of ``joint_names``, whether its torque is on at the start (the
            scene's); a torque sent to a disabled joint is said once (it acts only once the
            joint is enabled).
        mimics: each mimic joint's leader, by name: a command to a mimic joint is dropped
            with that reason (it follows its leader).
        prefix: what the scene's names of these joints start with (one robot of several:
            ``<robot>/``): commands name them without it, the stepper with it.
        scene_index: the scene indices of ``joint_names`` (to read their torques on a reset).
    """

    def __init__(self, joint_names: list[str], command_timeout: float = 0.0,
                 array_joints: list[str] | None = None, drive_joints=(), effort_bounds=None,
                 enabled=None, damped_joints=(), mimics=None, prefix: str = '',
                 scene_index=None):
        self.joint_names = list(joint_names)
        self.prefix = prefix
        self.scene_index = scene_index
        self.mimics = dict(mimics or {})
        self._index = {name: k for k, name in enumerate(self.joint_names)}
        self.command_timeout = command_timeout
        self.array_joints = list(array_joints or joint_names)
        self.drive_joints = set(drive_joints)
        self.damped_joints = set(damped_joints)
        self.effort_bounds = [math.inf] * len(self.joint_names) if effort_bounds is None \
            else [float(b) for b in effort_bounds]
        self._no_drive_said: set[str] = set()
        self._no_damping_said: set[str] = set()
        self._initially_enabled = [True] * len(self.joint_names) if enabled is None \
            else [bool(e) for e in enabled]
        self.reset([0.0] * len(self.joint_names))

    @classmethod
    def for_stepper(cls, sim, command_timeout: float = 0.0,
                    array_joints: list[str] | None = None, robot=None) -> 'CommandBuffer':
        """The buffer of a Stepper's command joints (``robot``: those of that ``scene.Robot``,
        named as in its URDF; None: those outside the scene's robots), with its drives and its
        step bounds (none for a joint whose effort_limit is within its bound: the stepper
        clamps every command to that limit, as ros2_control and Gazebo do, so none is too
        large)."""
        scene = sim.scene
        prefix = '' if robot is None else robot.prefix
        index = np.array([k for k in sim.command_joint_index
                          if scene.robot_of(scene.joints[k].name) == robot], dtype=np.intp)
        bounds = sim.step_effort_bounds[index]
        limits = np.array([scene.joints[k].effort_limit for k in index])

        def own(names):
            return [n[len(prefix):] for n in names if scene.robot_of(n) == robot]

        return cls(own(scene.joints[k].name for k in index), command_timeout,
                   array_joints=array_joints, drive_joints=own(sim.drive_joint_names),
                   effort_bounds=np.where(limits <= bounds, np.inf, bounds),
                   enabled=[scene.joints[k].enabled for k in index],
                   damped_joints=own(sim.damped_joint_names),
                   mimics={n[len(prefix):]: j.mimic.joint[len(prefix):]
                           for j in scene.joints if j.mimic
                           for n in own([j.name])},
                   prefix=prefix, scene_index=index)

    def reset(self, torques, sim_time: float = 0.0) -> None:
        """Forget pending commands; ``torques`` [N·m] (the scene's) count as commanded at
        ``sim_time`` [s]."""
        self._torque: dict[int, float] = {}
        self._enabled: dict[int, bool] = {}
        self._target: dict[str, float] = {}
        self._speed: dict[str, float] = {}
        self._last_command = [sim_time] * len(self.joint_names)
        self._held = [float(t) != 0.0 for t in torques]     # a non-zero torque that can time out
        self._on = list(self._initially_enabled)             # each joint's torque switch, as set
        self._disabled_said: set[int] = set()

    def torque(self, joint: str, value: float) -> str | None:
        """Queue torque ``value`` [N·m] (force [N] for a prismatic joint) for ``joint``;
        returns why it was rejected, or None."""
        k = self._index.get(joint)
        if k is None:
            return self._unknown(joint)
        if not math.isfinite(value):
            return f'torque {value!r} for joint {joint!r} is not finite: dropped'
        problem = None
        if abs(value) > self.effort_bounds[k]:
            bound = self.effort_bounds[k]
            problem = (f'torque/force {value:g} for joint {joint!r} is beyond what one step can '
                       f'represent (|value| <= {bound:.4g}: more would turn or throw its body '
                       'further than the step can follow): clamped to it')
            value = math.copysign(bound, value)
        elif not self._enabled.get(k, self._on[k]) and k not in self._disabled_said:
            self._disabled_said.add(k)
            problem = (f'joint {joint!r} is disabled (its torque switch is off): its torques '
                       'have no effect until it is enabled (said once)')
        self._torque[k] = float(value)
        return problem

    def _unknown(self, joint: str) -> str:
        """Why a command to ``joint``, not one of joint_names, is dropped."""
        if joint in self.mimics:
            return (f'joint {joint!r} mimics {self.mimics[joint]!r}: it follows it and takes no '
                    'command (dropped)')
        return f'unknown joint {joint!r} (joints: {", ".join(self.joint_names)})'

    def enable(self, joint: str, flag: bool) -> str | None:
        """Queue the enable flag of ``joint``'s torque; returns why it was rejected, or None."""
        k = self._index.get(joint)
        if k is None:
            return self._unknown(joint)
        self._enabled[k] = bool(flag)
        return None

    def malformed(self, key: str, msg) -> str | None:
        """Why a whole command message on topic ``key`` is unusable (its arrays' lengths do
        not match), or None. Such a message is dropped whole: it commands and answers nothing.
        A ``joint_commands`` JointState's position, velocity and effort arrays are each empty
        (not this interface) or as long as its names."""
        if key == 'joint_commands':
            for field, what in (('position', 'positions'), ('velocity', 'velocities'),
                                ('effort', 'efforts')):
                values = getattr(msg, field)
                if len(values) and len(values) != len(msg.name):
                    return f'{len(msg.name)} names but {len(values)} {what}: message dropped'
        if key in ('effort_commands', 'position_commands') \
                and len(msg.data) != len(self.array_joints):
            what = 'efforts' if key == 'effort_commands' else 'positions'
            return (f'{len(msg.data)} {what} but command_joints has {len(self.array_joints)} '
                    f'({", ".join(self.array_joints)}): message dropped')
        return None

    def joint_commands(self, names, efforts=(), positions=(), velocities=()) -> list[str]:
        """Queue a ``joint_commands`` message, as ros2_control's topic hardware interface sends
        it: ``name[i]`` gets ``effort[i]`` (a torque [N·m] or force [N]), ``position[i]``
        (its drive's target [rad | m]) and ``velocity[i]`` (the speed [rad/s | m/s] its
        damping pulls toward) where those arrays are not empty (the lengths checked by
        ``malformed``); a NaN entry leaves that command as it is.

        Entries with an unknown name, an infinite value, a position for a joint without a
        drive or a velocity for one without damping are dropped, the rest applied; returns
        the reasons for the dropped ones.
        """
        problems = []
        for i, name in enumerate(names):
            if name not in self._index:
                problems.append(self._unknown(name))
                continue
            if len(efforts) and not math.isnan(efforts[i]):
                problems.append(self.torque(name, efforts[i]))
            if len(positions) and not math.isnan(positions[i]):
                problems.append(self.position(name, positions[i]))
            if len(velocities) and not math.isnan(velocities[i]):
                problems.append(self.velocity(name, velocities[i]))
        return [p for p in problems if p is not None]

    def velocity(self, joint: str, value: float) -> str | None:
        """Queue the speed ``value`` [rad/s | m/s] ``joint``'s damping pulls toward; returns
        why it was dropped (no damping: said once per joint; not finite), or None."""
        return self._queue(joint, value, self.damped_joints, self._no_damping_said,
                           self._speed, 'velocity', 'has no damping: its velocity commands are '
                           'ignored (said once; its damping is the velocity drive\'s gain)')

    def position(self, joint: str, value: float) -> str | None:
        """Queue drive target ``value`` [rad | m] for ``joint``; returns why it was dropped
        (no drive: said once per joint; not finite), or None."""
        return self._queue(joint, value, self.drive_joints, self._no_drive_said, self._target,
                           'position', 'has no drive: its position commands are ignored (said '
                           'once)')

    @staticmethod
    def _queue(joint: str, value: float, able: set, said: set, pending: dict, what: str,
               refusal: str) -> str | None:
        """``pending[joint]`` = ``value`` for a joint of ``able``; returns why it was dropped:
        not one of ``able`` (``refusal``, said once per joint: ``said``) or not finite; or
        None."""
        if joint not in able:
            if joint in said:
                return None
            said.add(joint)
            return f'joint {joint!r} {refusal}'
        if not math.isfinite(value):
            return f'{what} {value!r} for joint {joint!r} is not finite: dropped'
        pending[joint] = float(value)
        return None

    def effort_array(self, values) -> list[str]:
        """Queue an ``effort_commands`` array: ``values[i]`` [N·m | N] for
        ``array_joints[i]`` (the length checked by ``malformed``); returns the reasons for
        what was dropped."""
        problems = [self.torque(name, v) for name, v in zip(self.array_joints, values)]
        return [p for p in problems if p is not None]

    def position_array(self, values) -> list[str]:
        """Queue a ``position_commands`` array: drive targets [rad | m] for the joints of
        ``array_joints`` that have a drive (the others are said once); returns the reasons
        for what was dropped (the length checked by ``malformed``)."""
        problems = [self.position(name, value) for name, value in zip(self.array_joints, values)]
        return [p for p in problems if p is not None]

    def take(self, key: str, joint: str | None, msg) -> list[str]:
        """Queue a command message as it arrived on the topic ``key`` of topics.yaml
        (``joint_torque`` / ``joint_enable``, ``joint_force`` / ``joint_force_enable`` for
        ``joint``, ``joint_commands``, ``effort_commands`` or ``position_commands``); returns
        the reasons for what was dropped. The node and the bag replay both feed commands
        here."""
        problem = self.malformed(key, msg)
        if problem is not None:
            return [problem]
        if key == 'joint_commands':
            return self.joint_commands(list(msg.name), list(msg.effort), list(msg.position),
                                       list(msg.velocity))
        if key == 'effort_commands':
            return self.effort_array(list(msg.data))
        if key == 'position_commands':
            return self.position_array(list(msg.data))
        queue = self.torque if key in ('joint_torque', 'joint_force') else self.enable
        problem = queue(joint, msg.data)
        return [] if problem is None else [problem]

    def apply(self, stepper, sim_time: float) -> list[str]:
        """Write the queued commands into ``stepper`` for the step starting at ``sim_time`` [s].

        Returns one notice per joint whose torque just timed out (said once per silence).
        """
        prefix = self.prefix
        if (len(self._torque) == len(self.joint_names)      # a whole array: one call
                and not prefix
                and getattr(stepper, 'command_joint_names', None) == self.joint_names):
            stepper.set_torques(np.array([self._torque[k] for k in range(len(self._torque))]))
        else:
            for k, value in self._torque.items():
                stepper.set_torque(prefix + self.joint_names[k], value)
        for k, value in self._torque.items():
            self._last_command[k] = sim_time
            self._held[k] = value != 0.0
        for k, flag in self._enabled.items():
            stepper.set_enabled(prefix + self.joint_names[k], flag)
            self._on[k] = flag
            if flag:
                self._disabled_said.discard(k)
        for name, target in self._target.items():
            stepper.set_target(prefix + name, target)
        for name, speed in self._speed.items():
            stepper.set_velocity_target(prefix + name, speed)
        self._torque.clear()
        self._enabled.clear()
        self._target.clear()
        self._speed.clear()
        if self.command_timeout <= 0.0:
            return []
        notices = []
        for k, name in enumerate(self.joint_names):
            silent = sim_time - self._last_command[k]
            if self._held[k] and silent > self.command_timeout + _TIME_EPS:
                self._held[k] = False
                stepper.set_torque(prefix + name, 0.0)
                notices.append(f'joint {name!r}: no torque command for {silent:.3f} s '
                               f'(command_timeout {self.command_timeout} s): torque set to 0')
        return notices
