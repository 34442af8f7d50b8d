"""The ``affine_joint_sim`` node: the Stepper behind ROS 2 topics and services (design.md §4).

Two threads: an executor thread runs the subscription, service and parameter callbacks; the
main thread steps. They share one lock, so a command whose callback ran before step n is
computed applies to step n, and a service never lands in the middle of a step. Each step
publishes ``joint_states`` (and ``/clock``) stamped with the step counter's simulated time.
(Running the callbacks between steps in one thread would cost ~0.2 ms per step: rclpy builds
its wait set in Python.) The node does no physics itself.

    python -m affine_joint_sim.ros.node --ros-args --params-file msg_configs/node_params.yaml
"""

import sys
import threading
import time
import warnings

import rclpy
from rclpy.duration import Duration
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.executors import (ExternalShutdownException, ShutdownException,
                             SingleThreadedExecutor)
from rclpy.node import Node
from rclpy.parameter import Parameter
from rcl_interfaces.msg import SetParametersResult
from std_srvs.srv import SetBool, Trigger

from affine_joint_sim.resources import scene_path
from affine_joint_sim.ros.commands import CommandBuffer
from affine_joint_sim.ros.pacing import Pacer
from affine_joint_sim.ros.parameters import PARAMETERS, ConfigError, check
from affine_joint_sim.ros.topics import load_topics
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import SimulationWarning, Stepper

__all__ = ['SimNode', 'main']

NODE_NAME = 'affine_joint_sim'
_WARN_EVERY = 2.0       # wall seconds between two warnings about the same topic
_RATE_WINDOW = 5.0      # wall seconds over which the realtime factor is checked


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
            self.scene = Scene.from_yaml(scene_path(self.config['scene']))
        except FileNotFoundError as exc:
            raise ConfigError(f"parameter 'scene': {exc}") from None
        try:
            self.sim = Stepper(self.scene, device=self.config['device'])
        except (ValueError, RuntimeError) as exc:
            raise ConfigError(f"parameter 'device': {exc}") from None
        self.commands = CommandBuffer(self.sim.joint_names, self.config['command_timeout'])
        self.pacer = Pacer(self.config['real_time_factor'])
        self.topics = load_topics()
        self.paused = False
        self._released = False          # lockstep: a joint_commands message came since last step
        self._wake = threading.Condition()     # guards everything below; notified by callbacks
        self._dt_ns = round(self.scene.dt * 1e9)
        self._last_warning: dict[str, float] = {}
        self._previous_showwarning = warnings.showwarning
        warnings.showwarning = self._log_simulation_warning
        self._make_interfaces()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._started = (time.monotonic(), 0)
        self.get_logger().info(
            f'scene {self.scene.name!r} ({len(self.sim.body_names)} bodies, joints '
            f'{", ".join(self.sim.joint_names)}), dt {self.scene.dt} s, device '
            f'{self.sim.device}, mode {self.config["mode"]}')

    # ---- setup ------------------------------------------------------------------------------

    def _declare_parameters(self) -> dict:
        config = {}
        for name, spec in PARAMETERS.items():
            try:
                value = self.declare_parameter(name, spec.default).value
            except InvalidParameterTypeException as exc:
                raise ConfigError(f'parameter {name!r}: expected a '
                                  f'{type(spec.default).__name__} ({exc})') from None
            check(name, value)
            config[name] = value
        return config

    def _make_interfaces(self):
        t = self.topics
        self.state_pub = self.create_publisher(t['joint_states'].msg_class,
                                               t['joint_states'].name(), t['joint_states'].qos)
        self.clock_pub = self.create_publisher(t['clock'].msg_class, t['clock'].name(),
                                               t['clock'].qos)
        self._state_msg = t['joint_states'].msg_class()
        self._state_msg.name = self.sim.joint_names
        self._clock_msg = t['clock'].msg_class()
        # Latched: the scene as run, every default spelled out, for late joiners and bags.
        self.scene_pub = self.create_publisher(t['scene'].msg_class, t['scene'].name(),
                                               t['scene'].qos)
        self.scene_pub.publish(t['scene'].msg_class(data=self.scene.to_yaml()))
        for joint in self.sim.joint_names:
            self._subscribe('joint_torque', joint, self._on_torque)
            self._subscribe('joint_enable', joint, self._on_enable)
        self._subscribe('joint_commands', None, self._on_joint_commands)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)

    def _subscribe(self, key, joint, handler):
        topic = self.topics[key]
        name = topic.name(joint)
        self.create_subscription(topic.msg_class, name,
                                 lambda msg: handler(msg, name, joint), topic.qos)

    # ---- commands ---------------------------------------------------------------------------

    def _on_torque(self, msg, topic, joint):
        with self._wake:
            self._reject(topic, self.commands.torque(joint, msg.data))

    def _on_enable(self, msg, topic, joint):
        with self._wake:
            self.commands.enable(joint, msg.data)

    def _on_joint_commands(self, msg, topic, _):
        with self._wake:
            for problem in self.commands.joint_commands(list(msg.name), list(msg.effort)):
                self._reject(topic, problem)
            self._released = True
            self._wake.notify()

    def _reject(self, topic, problem):
        """Warn about a dropped command, at most once per ``_WARN_EVERY`` s per topic."""
        if problem is None:
            return
        now = time.monotonic()
        if now - self._last_warning.get(topic, -_WARN_EVERY) >= _WARN_EVERY:
            self._last_warning[topic] = now
            self.get_logger().warning(f'{self.resolve_topic_name(topic)}: {problem}')

    def _log_simulation_warning(self, message, category, *args, **kwargs):
        if issubclass(category, SimulationWarning):
            self.get_logger().warning(str(message))
        else:
            self._previous_showwarning(message, category, *args, **kwargs)

    # ---- services ---------------------------------------------------------------------------

    def _on_reset(self, request, response):
        with self._wake:
            self.reset()
            self._wake.notify()
        response.success, response.message = True, 'reset to the initial state, t = 0'
        return response

    def _on_pause(self, request, response):
        with self._wake:
            self.paused = request.data
            if not self.paused:
                self.pacer.anchor(self.sim.time)
                self.pacer.restart_window(self.sim.time)
            self._wake.notify()
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at t = {self.sim.time:g} s'
        return response

    def _on_step(self, request, response):
        if not self.paused:
            response.success, response.message = False, 'not paused: call ~/pause first'
            return response
        with self._wake:
            self.step()
        response.success = True
        response.message = f'step {self.sim.step_count}, t = {self.sim.time:.6f} s'
        return response

    def _on_set_parameters(self, parameters):
        for p in parameters:
            spec = PARAMETERS.get(p.name)
            if spec is None:
                continue
            if not spec.live:
                return SetParametersResult(successful=False,
                                           reason=f'{p.name} is fixed while the node runs')
            try:
                check(p.name, p.value)
            except ConfigError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        with self._wake:
            for p in parameters:
                if p.name in PARAMETERS:
                    self.config[p.name] = p.value
            self.commands.command_timeout = self.config['command_timeout']
            self.pacer.real_time_factor = self.config['real_time_factor']
            self.pacer.anchor(self.sim.time)
            self._wake.notify()
        return SetParametersResult(successful=True)

    # ---- stepping ---------------------------------------------------------------------------

    @property
    def sim_time_ns(self) -> int:
        """Simulated time of the current state [ns], from the step counter."""
        return self.sim.step_count * self._dt_ns

    def reset(self):
        """Back to the scene's initial state at t = 0; publishes that state."""
        self.sim.reset()
        self.commands.reset(self.sim.torques)
        self._released = False
        self.pacer.anchor(0.0)
        self.pacer.restart_window(0.0)
        self._started = (time.monotonic(), 0)
        self.publish_state()

    def step(self):
        """Apply the queued commands, advance one dt, publish the new state."""
        for notice in self.commands.apply(self.sim, self.sim.time):
            self.get_logger().warning(notice)
        self.sim.step()
        self._released = False
        self.publish_state()

    def publish_state(self):
        """Publish joint_states (and /clock) for the current step."""
        sec, nanosec = divmod(self.sim_time_ns, 1_000_000_000)
        msg = self._state_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
        msg.position = self.sim.angles.tobytes()
        msg.velocity = self.sim.velocities.tobytes()
        msg.effort = self.sim.efforts.tobytes()
        self.state_pub.publish(msg)
        if self.config['publish_clock']:
            self._clock_msg.clock.sec, self._clock_msg.clock.nanosec = sec, nanosec
            self.clock_pub.publish(self._clock_msg)

    def _wait_before_step(self) -> float:
        """Wall seconds until the next step is due (inf while paused or awaiting lockstep)."""
        mode = self.config['mode']
        if self.paused or (mode == 'lockstep' and not self._released):
            return float('inf')
        if mode == 'realtime':
            return self.pacer.wait(self.sim.time + self.scene.dt)
        return 0.0

    def _finished(self) -> bool:
        duration = self.config['duration']
        return duration > 0.0 and self.sim.step_count >= round(duration / self.scene.dt)

    def _check_rate(self):
        now = time.monotonic()
        if now - self._window_start < _RATE_WINDOW:
            return
        self._window_start = now
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
        with self._wake:
            self.reset()
        self._window_start = time.monotonic()
        spinner.start()
        try:
            while self.context.ok() and not failure and not self._finished():
                with self._wake:
                    wait = self._wait_before_step()
                    if wait > 0.0:
                        self._wake.wait(min(wait, 0.1))
                        continue
                    self.step()
                self._check_rate()
        finally:
            executor.shutdown(timeout_sec=1.0)
            spinner.join(timeout=1.0)
        if failure:
            raise failure[0]
        if not self.context.ok():
            raise ExternalShutdownException()
        # A run that ends by itself delivers its last state before the node goes.
        self.state_pub.wait_for_all_acked(Duration(seconds=1.0))

    def summary(self) -> dict:
        """Figures of the run since the last reset: steps, wall time, steps/s, real-time factor."""
        wall = time.monotonic() - self._started[0]
        steps = self.sim.step_count - self._started[1]
        return {'steps': steps, 'sim_time': self.sim.time, 'wall_time': wall,
                'steps_per_second': steps / wall if wall > 0 else 0.0,
                'real_time_factor': self.sim.time / wall if wall > 0 else 0.0,
                'fell_behind': self.pacer.fell_behind, 'mode': self.config['mode'],
                'angles': dict(zip(self.sim.joint_names, self.sim.angles.tolist()))}

    def destroy_node(self):
        warnings.showwarning = self._previous_showwarning
        return super().destroy_node()


def main(args=None, parameter_overrides=None) -> int:
    """Run the node until ``duration`` or SIGINT/SIGTERM; print the run's summary on stdout.

    Returns the exit status: 0, or 2 for an invalid parameter or scene (one line on stderr).
    """
    import warp as wp

    wp.config.quiet = True      # the node reports through ROS logging and its summary
    rclpy.init(args=args)
    node = None
    try:
        node = SimNode(parameter_overrides=parameter_overrides)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        node.run(executor)
    except (ConfigError, SceneError) as exc:
        print(f'affine-joint-sim: error: {exc}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            print_summary(node.summary())
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def print_summary(summary: dict) -> None:
    """The run's figures, for people (stdout)."""
    print(f'{summary["steps"]} steps, {summary["sim_time"]:.3f} s simulated in '
          f'{summary["wall_time"]:.3f} s wall ({summary["mode"]}): '
          f'{summary["steps_per_second"]:.0f} steps/s, real-time factor '
          f'{summary["real_time_factor"]:.3g}')
    print('final angles [rad]: ' + ', '.join(f'{k} {v:.6f}'
                                              for k, v in summary['angles'].items()))
    sys.stdout.flush()


if __name__ == '__main__':
    sys.exit(main(sys.argv))
