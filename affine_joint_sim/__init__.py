"""affine_joint_sim: affine-body robot simulation with a ROS 2 (Jazzy) front end.

Bodies are affine bodies joined by revolute, prismatic and fixed joints. The physics
(``Scene``, ``Stepper``) needs no ROS; ``affine_joint_sim.ros`` wraps it in an rclpy node.
Names are imported lazily so that light entry points (CLI helpers) do not pay for Warp.
"""

__all__ = ['Scene', 'SceneError', 'Stepper']


def __getattr__(name):
    if name in ('Scene', 'SceneError'):
        from affine_joint_sim import scene
        return getattr(scene, name)
    if name == 'Stepper':
        from affine_joint_sim.stepper import Stepper
        return Stepper
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
