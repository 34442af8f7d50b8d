"""A scene's robots as the node, the bag replay and the loop see them (README.md#several-robots).

A scene listing robots (``Scene.robots``) gives each its own topics under its namespace, its
joints named there as in its URDF; the joints outside them (every joint of a scene without
that list: one robot, or none) are on the node's own topics. ``robot_faces`` lists them,
``RobotCommands`` holds one ``CommandBuffer`` per robot and acts as one towards ``SimLoop``.
"""

from dataclasses import dataclass

import numpy as np

from affine_joint_sim.physics.host.joint_kinds import joint_kind
from affine_joint_sim.ros.commands import CommandBuffer

__all__ = ['RobotFace', 'robot_faces', 'RobotCommands']


@dataclass(frozen=True)
class RobotFace:
    """One robot's topics: ``robot`` (a ``scene.Robot``; None: the whole scene, one robot or
    none), ``namespace`` (what its topic names start with: ``<namespace>/``, or '' for the
    node's own) and ``description`` (its URDF text, None where the scene has none of its
    own)."""

    robot: object
    namespace: str
    description: str | None

    @property
    def key(self) -> str | None:
        """The robot's name; None for the scene's own joints."""
        return None if self.robot is None else self.robot.name

    def topic(self, name: str) -> str:
        """A topic name of topics.yaml for this robot: a relative one under its namespace,
        an absolute or private one (/clock, ~/scene) as it is."""
        return name if name.startswith(('/', '~')) else self.namespace + name


def robot_faces(scene) -> list[RobotFace]:
    """The robots of ``scene`` in order: the scene's own (its joints outside ``scene.robots``,
    on the node's own topics: every joint of a scene without that list), where it has joints
    or bodies outside them or no robots, then one face per ``scene.robots`` entry."""
    own = [j for j in scene.joints if scene.robot_of(j.name) is None
           and joint_kind(j.type).command is not None]
    own += [b for b in scene.bodies if scene.robot_of(b.name) is None]
    faces = [RobotFace(None, '', scene.robot_description)] if own or not scene.robots else []
    return faces + [RobotFace(r, r.namespace + '/', scene.robot_descriptions.get(r.name))
                    for r in scene.robots]


class RobotCommands:
    """One ``CommandBuffer`` per robot face, as one buffer towards ``SimLoop`` (``reset``,
    ``apply``, ``scene_index``, ``command_timeout``).

    Args:
        sim: the Stepper.
        command_timeout: as ``CommandBuffer``'s [s].
        array_joints: the joints of the command arrays, scene names (parameter
            ``command_joints``); each robot takes its own, in this order, or all of its own
            where none is listed. None: every robot all of its own.
    """

    def __init__(self, sim, command_timeout: float = 0.0, array_joints=None):
        self.faces = robot_faces(sim.scene)
        self.buffers = [CommandBuffer.for_stepper(sim, command_timeout, robot=face.robot)
                        for face in self.faces]
        if array_joints is not None:
            self.array_joints = array_joints
        self.scene_index = np.concatenate([b.scene_index for b in self.buffers])

    def buffer_of(self, key) -> CommandBuffer:
        """The buffer of the robot face ``key`` (``RobotFace.key``)."""
        return self.buffers[[f.key for f in self.faces].index(key)]

    def refresh(self, sim) -> tuple[list[RobotFace], list]:
        """Follow a spawn or delete of ``sim``'s scene: each robot kept keeps its buffer (its
        pending commands and timeouts), a new one gets its own, a deleted one's goes.
        Returns (the new faces, the keys of the deleted ones)."""
        kept = {f.key: b for f, b in zip(self.faces, self.buffers)}
        timeout = self.command_timeout
        self.faces, self.buffers, added = robot_faces(sim.scene), [], []
        for face in self.faces:
            fresh = CommandBuffer.for_stepper(sim, timeout, robot=face.robot)
            if face.key in kept:
                kept[face.key].scene_index = fresh.scene_index
            else:
                fresh.reset(sim.torques[fresh.scene_index], sim.time)
                added.append(face)
            self.buffers.append(kept.get(face.key, fresh))
        self.scene_index = np.concatenate([b.scene_index for b in self.buffers])
        return added, [key for key in kept if key not in {f.key for f in self.faces}]

    @property
    def command_timeout(self) -> float:
        return self.buffers[0].command_timeout

    @command_timeout.setter
    def command_timeout(self, seconds: float) -> None:
        for buffer in self.buffers:
            buffer.command_timeout = seconds

    @property
    def array_joints(self) -> list[str]:
        """The joints of every robot's command arrays, scene names."""
        return [b.prefix + name for b in self.buffers for name in b.array_joints]

    @array_joints.setter
    def array_joints(self, names) -> None:
        for buffer in self.buffers:
            own = [n[len(buffer.prefix):] for n in names if n.startswith(buffer.prefix)
                   and n[len(buffer.prefix):] in buffer.joint_names]
            buffer.array_joints = own or list(buffer.joint_names)

    def reset(self, torques, sim_time: float = 0.0) -> None:
        """Each buffer's ``reset`` with its joints' ``torques`` (in ``scene_index`` order)."""
        start = 0
        for buffer in self.buffers:
            stop = start + len(buffer.joint_names)
            buffer.reset(torques[start:stop], sim_time)
            start = stop

    def apply(self, stepper, sim_time: float) -> list[str]:
        """Each buffer's ``apply``; their notices."""
        return [notice for b in self.buffers for notice in b.apply(stepper, sim_time)]
