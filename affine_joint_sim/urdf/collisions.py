"""A URDF's ``<collision>`` elements, read leniently (README.md#contact).

yourdfpy never sees them (``urdf.read`` drops them first): a robot whose collision geometry is
odd must still load when the scene has no contact. Each element becomes a ``LinkCollision``:
its pose on the link and its geometry as a scene ``collision`` entry, or the one line that
says what is wrong with it, raised only when the scene uses contact.
"""

import math
from dataclasses import dataclass

import numpy as np

from affine_joint_sim.rotations import pose_matrix

__all__ = ['LinkCollision', 'read_collisions']

# <geometry> child -> (attribute, count) of each number it needs
_GEOMETRY = {'box': (('size', 3),), 'sphere': (('radius', 1),),
             'cylinder': (('radius', 1), ('length', 1)),
             'capsule': (('radius', 1), ('length', 1)), 'mesh': ()}


@dataclass(frozen=True)
class LinkCollision:
    """One ``<collision>`` of a link.

    Attributes:
        link: the link's name.
        line: its line in the URDF file.
        origin: its pose in the link's frame (4×4, portable rounding).
        geometry: the scene collision geometry without origin (``{'box': [...]}``,
            ``{'sphere': {'radius'}}``, ``{'mesh': {'uri', 'scale'}}``, ...), or None.
        problem: why it cannot be used (then ``geometry`` is None), else None.
    """

    link: str
    line: int
    origin: np.ndarray
    geometry: dict | None
    problem: str | None = None


def read_collisions(root) -> list[LinkCollision]:
    """Every ``<collision>`` of every ``<link>`` of the lxml ``<robot>`` element ``root``."""
    out = []
    for link in root.iterchildren('link'):
        for element in link.findall('collision'):
            out.append(_read(link.get('name'), element))
    return out


def _read(link: str, element) -> LinkCollision:
    line = element.sourceline
    try:
        origin = _origin(element.find('origin'))
    except ValueError as exc:
        return LinkCollision(link, line, np.eye(4), None, f'<origin> {exc}')
    geometry = element.find('geometry')
    shapes = [] if geometry is None else [el for el in geometry if isinstance(el.tag, str)]
    if len(shapes) != 1:
        return LinkCollision(link, line, origin, None,
                             f'{len(shapes)} shapes in its <geometry>, expected one')
    shape = shapes[0]
    if shape.tag not in _GEOMETRY:
        return LinkCollision(link, line, origin, None,
                             f'<{shape.tag}> geometry (known: {", ".join(_GEOMETRY)})')
    try:
        values = {key: _numbers(shape, key, count) for key, count in _GEOMETRY[shape.tag]}
        for key, numbers in values.items():
            if min(numbers) <= 0.0:
                raise ValueError(f'<{shape.tag} {key}="{shape.get(key)}"> must be positive')
        if shape.tag == 'mesh':
            if not shape.get('filename'):
                raise ValueError('<mesh> needs filename="..."')
            scale = _numbers(shape, 'scale', None) if shape.get('scale') else [1.0]
            if len(scale) not in (1, 3):
                raise ValueError(f'<mesh scale="{shape.get("scale")}"> must be 1 or 3 numbers')
            geometry = {'mesh': {'uri': shape.get('filename'),
                                 'scale': [float(s) for s in np.broadcast_to(scale, 3)]}}
        elif shape.tag == 'box':
            geometry = {'box': values['size']}
        else:
            geometry = {shape.tag: {key: value[0] for key, value in values.items()}}
    except ValueError as exc:
        return LinkCollision(link, line, origin, None, str(exc))
    return LinkCollision(link, line, origin, geometry)


def _numbers(element, key: str, count: int | None) -> list[float]:
    """The finite numbers of attribute ``key`` (``count`` of them, None: any); ValueError
    saying what is wrong."""
    value = element.get(key)
    if value is None:
        raise ValueError(f'<{element.tag}> needs {key}="..."')
    try:
        numbers = [float(v) for v in value.split()]
    except ValueError:
        numbers = []
    if not numbers or (count is not None and len(numbers) != count) \
            or not all(math.isfinite(v) for v in numbers):
        raise ValueError(f'<{element.tag} {key}="{value}"> must be '
                         f'{count or "some"} finite number{"s" if count != 1 else ""}')
    return numbers


def _origin(element) -> np.ndarray:
    if element is None:
        return np.eye(4)
    return pose_matrix(*(_numbers(element, key, 3) if element.get(key) else [0.0] * 3
                         for key in ('xyz', 'rpy')))
