"""A controller written the usual way: a volatile ``joint_states`` subscription (depth 10) and
a ``joint_commands`` publisher that answers every state it receives, copies the node
publishes again while it waits included, stamped with the state's stamp (``--unstamped``: no
stamp). Its torque is a PD law on one joint. Runs until interrupted.

    python plain_controller.py JOINT TARGET [--unstamped] [--name NODE]
"""

import argparse

import rclpy
from rclpy.executors import ExternalShutdownException
from sensor_msgs.msg import JointState


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

    def on_state(msg):
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
