"""Robots from URDF files (design.md §10): reading, mass properties, conversion to a Scene."""

from affine_joint_sim.urdf.convert import ANCHOR_HALF_LENGTH, UrdfOptions, scene_from_urdf

__all__ = ['scene_from_urdf', 'UrdfOptions', 'ANCHOR_HALF_LENGTH']
