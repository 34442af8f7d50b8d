"""A scene's robots as the node, the bag replay and the loop see them (README.md#several-robots).

A scene listing several robots (``Scene.robots``) gives each its own topics under its
namespace, its joints named there as in its URDF; a scene without that list is one robot (or
none) whose topics are the node's own. ``robot_faces`` lists them, ``RobotCommands`` holds one
``CommandBuffer`` per robot and acts as one towards ``SimLoop``.
"""

from dataclasses import dataclass

import numpy as np

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

    def topic(self, name: str) -> str:
        """A topic name of topics.yaml for this robot: a relative one under its namespace,
        an absolute or private one (/clock, ~/scene) as it is."""
        return name if name.startswith(('/', '~')) else self.namespace + name


def robot_faces(scene) -> list[RobotFace]:
    """The robots of ``scene`` in order: one face per ``scene.robots`` entry, or a single one
    for the whole scene."""
    if not scene.robots:
        return [RobotFace(None, '', scene.robot_description)]
    return [RobotFace(r, r.namespace + '/', scene.robot_descriptions.get(r.name))
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
