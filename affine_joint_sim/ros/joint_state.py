"""The ``joint_states`` message of a Stepper: one filler for the node, the bag replay and its
``--out`` bag, so all three publish and compare the same thing.

It lists the joints that move (revolute and prismatic, mimic joints included, in scene order),
as ros2_control's joint_state_broadcaster does; fixed joints have no state
(robot_state_publisher takes them from the robot description). position = angle [rad] or
distance [m], velocity [rad/s | m/s], effort = applied torque [N·m] or force [N]; the stamp is
the simulated time.
"""

import numpy as np

from affine_joint_sim.physics.host.joint_kinds import joint_kind

__all__ = ['JointStateFiller']


class JointStateFiller:
    """Fills a ``sensor_msgs/JointState`` from a Stepper's current step.

    Args:
        sim: the Stepper.
        msg_class: the JointState class (``topics['joint_states'].msg_class``).
        robot: a ``scene.Robot``: its joints only, named as in its URDF; None: the joints
            outside the scene's robots (every joint of a scene without robots).
        every: every joint of the scene, as the scene names them (``robot`` unused).
    """

    def __init__(self, sim, msg_class, robot=None, every: bool = False):
        scene = sim.scene
        moving = np.array([k for k, kind in enumerate(sim.joint_types)
                           if joint_kind(kind).command is not None
                           and (every or scene.robot_of(sim.joint_names[k]) == robot)],
                          dtype=np.intp)
        prefix = '' if robot is None or every else robot.prefix
        self.names = [sim.joint_names[k][len(prefix):] for k in moving]
        # without fixed joints every array is sent as it is (no copy per step)
        self.index = None if len(moving) == len(sim.joint_types) else moving
        self.wrapped = np.array([j.angle_mode == 'wrapped' and j.type == 'revolute'
                                 for j in sim.scene.joints])[moving]
        self.msg = msg_class()
        self.msg.name = self.names

    def select(self, values: np.ndarray) -> np.ndarray:
        """The entries of a per-joint array that the message carries."""
        return values if self.index is None else values[self.index]

    def fill(self, sim, stamp_ns: int):
        """The message for ``sim``'s current state at stamp ``stamp_ns`` [ns]."""
        msg = self.msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        msg.position = self.select(sim.angles).tobytes()
        msg.velocity = self.select(sim.velocities).tobytes()
        msg.effort = self.select(sim.efforts).tobytes()
        return msg
