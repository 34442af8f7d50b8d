"""Fixed bodies' collision geometry as static shapes (README.md#contact), host side.

A fixed body with ``collision`` is world geometry: each of its boxes, spheres, capsules and
cylinders becomes a static shape at its world pose at t = 0 (a fixed body never moves), and
each triangle of its meshes one too (at most ``MAX_STATIC_TRIANGLES`` a mesh). Moving bodies
touch it with their contact points: the distance of a point to a convex shape, a triangle
included, is exact (``shape_distance`` here, ``contact.geometry.shape_separation`` in the
kernel); and with their edges and faces against its edges and vertices
(``contact.primitives``).
Which points may touch which shape follows the articulations (``Scene.articulations``;
``contact.model`` decides).
"""


import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.physics.contact.kinds import (BOX, CAPSULE, CYLINDER, SHAPE_CODES,
                                                  TRIANGLE)
from affine_joint_sim.physics.contact.mesh import mesh_triangles
from affine_joint_sim.rotations import rpy_matrix

__all__ = ['static_shapes', 'shape_separation', 'shape_distance',
           'triangle_weights']

def static_shapes(bodies, q0: np.ndarray, geometries_of,
                  moving: bool = False) -> tuple[dict, list[int], list[str]]:
    """(shape model fields, the body index of each shape, a name for each shape) of the fixed
    ones (with ``moving``: the free ones, placed as they start) of the scene bodies
    ``bodies`` with collision geometry, at states ``q0`` (n_bodies, 12);
    ``geometries_of(body)`` lists a body's geometries (its own shape for ``collision:
    shape``)."""
    kinds, rotations, centers, sizes, owners, names = [], [], [], [], [], []
    for b, body in enumerate(bodies):
        if body.fixed == moving or body.collision is None:
            continue
        geometries = geometries_of(body)
        for k, geometry in enumerate(geometries):
            name = body.name if len(geometries) == 1 else f'{body.name} (collision[{k}])'
            axes = pm.matmul(q0[b, 3:].reshape(3, 3), rpy_matrix(*geometry.origin.rpy))
            centre = q0[b, :3] + pm.matmul(q0[b, 3:].reshape(3, 3),
                                           np.array(geometry.origin.xyz, float))
            if geometry.kind == 'mesh':
                mesh = geometry.mesh
                for triangle in mesh_triangles(mesh.path or mesh.uri, mesh.scale,
                                               f'body {body.name!r} (collision[{k}])'):
                    corners = np.array([centre + pm.matmul(axes, v) for v in triangle])
                    middle = corners.sum(axis=0) / 3.0
                    kinds.append(TRIANGLE.code)
                    rotations.append(corners.T)           # the vertices as columns
                    centers.append(middle)
                    sizes.append([max(pm.norm(v - middle) for v in corners), 0.0, 0.0])
                    owners.append(b)
                    names.append(name)
                continue
            kinds.append(SHAPE_CODES[geometry.kind])
            rotations.append(axes)
            centers.append(centre)
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


def shape_separation(kind: int, rotation, center, size, x) -> tuple[float, np.ndarray]:
    """(signed distance [m] of the world point ``x`` to a static shape's surface, negative
    inside; the unit outward direction n, the distance's gradient), as the kernel computes
    them (``contact.geometry.shape_separation``)."""
    rotation = np.asarray(rotation)
    if kind == TRIANGLE.code:
        a, b, c = rotation.T
        weights = triangle_weights(np.asarray(x), a, b, c)
        gap = np.asarray(x) - (weights[0] * a + weights[1] * b + weights[2] * c)
        length = pm.norm(gap)
        return length, gap / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    local = pm.matmul(rotation.T, np.asarray(x) - np.asarray(center))
    size = np.asarray(size)
    sign = np.where(local < 0.0, -1.0, 1.0)
    if kind == BOX.code:
        excess = np.maximum(np.abs(local) - size, 0.0)
        d = pm.norm(excess)
        if d > 0.0:
            return d, pm.matmul(rotation, sign * excess / d)
        axis = int(np.argmax(np.abs(local) - size))
        return float(np.abs(local[axis]) - size[axis]), rotation[:, axis] * sign[axis]
    if kind == CYLINDER.code:
        radial = pm.norm(local[:2])
        out = np.array([local[0] / radial, local[1] / radial, 0.0]) if radial > 0.0 \
            else np.array([1.0, 0.0, 0.0])
        up = np.array([0.0, 0.0, sign[2]])
        dr, dz = radial - size[0], abs(local[2]) - size[1]
        if dr > 0.0 and dz > 0.0:
            d = pm.norm([dr, dz])
            return d, pm.matmul(rotation, (dr * out + dz * up) / d)
        return (dr, pm.matmul(rotation, out)) if dr > dz else (dz, pm.matmul(rotation, up))
    axis_point = np.zeros(3)
    if kind == CAPSULE.code:
        axis_point[2] = min(max(local[2], -size[1]), size[1])
    gap = local - axis_point
    length = pm.norm(gap)
    n = gap / length if length > 0.0 else np.array([0.0, 0.0, 1.0])
    return length - size[0], pm.matmul(rotation, n)


def triangle_weights(x, a, b, c) -> tuple[float, float, float]:
    """The barycentric weights (of a, b, c) of the point of triangle abc nearest to x, by the
    Voronoi region x is in (the kernel's ``triangle_weights``)."""
    ab, ac = b - a, c - a
    d1, d2 = pm.dot(ab, x - a), pm.dot(ac, x - a)
    d3, d4 = pm.dot(ab, x - b), pm.dot(ac, x - b)
    d5, d6 = pm.dot(ab, x - c), pm.dot(ac, x - c)
    vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        s = d1 / (d1 - d3)
        return 1.0 - s, s, 0.0
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        s = d2 / (d2 - d6)
        return 1.0 - s, 0.0, s
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - s, s
    total = va + vb + vc
    return va / total, vb / total, vc / total


def shape_distance(kind: int, rotation, center, size, x) -> float:
    """Signed distance [m] of the world point ``x`` to a static shape's surface (negative
    inside)."""
    return shape_separation(kind, rotation, center, size, x)[0]
