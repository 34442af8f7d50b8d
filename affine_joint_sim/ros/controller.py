"""A demo PD controller in its own process: joint targets → torques over ``joint_commands``.

On every ``joint_states`` message it answers with one command, the torques τ = kp (θ* − θ) − kd
ω for the joints it has targets for, so against a ``lockstep`` node the closed loop is
deterministic. The targets are fixed, or follow a control script's keyframes in the state's
simulated time, each joint with the script's gains (``control_script``). It answers each state
once: a copy of the state it has just answered (the node publishes a waiting state again for a
controller that joins, or after 2 s without answers, and a busy process can find the original
and a copy queued together) is skipped: the node counts a second answer once, but an unstamped
one (an array) that arrives after the step would answer the node's next state. The command
goes out on ``joint_commands`` (a JointState: names and efforts, stamped with the state it
answers) or, as ros2_control's JointGroupEffortController does, on ``effort_commands`` (a
Float64MultiArray: one effort per joint of ``joint_states``, 0 for joints without a target; the
node's ``command_joints`` default has that order). Being PD (no gravity model, no integral
term), it settles ``m g l sin θ* / kp`` short of a target held against gravity.
"""

import time

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node

from affine_joint_sim.control_script import ControlScript, pd_torques
from affine_joint_sim.ros.topics import load_topics

__all__ = ['PDController', 'main', 'DUPLICATE_WINDOW']

# A state with the stamp just answered, received less than this long after the answer [s,
# wall], is a copy of it. Shorter than the node's 2 s republish interval: a state still
# waiting after that (a lost answer, or the same stamp again after a reset) is answered.
DUPLICATE_WINDOW = 0.1


class PDController(Node):
    """PD control of some joints of the simulator node.

    Args:
        targets: target angle per joint [rad] (ignored when ``script`` is given).
        kp: proportional gain [N·m/rad].
        kd: derivative gain [N·m·s/rad].
        effort_limit: largest |τ| sent [N·m].
        clock: wall clock in seconds (monotonic); injectable for tests.
        script: a ControlScript whose targets and gains replace ``targets``, ``kp``, ``kd``.
        **node_kwargs: passed to ``rclpy.node.Node`` (``namespace=``, ``context=``).
    """

    def __init__(self, targets: dict[str, float] | None = None, kp: float = 100.0,
                 kd: float = 10.0, effort_limit: float = np.inf,
                 interface: str = 'joint_commands', clock=time.monotonic,
                 script: ControlScript | None = None, **node_kwargs):
        super().__init__('pd_controller', **node_kwargs)
        self.script = script or ControlScript.hold(targets, kp, kd)
        self.scripted = script is not None
        self.targets = dict.fromkeys(self.script.joints, 0.0)     # the last state's targets
        self.effort_limit = effort_limit
        self.interface = interface
        topics = load_topics()
        commands = topics[interface]
        states = topics['joint_states']
        self.publisher = self.create_publisher(commands.msg_class, commands.name(), commands.qos)
        self.create_subscription(states.msg_class, states.name(), self._on_state, states.qos)
        self._command = commands.msg_class()
        if interface == 'joint_commands':
            self._command.name = list(self.targets)
        self.last_state = None
        self.states_received = 0
        self.copies_skipped = 0
        self._clock = clock
        self._answered = (None, -np.inf)      # (stamp, wall time) of the last answer

    def _on_state(self, msg):
        stamp, now = (msg.header.stamp.sec, msg.header.stamp.nanosec), self._clock()
        if stamp == self._answered[0] and now - self._answered[1] < DUPLICATE_WINDOW:
            self.copies_skipped += 1
            return
        index = {name: i for i, name in enumerate(msg.name)}
        missing = [j for j in self.targets if j not in index]
        if missing:
            self.get_logger().error(f'joints {missing} are not in joint_states ({list(msg.name)})',
                                    throttle_duration_sec=5.0)
            return
        rows = [index[j] for j in self.targets]
        target = self.script.targets_at(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
        self.targets = dict(zip(self.targets, target.tolist()))
        tau = pd_torques(self.script.kp, self.script.kd, target, np.asarray(msg.position)[rows],
                         np.asarray(msg.velocity)[rows], self.effort_limit)
        if self.interface == 'joint_commands':
            self._command.header.stamp = msg.header.stamp
            self._command.effort = tau.tobytes()
        else:
            efforts = np.zeros(len(msg.name))
            efforts[rows] = tau
            self._command.data = efforts.tobytes()
        self.publisher.publish(self._command)
        self._answered = (stamp, now)
        self.last_state = msg
        self.states_received += 1

    def report(self) -> str:
        """Final angles against targets, for people."""
        if self.last_state is None:
            return 'PD controller: no joint_states received'
        msg = self.last_state
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        width = max([12, *map(len, self.targets)])    # the joint column fits every name
        copies = (f' ({self.copies_skipped} copies of an answered state skipped)'
                  if self.copies_skipped else '')
        gains = ('scripted targets and gains' if self.scripted else
                 f'kp {self.script.kp[0]:g}, kd {self.script.kd[0]:g}')
        lines = [f'PD controller ({gains}): {self.states_received} states '
                 f'answered{copies}, last at t = {t:.3f} s',
                 f'{"joint":<{width}} {"target [rad]":>13} {"final [rad]":>13} '
                 f'{"error [rad]":>13}']
        for joint, target in self.targets.items():
            angle = msg.position[list(msg.name).index(joint)]
            lines.append(f'{joint:<{width}} {target:13.6f} {angle:13.6f} {angle - target:13.6f}')
        return '\n'.join(lines)


def main(targets: dict[str, float], kp: float, kd: float, effort_limit: float = np.inf,
         namespace: str = '', args=None, interface: str = 'joint_commands',
         script: str | None = None) -> int:
    """Run the controller until SIGINT/SIGTERM, then print its report on stdout; ``script``:
    a control script's file or packaged name, run instead of ``targets``."""
    loaded = ControlScript.load(script) if script is not None else None
    rclpy.init(args=args)
    node = PDController(targets, kp, kd, effort_limit, interface=interface,
                        namespace=namespace, script=loaded)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except _rclpy.RCLError:         # a publish that raced with SIGINT/SIGTERM
        if rclpy.ok():
            raise
    finally:
        print(node.report(), flush=True)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
