"""A controller written the usual way: a volatile ``joint_states`` subscription (depth 10) and
a ``joint_commands`` publisher that answers each state once (again if the node publishes it
again a second later or more: its answer was lost), stamped with the state's stamp
(``--unstamped``: no stamp). ``--every``: the plainest controller, answering every message it
receives, a copy of a state it answered too. ``--first-answer-after S``: its first answer goes
out S seconds after the state came (a controller still warming up on a loaded machine). Its
torque is a PD law on one joint. Runs until interrupted.

    python plain_controller.py JOINT TARGET [--unstamped] [--every] [--first-answer-after S]
        [--name NODE] [--namespace NS]
"""

import argparse
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from sensor_msgs.msg import JointState

REANSWER_AFTER = 1.0     # s after which a state published again is answered again


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('joint')
    parser.add_argument('target', type=float, help='target angle [rad]')
    parser.add_argument('--unstamped', action='store_true')
    parser.add_argument('--every', action='store_true', help='answer every message received')
    parser.add_argument('--first-answer-after', type=float, default=0.0, metavar='S',
                        help='wall seconds [s] to wait before the first answer')
    parser.add_argument('--name', default='plain_controller')
    parser.add_argument('--namespace', default='', help="the robot's (its topics under it)")
    args = parser.parse_args(argv)
    rclpy.init()
    node = rclpy.create_node(args.name, namespace=args.namespace)
    publisher = node.create_publisher(JointState, 'joint_commands', 10)
    answered = {}                      # stamp -> when it was answered (monotonic s)

    def on_state(msg):
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        now = time.monotonic()
        # a state published again soon after: answered already (another controller joined);
        # the node's fallback copy, 2 s after it went out, means the answer was lost (sent
        # before the node's subscription matched this publisher): answer again
        if not args.every and stamp in answered and now - answered[stamp] < REANSWER_AFTER:
            return
        if not answered:
            time.sleep(args.first_answer_after)
        answered[stamp] = now
        k = list(msg.name).index(args.joint)
        tau = 20.0 * (args.target - msg.position[k]) - 2.0 * msg.velocity[k]
        command = JointState(name=[args.joint], effort=[tau])
        if not args.unstamped:
            command.header.stamp = msg.header.stamp
        publisher.publish(command)

    node.create_subscription(JointState, 'joint_states', on_state, 10)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
