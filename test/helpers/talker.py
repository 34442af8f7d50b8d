"""Publish one message over and over until interrupted: a stand-in ROS process for tests.

    python talker.py TOPIC float64 VALUE
    python talker.py TOPIC joint_state NAME=POSITION [NAME=POSITION ...]

The message goes out on a reliable publisher (depth 10) at `--rate` Hz. SIGINT or SIGTERM ends
it with exit status 0.
"""

import argparse

import rclpy
from rclpy.executors import ExternalShutdownException
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64


def parse_args(argv=None):
    """Parse the command line into topic, message kind and its content."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('topic')
    parser.add_argument('--rate', type=float, default=20.0, help='messages per second [Hz]')
    kinds = parser.add_subparsers(dest='kind', required=True)
    kinds.add_parser('float64').add_argument('value', type=float)
    kinds.add_parser('joint_state').add_argument(
        'joints', nargs='+', metavar='NAME=POSITION', help='joint name and angle [rad]')
    return parser.parse_args(argv)


def build_message(args):
    """Return the message that `args` describe."""
    if args.kind == 'float64':
        return Float64(data=args.value)
    pairs = [joint.split('=') for joint in args.joints]
    return JointState(name=[name for name, _ in pairs],
                      position=[float(position) for _, position in pairs])


def main(argv=None):
    """Publish until interrupted."""
    args = parse_args(argv)
    message = build_message(args)
    rclpy.init()
    node = rclpy.create_node('talker')
    publisher = node.create_publisher(type(message), args.topic, 10)
    node.create_timer(1.0 / args.rate, lambda: publisher.publish(message))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
