"""Fixed bodies' collision geometry as static shapes (README.md#contact), host side.

A fixed body with ``collision`` is world geometry: each of its boxes, spheres, capsules and
cylinders becomes a static shape at its world pose at t = 0 (a fixed body never moves). Moving
bodies touch it with their contact points: the distance of a point to a convex shape is exact
(``shape_distance`` here, ``contact.shape_separation`` in the kernel). A fixed body's mesh is
not static geometry yet: it is said once and left out. Which points may touch which shape
follows the articulations (``Scene.articulations``; ``contact_model`` decides).
"""

import warnings

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.rotations import rpy_matrix
from affine_joint_sim.sim_warnings import SimulationWarning

__all__ = ['SHAPE_KINDS', 'static_shapes', 'shape_distance']

SHAPE_KINDS = {'box': 1, 'sphere': 2, 'capsule': 3, 'cylinder': 4}


def static_shapes(bodies, q0: np.ndarray, geometries_of) -> tuple[dict, list[int], list[str]]:
    """(shape model fields, the body index of each shape, a name for each shape) of the fixed
    ones of the scene bodies ``bodies`` with collision geometry, at states ``q0``
    (n_bodies, 12); ``geometries_of(body)`` lists a body's geometries (its own shape for
    ``collision: shape``)."""
    kinds, rotations, centers, sizes, owners, names = [], [], [], [], [], []
    for b, body in enumerate(bodies):
        if not body.fixed or body.collision is None:
            continue
        geometries = geometries_of(body)
        for k, geometry in enumerate(geometries):
            name = body.name if len(geometries) == 1 else f'{body.name} (collision[{k}])'
            if geometry.kind == 'mesh':
                warnings.warn(f'body {body.name!r}: a fixed body\'s collision mesh is not static '
                              'geometry yet (boxes, spheres, capsules and cylinders are): it is '
                              'left out', SimulationWarning, stacklevel=4)
                continue
            axes = q0[b, 3:].reshape(3, 3)
            kinds.append(SHAPE_KINDS[geometry.kind])
            rotations.append(pm.matmul(axes, rpy_matrix(*geometry.origin.rpy)))
            centers.append(q0[b, :3] + pm.matmul(axes, np.array(geometry.origin.xyz, float)))
            sizes.append(_size(geometry))
            owners.append(b)
            names.append(name)
    arrays = dict(shape_kind=np.array(kinds, dtype=np.int32),
                  shape_rotation=np.array(rotations, dtype=np.float64).reshape(-1, 3, 3),
                  shape_center=np.array(centers, dtype=np.float64).reshape(-1, 3),
                  shape_size=np.array(sizes, dtype=np.float64).reshape(-1, 3))
    return arrays, owners, names


def _size(geometry) -> list[float]:
    if geometry.kind == 'box':
        return [0.5 * side for side in geometry.box]
    if geometry.kind == 'sphere':
        return [geometry.sphere.radius, 0.0, 0.0]
    solid = geometry.capsule if geometry.kind == 'capsule' else geometry.cylinder
    return [solid.radius, 0.5 * solid.length, 0.0]


def shape_distance(kind: int, rotation, center, size, x) -> float:
    """Signed distance [m] of the world point ``x`` to a static shape's surface (negative
    inside), as the kernel computes it."""
    local = pm.matmul(np.asarray(rotation).T, np.asarray(x) - np.asarray(center))
    if kind == SHAPE_KINDS['box']:
        excess = np.maximum(np.abs(local) - size, 0.0)
        outside = pm.norm(excess)
        return outside if outside > 0.0 else float(np.max(np.abs(local) - size))
    if kind == SHAPE_KINDS['sphere']:
        return pm.norm(local) - size[0]
    if kind == SHAPE_KINDS['capsule']:
        axis_point = np.array([0.0, 0.0, min(max(local[2], -size[1]), size[1])])
        return pm.norm(local - axis_point) - size[0]
    radial = pm.norm(local[:2]) - size[0]
    along = abs(local[2]) - size[1]
    if radial > 0.0 and along > 0.0:
        return pm.norm([radial, along])
    return max(radial, along)
