"""A controller written the usual way: a volatile ``joint_states`` subscription (depth 10) and
a ``joint_commands`` publisher that answers each state once (again if the node publishes it
again a second later: its answer was lost), stamped with the state's stamp (``--unstamped``:
no stamp). Its torque is a PD law on one joint. Runs until interrupted. Answering every copy
would not do: the first state is stamped 0, which reads as unstamped, so a copy of it
answered late would count for the next state (the two-controller runs then differed).

    python plain_controller.py JOINT TARGET [--unstamped] [--name NODE]
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
    parser.add_argument('--name', default='plain_controller')
    args = parser.parse_args(argv)
    rclpy.init()
    node = rclpy.create_node(args.name)
    publisher = node.create_publisher(JointState, 'joint_commands', 10)
    answered = {}                      # stamp -> when it was answered (monotonic s)

    def on_state(msg):
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        now = time.monotonic()
        # a state published again soon after: answered already; a second later the node is
        # still waiting for it, so the answer was lost (sent before the node's subscription
        # matched this publisher): answer again
        if stamp in answered and now - answered[stamp] < REANSWER_AFTER:
            return
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
