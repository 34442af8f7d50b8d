"""One robot's topics on the node (README.md#several-robots): its ``joint_states`` publisher
and filler, its URDF on ``robot_description`` (latched, a robot of ``Scene.robots`` with its
own URDF) and its command subscriptions, made when the node starts or a robot is spawned and
gone when it is deleted.
"""

from affine_joint_sim.physics.host.joint_kinds import joint_kind
from affine_joint_sim.ros.joint_state import JointStateFiller
from affine_joint_sim.ros.topics import ANSWER_KEYS, JOINT_COMMAND_KEYS

__all__ = ['RobotTopics']


class RobotTopics:
    """The topics of robot face ``face`` (``ros.robots.RobotFace``) on ``node`` (a SimNode),
    its commands going to ``buffer``; ``answers``: it subscribes the answer topics (its
    controllers answer in lockstep)."""

    def __init__(self, node, face, buffer, answers: bool):
        self.node, self.face, self.answers = node, face, answers
        self.state_pub = node._publisher('joint_states', namespace=face.namespace)
        self.states = JointStateFiller(node.sim, node.topics['joint_states'].msg_class,
                                       face.robot)
        self.description_pub = None
        if face.robot is not None and face.description is not None:
            self.description_pub = node._publisher('robot_description',
                                                   namespace=face.namespace)
        self.subscriptions = []
        for joint, k in zip(buffer.joint_names, buffer.scene_index):
            for key in JOINT_COMMAND_KEYS.get(joint_kind(node.sim.joint_types[k]).command, ()):
                self.subscriptions.append(node._subscribe(key, joint, face.key))
        for key in ANSWER_KEYS if answers else ():
            self.subscriptions.append(node._subscribe(key, None, face.key))

    def publish_description(self, t_ns: int) -> None:
        """Publish (and record) its URDF, latched."""
        if self.description_pub is not None:
            msg = self.node.topics['robot_description'].msg_class(data=self.face.description)
            self.node._publish_and_record(self.description_pub, msg, t_ns)

    def destroy(self) -> None:
        """Remove its publishers and subscriptions from the node."""
        node = self.node
        for subscription in self.subscriptions:
            node._answer_subs.pop(subscription.topic_name, None)
            node.destroy_subscription(subscription)
        for publisher in (self.state_pub, self.description_pub):
            if publisher is not None:
                node.destroy_publisher(publisher)
