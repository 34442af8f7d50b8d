"""The run made visible (README.md#seeing-a-run): ``markers`` (MarkerArray, one marker per shape
of every body), ``body_poses`` (PoseArray: every body, or every link frame of a URDF robot) and
/tf (``ros.transforms``; /tf_static once), in ``frame_id`` and stamped with sim time, at
``viz_rate`` Hz of sim time; a DELETEALL on reset. Both messages are serialized once and then
patched in place (``ros.patched``); the same bytes are published and recorded. In a scene with
contact a second MarkerArray on ``markers`` follows each one: an arrow per active contact, its
force (normal and friction) at ``ARROW_SCALE`` m/N from the touching point (namespace
``contact_forces``), and a DELETE for each arrow of the last one that is gone.
"""

import math

from affine_joint_sim.poses import LinkFrames
from affine_joint_sim.ros.patched import PatchedMessage
from affine_joint_sim.ros.topics import interfaces_built
from affine_joint_sim.ros.transforms import TransformTree
from affine_joint_sim.viz.drawables import drawables

__all__ = ['VizMessages', 'VizSchedule', 'VizPublisher', 'ContactArrows', 'ARROW_SCALE']

ARROW_SCALE = 0.01        # m/N: a contact force's arrow length (a 1 kg box's 2.5 N corner: 2.5 cm)

_MARKER_TYPES = {'box': 'CUBE', 'cylinder': 'CYLINDER', 'sphere': 'SPHERE',
                 'mesh': 'MESH_RESOURCE'}


class VizSchedule:
    """When the views are due: at t = 0 and at the first step at or after each multiple of
    1 / ``rate`` [Hz of sim time]; never for rate 0. Asked every step: one comparison."""

    def __init__(self, rate: float):
        self.rate = rate
        self._next_ns = 0 if rate > 0.0 else math.inf

    def due(self, sim_time_ns: int) -> bool:
        if sim_time_ns < self._next_ns:
            return False
        # the next multiple of 1/rate after this time [ns], rounded up to a whole ns
        slot = math.floor(sim_time_ns * 1e-9 * self.rate + 1e-9) + 1
        self._next_ns = math.ceil(slot / self.rate * 1e9 - 1.0)
        return True

    def reset(self) -> None:
        self._next_ns = 0 if self.rate > 0.0 else math.inf


class VizMessages:
    """The markers and body_poses of a stepper's scene (environment 0), as prebuilt serialized
    messages; the poses come from one kernel launch (``Stepper.pose_reader``).

    """

    def __init__(self, sim, frame_id: str):
        from geometry_msgs.msg import Pose, PoseArray
        from visualization_msgs.msg import Marker, MarkerArray

        scene = sim.scene
        self._items = drawables(scene)
        self._links = LinkFrames(scene)
        names = [b.name for b in scene.bodies]
        markers = []
        for i, item in enumerate(self._items):
            marker = Marker(ns=names[item.body], id=i, action=Marker.ADD,
                            type=getattr(Marker, _MARKER_TYPES[item.kind]))
            marker.header.frame_id = frame_id
            marker.scale.x, marker.scale.y, marker.scale.z = map(float, item.scale)
            marker.color.r, marker.color.g, marker.color.b, marker.color.a = map(
                float, item.color)
            if item.mesh_path:
                marker.mesh_resource = 'file://' + item.mesh_path
                marker.mesh_use_embedded_materials = True
            markers.append(marker)
        self.markers = PatchedMessage(MarkerArray(markers=markers), _pose_fields(
            [m.pose for m in markers]), [m.header for m in markers])
        poses = PoseArray(poses=[Pose() for _ in self._links.names])
        poses.header.frame_id = frame_id
        self.poses = PatchedMessage(poses, _pose_fields(poses.poses), [poses.header])
        clear = Marker(action=Marker.DELETEALL)
        clear.header.frame_id = frame_id
        self.delete_all = MarkerArray(markers=[clear])
        # one launch: the shapes, then the link frames
        self._read = sim.pose_reader(
            [item.body for item in self._items] + list(self._links.body),
            [item.local for item in self._items] + list(self._links.local))
        self._count = len(self._items)

    def update(self, stamp_ns: int) -> tuple[bytes, bytes]:
        """Serialized (markers, body_poses) of the stepper's current state, stamped
        ``stamp_ns`` [ns of sim time]."""
        values = self._read()
        return (self.markers.update(values[:self._count], stamp_ns),
                self.poses.update(values[self._count:], stamp_ns))


class ContactArrows:
    """The contact forces of a stepper's environment 0 as ARROW markers (``sim.contacts``):
    from the touching point along the force on the body, ``ARROW_SCALE`` m/N, red."""

    NAMESPACE = 'contact_forces'

    def __init__(self, sim, frame_id: str):
        self._sim, self._frame_id, self._shown = sim, frame_id, 0

    def message(self, stamp_ns: int):
        """The MarkerArray of the current contacts, stamped ``stamp_ns`` [ns of sim time]."""
        from geometry_msgs.msg import Point
        from visualization_msgs.msg import Marker, MarkerArray

        contacts = self._sim.contacts
        markers = []
        for k in range(max(len(contacts), self._shown)):
            marker = Marker(ns=self.NAMESPACE, id=k, type=Marker.ARROW)
            marker.header.frame_id = self._frame_id
            marker.header.stamp.sec, marker.header.stamp.nanosec = divmod(stamp_ns, 10 ** 9)
            if k < len(contacts):
                c = contacts[k]
                tip = c['point'] + ARROW_SCALE * (c['normal_force'] * c['normal']
                                                  + c['friction_force'])
                marker.action = Marker.ADD
                marker.points = [Point(x=float(a), y=float(b), z=float(z))
                                 for a, b, z in (c['point'], tip)]
                marker.scale.x, marker.scale.y = 0.004, 0.008     # m: shaft, head diameters
                marker.color.r, marker.color.a = 1.0, 1.0
                marker.pose.orientation.w = 1.0
            else:
                marker.action = Marker.DELETE
            markers.append(marker)
        self._shown = len(contacts)
        return MarkerArray(markers=markers)

    def reset(self) -> None:
        """The viewers were cleared (DELETEALL): no arrow is shown."""
        self._shown = 0


def _pose_fields(poses) -> list:
    return [(obj, attr) for pose in poses for obj, attr in (
        (pose.position, 'x'), (pose.position, 'y'), (pose.position, 'z'),
        (pose.orientation, 'x'), (pose.orientation, 'y'), (pose.orientation, 'z'),
        (pose.orientation, 'w'))]


class VizPublisher:
    """The node's ``markers``, ``body_poses`` and ``tf`` publishers and their schedule (``tf``
    and ``tf_static`` only where tf2_msgs is built: ``topics.interfaces_built``).

    Args:
        publisher: ``publisher(key)`` creates the node's publisher of topic ``key``
            (``load_topics()``) and lists it for the node's bag.
        sim: the node's Stepper.
        rate: ``viz_rate`` [Hz of sim time]; 0 creates nothing.
        frame_id: the frame the poses are in.
        publish: ``publish(publisher, msg or serialized bytes, t_ns)`` (publishes and records).
        recording: ``recording()`` says whether the run is being recorded: views nobody
            subscribes to and no bag records are not computed (a viewer that joins gets the
            next one, at most 1/rate later; subscriptions are counted from DDS's matched
            events, so a view tick without either costs no call into DDS).
    """

    KEYS = ('markers', 'body_poses')

    def __init__(self, publisher, sim, rate: float, frame_id: str, publish, recording):
        self.schedule = VizSchedule(rate)
        self._publish, self._recording = publish, recording
        self.publishers, self.tree = {}, None     # tree: /tf's, where tf2_msgs is built
        self._matched = {}
        if rate <= 0.0:
            return
        self.messages = VizMessages(sim, frame_id)
        self.arrows = ContactArrows(sim, frame_id) if sim.scene.contact is not None \
            or sim.scene.ground is not None else None
        self.tree = TransformTree(sim, frame_id) if interfaces_built('tf2_msgs') else None
        keys = self.KEYS + (('tf', 'tf_static') if self.tree is not None else ())
        self._matched = dict.fromkeys(keys, 0)    # subscriptions matched, per topic
        self.publishers = {key: publisher(key, on_matched=self._on_matched(key))
                           for key in keys}

    @property
    def watched(self) -> bool:
        """Whether some subscription to a view topic is matched (DDS's matched events)."""
        return any(self._matched.values())

    def _on_matched(self, key: str):
        def matched(status):
            self._matched[key] = status.current_count
        return matched

    def publish_static(self, t_ns: int) -> None:
        """Publish (and record) /tf_static once: the frames that never move in their parent."""
        if self.tree is not None:
            self._publish(self.publishers['tf_static'], self.tree.static_message(0), t_ns)

    def publish(self, sim_time_ns: int, t_ns: int) -> None:
        """Publish (and record) the views of the current state if they are due."""
        if not self.publishers or not self.schedule.due(sim_time_ns):
            return
        if not self._recording() and not self.watched:
            return
        markers, poses = self.messages.update(sim_time_ns)
        self._publish(self.publishers['markers'], markers, t_ns)
        if self.arrows is not None:
            self._publish(self.publishers['markers'], self.arrows.message(sim_time_ns), t_ns)
        self._publish(self.publishers['body_poses'], poses, t_ns)
        if self.tree is not None:
            self._publish(self.publishers['tf'], self.tree.moving_message(sim_time_ns), t_ns)

    def rebuild(self, sim, frame_id: str, t_ns: int) -> None:
        """Follow a spawn or delete: the views of ``sim``'s scene now, the viewers' markers
        cleared and /tf_static published again."""
        if not self.publishers:
            return
        self.reset(t_ns)
        self.messages = VizMessages(sim, frame_id)
        self.arrows = ContactArrows(sim, frame_id) if sim.scene.contact is not None \
            or sim.scene.ground is not None else None
        if self.tree is not None:
            self.tree = TransformTree(sim, frame_id)
            self.publish_static(t_ns)

    def reset(self, t_ns: int) -> None:
        """Clear the viewers' markers (DELETEALL); the next state is published in full."""
        self.schedule.reset()
        if self.publishers:
            self._publish(self.publishers['markers'], self.messages.delete_all, t_ns)
            if self.arrows is not None:
                self.arrows.reset()
