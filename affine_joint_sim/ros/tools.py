"""Command-line stand-ins for ``ros2 topic pub/echo``: send one torque or enable, watch states.

Each tool is a short-lived node (namespace ``--namespace``, so it reaches a node started in the
same namespace) using the topic names and QoS of ``msg_configs/topics.yaml``.
"""

import math
import os
import sys
import time

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException

from affine_joint_sim.ros.topics import load_topics

__all__ = ['send', 'echo']


def _tool_node(namespace: str):
    rclpy.init()
    return rclpy.create_node(f'affine_joint_sim_cli_{os.getpid()}', namespace=namespace)


def _wait(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


# The same command for a prismatic joint: a force [N] on external_force.
_PRISMATIC_TWIN = {'joint_torque': 'joint_force', 'joint_enable': 'joint_force_enable'}


def send(key: str, joint: str, value, namespace: str = '', timeout: float = 10.0) -> int:
    """Publish one command (``key`` is ``joint_torque`` or ``joint_enable``) to ``joint``; a
    prismatic joint (whose node subscribes ``external_force``) gets it as a force [N].

    Waits up to ``timeout`` [s] for a subscriber (the node) and for its acknowledgement.
    Returns the exit status: 0 delivered, 1 no subscriber (the message names the joints the
    graph knows), 2 invalid value.
    """
    topics = load_topics()
    if key == 'joint_torque' and not math.isfinite(value):
        print(f'affine-joint-sim: error: torque must be finite, got {value!r}', file=sys.stderr)
        return 2
    node = _tool_node(namespace)
    try:
        candidates = [(topics[k], node.create_publisher(topics[k].msg_class, topics[k].name(joint),
                                                        topics[k].qos))
                      for k in (key, _PRISMATIC_TWIN[key])]

        def matched():
            return next(((t, p) for t, p in candidates if p.get_subscription_count() > 0), None)

        if not _wait(lambda: matched() is not None, timeout):
            suffixes = tuple(topics[k].template.split('{joint}')[-1]
                             for k in ('joint_torque', 'joint_force'))
            known = sorted(n for n, _ in node.get_topic_names_and_types()
                           if n.endswith(suffixes) and node.count_subscribers(n) > 0)
            print(f'affine-joint-sim: error: nothing subscribes to '
                  f'{candidates[0][1].topic_name} after {timeout:g} s; is the node running in '
                  f'namespace {namespace or "/"!r} and is {joint!r} a joint that takes commands?'
                  f' Torque and force topics seen: {", ".join(known) or "none"}',
                  file=sys.stderr)
            return 1
        topic, publisher = matched()
        full_name = publisher.topic_name
        publisher.publish(topic.msg_class(data=value))
        if not publisher.wait_for_all_acked(Duration(seconds=timeout)):
            print(f'affine-joint-sim: error: {full_name}: not acknowledged within {timeout:g} s',
                  file=sys.stderr)
            return 1
        print(f'{full_name}: {value}')
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def _table(msg) -> str:
    t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
    width = max([5] + [len(n) for n in msg.name])
    lines = [f't = {t:.3f} s',
             f'{"joint":<{width}}  {"position [rad]":>15}  {"velocity [rad/s]":>17}  '
             f'{"effort [N·m]":>13}']
    for i, name in enumerate(msg.name):
        row = [msg.position, msg.velocity, msg.effort]
        values = [f'{field[i]:{w}.6f}' if i < len(field) else f'{"-":>{w}}'
                  for field, w in zip(row, (15, 17, 13))]
        lines.append(f'{name:<{width}}  ' + '  '.join(values))
    return '\n'.join(lines)


def echo(namespace: str = '', rate: float = 10.0, once: bool = False,
         timeout: float = 0.0) -> int:
    """Print joint_states as a table, refreshed ``rate`` times per second (in place on a TTY).

    ``once`` prints the first message and returns; ``timeout`` > 0 gives up (status 1) when
    no message arrives within that many seconds.
    """
    topic = load_topics()['joint_states']
    node = _tool_node(namespace)
    latest = []
    node.create_subscription(topic.msg_class, topic.name(), latest.append, topic.qos)
    redraw = sys.stdout.isatty() and not once
    start = next_print = time.monotonic()
    try:
        while True:
            rclpy.spin_once(node, timeout_sec=0.05)
            now = time.monotonic()
            if not latest:
                if timeout > 0 and now - start > timeout:
                    name = node.resolve_topic_name(topic.name())
                    print(f'affine-joint-sim: error: no message on {name} within {timeout:g} s',
                          file=sys.stderr)
                    return 1
            elif now >= next_print:
                print(('\x1b[H\x1b[J' if redraw else '') + _table(latest[-1]), flush=True)
                latest.clear()
                next_print = now + 1.0 / rate
                if once:
                    return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    except BrokenPipeError:         # `echo | head`: the reader has what it wanted
        sys.stdout = open(os.devnull, 'w')      # nothing more goes to the closed pipe at exit
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
