"""Robots from URDF files (README.md#robots-from-urdf): reading, mass properties, conversion."""

from affine_joint_sim.urdf.convert import ANCHOR_HALF_LENGTH, UrdfOptions, urdf_scene_data

__all__ = ['urdf_scene_data', 'UrdfOptions', 'ANCHOR_HALF_LENGTH']
