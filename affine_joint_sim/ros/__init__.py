"""The ROS 2 side of affine_joint_sim: node, topic configuration, tools and demo controller.

Everything here imports rclpy; the physics (``affine_joint_sim.physics``, ``Stepper``) never
does.
"""
