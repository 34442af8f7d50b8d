"""A URDF's ``<visual>`` elements as scene visuals: geometry, pose on the body, colour.

Meshes are looked up (``urdf.packages``) but never loaded: a visual keeps the URI the URDF
gives and the file found for it; one that is not found is said once and drawn as a box the
size of ``fallback`` [m].
"""

import numpy as np

from affine_joint_sim.rotations import quaternion_from_matrix
from affine_joint_sim.urdf.packages import resolve_uri

__all__ = ['link_visuals']


def link_visuals(robot, local: dict, body_of: dict, package_paths: dict, urdf_dir,
                 fallback: dict, warn) -> list[dict]:
    """Scene visual dicts of every link's visuals.

    Args:
        robot: yourdfpy Robot.
        local: link name -> its pose in its body's frame (4×4).
        body_of: link name -> body name.
        package_paths: {package: directory} for ``package://`` URIs.
        urdf_dir: the URDF's directory (relative URIs).
        fallback: body name -> box sides [m] drawn for a mesh that is not found.
        warn: called with a message for each mesh that is not found.
    """
    colors = {m.name: _rgba(m) for m in robot.materials if m.name}
    out = []
    for link in robot.links:
        for visual in link.visuals:
            origin = np.eye(4) if visual.origin is None else np.asarray(visual.origin, float)
            pose = local[link.name] @ origin
            geometry = _geometry(link.name, visual.geometry, package_paths, urdf_dir,
                                 fallback[body_of[link.name]], warn)
            entry = {'body': body_of[link.name], 'geometry': geometry,
                     'position': [float(x) for x in pose[:3, 3]],
                     'orientation': {'quat_xyzw': quaternion_from_matrix(pose[:3, :3])}}
            material = visual.material
            color = _rgba(material) if material is not None else None
            if color is None and material is not None:
                color = colors.get(material.name)
            if color is not None:
                entry['color'] = color
            out.append(entry)
    return out


def _rgba(material) -> list[float] | None:
    color = getattr(material, 'color', None)
    rgba = getattr(color, 'rgba', None)
    if rgba is None:
        return None
    return [float(min(max(c, 0.0), 1.0)) for c in rgba]


def _geometry(link: str, geometry, package_paths, urdf_dir, fallback, warn) -> dict:
    if geometry.box is not None:
        return {'box': [float(s) for s in geometry.box.size]}
    if geometry.cylinder is not None:
        return {'cylinder': {'radius': float(geometry.cylinder.radius),
                             'length': float(geometry.cylinder.length)}}
    if geometry.sphere is not None:
        return {'sphere': {'radius': float(geometry.sphere.radius)}}
    mesh = geometry.mesh
    scale = mesh.scale if mesh.scale is not None else 1.0
    scale = np.broadcast_to(np.asarray(scale, dtype=float), (3,))
    path = resolve_uri(mesh.filename, package_paths, urdf_dir)
    if path is None:
        warn(f'link {link!r}: mesh {mesh.filename!r} not found (package_paths, '
             'ROS_PACKAGE_PATH, AMENT_PREFIX_PATH searched); its visual is drawn as a box')
    return {'mesh': {'uri': mesh.filename, 'path': None if path is None else str(path.resolve()),
                     'scale': [float(s) for s in scale],
                     'fallback': [float(s) for s in fallback]}}
