"""The shapes viewers draw for a scene, each rigidly attached to a body.

A scene's ``visuals`` (a URDF robot's) are drawn as given; a scene without any draws every
body's own shape. Sizes follow RViz's marker conventions: a box by its full sides, a cylinder
along its local z by diameter, diameter and length, a sphere by its diameter [m]; a mesh by
its scale, or, when its file was not found, as a box of its fallback sides.
"""

from dataclasses import dataclass

import numpy as np

from affine_joint_sim.rotations import rotation_matrix

__all__ = ['Drawable', 'drawables', 'PALETTE']

# Opaque colours for bodies without a material (RGBA), cycled in body order.
PALETTE = ((0.93, 0.45, 0.10, 1.0), (0.16, 0.47, 0.71, 1.0), (0.30, 0.69, 0.29, 1.0),
           (0.60, 0.31, 0.64, 1.0), (0.89, 0.10, 0.11, 1.0), (0.65, 0.34, 0.16, 1.0),
           (0.50, 0.50, 0.50, 1.0))


@dataclass(frozen=True)
class Drawable:
    """One shape on one body.

    Attributes:
        body: index of the body (scene order).
        local: pose in the body's frame, 4×4 [m].
        kind: 'box', 'cylinder', 'sphere' or 'mesh' (a mesh whose file was not found is a box).
        scale: RViz marker scale (see the module docstring) [m, or the mesh's factors].
        color: RGBA in 0–1.
        mesh_path: the mesh file (kind 'mesh'), else None.
    """

    body: int
    local: np.ndarray
    kind: str
    scale: tuple
    color: tuple
    mesh_path: str | None = None


def _scale(geometry) -> tuple[str, tuple, str | None]:
    kind = geometry.kind
    if kind == 'box':
        return 'box', tuple(geometry.box), None
    if kind == 'cylinder':
        d = 2.0 * geometry.cylinder.radius
        return 'cylinder', (d, d, geometry.cylinder.length), None
    if kind == 'sphere':
        d = 2.0 * geometry.sphere.radius
        return 'sphere', (d, d, d), None
    mesh = geometry.mesh
    if mesh.path is None:
        return 'box', tuple(mesh.fallback), None
    return 'mesh', tuple(mesh.scale), mesh.path


def drawables(scene) -> list[Drawable]:
    """Every shape to draw, in a stable order (visuals as listed, else bodies in order)."""
    out = []
    if scene.visuals:
        for visual in scene.visuals:
            body = scene.body_index(visual.body)
            local = np.eye(4)
            local[:3, :3] = rotation_matrix(visual.orientation)
            local[:3, 3] = visual.position
            kind, scale, path = _scale(visual.geometry)
            color = tuple(visual.color) if visual.color else PALETTE[body % len(PALETTE)]
            out.append(Drawable(body, local, kind, scale, color, path))
        return out
    for body, spec in enumerate(scene.bodies):
        if spec.shape is None:
            continue
        kind, scale, _ = _scale(spec.shape)
        out.append(Drawable(body, np.eye(4), kind, scale, PALETTE[body % len(PALETTE)]))
    return out
