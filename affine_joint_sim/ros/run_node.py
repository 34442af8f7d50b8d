"""The node's process: ROS initialisation, signals, exit status and the run's summary.

    python -m affine_joint_sim.ros.run_node --ros-args --params-file msg_configs/node_params.yaml
"""

import signal
import sys
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.signals import SignalHandlerOptions

from affine_joint_sim.quiet_warp import quiet_warp
from affine_joint_sim.ros.node import SimNode
from affine_joint_sim.ros.parameters import ConfigError
from affine_joint_sim.scene import SceneError

__all__ = ['main', 'print_summary']


def main(args=None, parameter_overrides=None) -> int:
    """Run the node until ``duration`` or SIGINT/SIGTERM; print the run's summary on stdout.

    The signals are this function's, not rclpy's: rclpy's handlers shut the context down at
    once, under the executor thread and the bag writer, which now and then crashed with a
    segfault at exit (docs/architecture.md#measured-figures). Here a signal only asks the
    stepping loop to stop; the executor, the bag, the node and then the context are closed in
    that order. (A signal while the node is still being built interrupts the build.)

    Returns the exit status: 0, or 2 for an invalid parameter or scene (one line on stderr).
    """
    quiet_warp()                 # the node reports through ROS logging and its summary
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except _rclpy.UnknownROSArgsError as exc:
        print(f'affine-joint-sim: error: unknown ROS arguments: {exc}', file=sys.stderr)
        return 2
    except _rclpy.RCLError as exc:
        print(f'affine-joint-sim: error: ROS arguments: {exc}', file=sys.stderr)
        return 2
    node = None

    def on_signal(signum, frame):
        if node is None:
            raise KeyboardInterrupt
        node.stop_requested.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
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
            node.close_bag()
            print_summary(node.summary())
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0


def print_summary(summary: dict) -> None:
    """The run's figures, for people (stdout)."""
    print(f'{summary["steps"]} steps, {summary["sim_time"]:.3f} s simulated in '
          f'{summary["wall_time"]:.3f} s wall ({summary["mode"]}): '
          f'{summary["steps_per_second"]:.0f} steps/s, real-time factor '
          f'{summary["real_time_factor"]:.3g}')
    print('final angles [rad]: ' + ', '.join(f'{k} {v:.6f}'
                                              for k, v in summary['angles'].items()))
    dropped = {k: v for k, v in summary['dropped'].items() if v}
    surplus, repeated = summary['surplus_answers'], summary['repeated_answers']
    print(f'commands taken: {summary["taken"]}' + (
        '; dropped: ' + ', '.join(f'{v} {k}' for k, v in dropped.items()) if dropped else '') + (
        f'; {surplus} lockstep answers beyond lockstep_publishers (applied to the state they '
        'answered, not to the next)' if surplus else '') + (
        f'; {repeated} lockstep answers repeated for the same joints (applied, counted once)'
        if repeated else ''))
    problems = summary['problems']
    rejected = max(problems['non_finite'], problems['angle_aliased'])   # a step may have both
    if rejected or problems['not_converged']:
        print(f'steps not converged: {problems["not_converged"]}; steps rejected: '
              f'{problems["non_finite"]} non-finite, {problems["angle_aliased"]} with a joint '
              'turning over 0.9π' + (': every step was rejected, nothing moved'
                                     if rejected >= summary['steps'] > 0 else ''))
    print(f'largest ‖AAᵀ − I‖ of a moving body at the end: {summary["rotation_strain"]:.2g} '
          '(stats rotation_strain; viewers draw the nearest rotation)')
    collected = summary['garbage_collection']
    print(f'garbage collections while stepping: {collected["collections"]} '
          f'({collected["full"]} full), longest {collected["longest"] * 1e3:.2f} ms; '
          f'{collected["frozen"]:,} set-up objects frozen out of them')
    contact = summary.get('contact')
    if contact is not None:
        print(f'contact: smallest distance to the world {contact["min_distance"]:.3g} m, at '
              f'most {contact["most_contacts"]} contacts at once')
    if summary['bag']:
        stopped = summary['recording_stopped']
        print(f'bag: {Path(summary["bag"]).resolve()}' +
              (f' (recording stopped early: {stopped})' if stopped else ''))
    sys.stdout.flush()


if __name__ == '__main__':
    sys.exit(main(sys.argv))
