"""/tf and /tf_static (README.md#transforms), as robot_state_publisher publishes a robot: one
transform per frame of the scene (a URDF's links, or every body of a YAML scene) from its
parent frame (the URDF parent link; the node's ``frame_id`` for a root link, a floating base,
an object or a YAML body). A frame whose pose in its parent never changes, a welded link or one
on a fixed body under the world, goes once on /tf_static (transient local); the others on /tf
at ``viz_rate``, computed from the bodies' rigid poses (as ``Stepper.link_transforms``), so
that composing them from ``frame_id`` gives every link's pose. A frame named as ``frame_id`` (a
URDF's own ``world`` link) is that frame and gets no transform.
"""

import numpy as np

from affine_joint_sim.poses import LinkFrames
from affine_joint_sim.ros.patched import PatchedMessage

__all__ = ['TransformTree']


class TransformTree:
    """The transforms of a Stepper's scene (environment 0) from ``frame_id``, as CDR bytes
    serialized once and patched in place (``ros.patched``); each message's poses come from
    one launch (``Stepper.pose_reader`` with parent frames)."""

    def __init__(self, sim, frame_id: str):
        scene = sim.scene
        links = LinkFrames(scene)
        parents = [f.parent for f in scene.frames] if scene.frames else [None] * len(links.names)
        index = {name: k for k, name in enumerate(links.names)}
        fixed = [scene.bodies[b].fixed for b in links.body]
        static, moving = [], []
        for k, (name, parent) in enumerate(zip(links.names, parents)):
            if name == frame_id:
                continue
            above = frame_id if parent is None or parent == frame_id else parent
            still = fixed[k] if above == frame_id else links.body[index[above]] == links.body[k]
            (static if still else moving).append((above, name, k, index.get(above, -1)))
        self._static = _Transforms(sim, links, static)
        self._moving = _Transforms(sim, links, moving)

    def static_message(self, stamp_ns: int) -> bytes:
        """The serialized TFMessage of /tf_static at the stepper's current state."""
        return self._static.update(stamp_ns)

    def moving_message(self, stamp_ns: int) -> bytes:
        """The serialized TFMessage of /tf at the stepper's current state."""
        return self._moving.update(stamp_ns)


class _Transforms:
    """One TFMessage of edges (parent name, child name, child frame, parent frame or −1: the
    world) and the reader of their poses."""

    def __init__(self, sim, links: LinkFrames, edges):
        from geometry_msgs.msg import TransformStamped
        from tf2_msgs.msg import TFMessage

        items = []
        for parent, child, _, _ in edges:
            item = TransformStamped(child_frame_id=child)
            item.header.frame_id = parent
            items.append(item)
        fields = [(obj, attr) for item in items for obj, attr in (
            (item.transform.translation, 'x'), (item.transform.translation, 'y'),
            (item.transform.translation, 'z'), (item.transform.rotation, 'x'),
            (item.transform.rotation, 'y'), (item.transform.rotation, 'z'),
            (item.transform.rotation, 'w'))]
        self._message = PatchedMessage(TFMessage(transforms=items), fields,
                                       [item.header for item in items])
        child = [k for _, _, k, _ in edges]
        up = [j for _, _, _, j in edges]
        self._read = sim.pose_reader(
            links.body[child], links.local[child],
            parent=[links.body[j] if j >= 0 else -1 for j in up],
            parent_local=[links.local[j] if j >= 0 else np.eye(4) for j in up]) \
            if edges else None

    def update(self, stamp_ns: int) -> bytes:
        """The serialized message at the stepper's current state, stamped ``stamp_ns``."""
        return self._message.update(self._read() if self._read else np.zeros((0, 7)), stamp_ns)
