"""Client side of the node tests: message inboxes, publishers, service calls, the node fixture.

Imported by test modules as ``helpers.ros_client`` (pytest puts test/ on the path).
"""

import copy

from affine_joint_sim.ros.topics import load_topics

TOPICS = load_topics()
DT_NS = 10_000_000          # every scene used here has dt = 0.01 s


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


class Inbox:
    """Every message received on one topic, in order; ``depth``: the subscription's history
    (default the topic's), deeper for a burst that a busy test process takes late."""

    def __init__(self, node, topic_key, name=None, depth=None):
        topic = TOPICS[topic_key]
        qos = copy.copy(topic.qos)
        qos.depth = depth or qos.depth
        self.messages = []
        self.sub = node.create_subscription(topic.msg_class, name or topic.name(),
                                            self.messages.append, qos)

    @property
    def last(self):
        return self.messages[-1] if self.messages else None

    def since(self, count):
        return self.messages[count:]


def node_services(node) -> dict:
    """Services of the simulator node as seen from ``node`` ({} until it is discovered)."""
    if ('affine_joint_sim', '/') not in node.get_node_names_and_namespaces():
        return {}
    return dict(node.get_service_names_and_types_by_node('affine_joint_sim', '/'))


def wait_until_up(node, wait_for, process, states: str = '/joint_states') -> bool:
    """Wait until the simulator node in ``process`` publishes ``states`` (a robot's
    joint_states) and serves ~/step as seen from ``node``, or the process ends; True if it
    is up."""
    seen = wait_for(lambda: process.poll() is not None or (
        node.count_publishers(states) > 0 and
        '/affine_joint_sim/step' in node_services(node)), timeout=30.0)
    return seen and process.poll() is None


def publisher(node, wait_for, key, joint=None, name=None):
    topic = TOPICS[key]
    pub = node.create_publisher(topic.msg_class, name or '/' + topic.name(joint), topic.qos)
    assert wait_for(lambda: pub.get_subscription_count() > 0)
    return pub


def call(node, wait_for, service_type, name, request):
    client = node.create_client(service_type, name)
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(request)
    assert wait_for(future.done)
    return future.result()
