"""Reading a URDF file: XML checks with line numbers, then yourdfpy's parse (no meshes).

yourdfpy parses the elements but reports a missing attribute as a bare ``KeyError`` and
refuses a file for geometry it does not know (``<capsule>``); the checks here come first so
that a user reads which element on which line is wrong, and geometry cannot stop a robot from
loading: ``<collision>`` elements are read here (``urdf.collisions``, checked only when the
scene uses contact) and dropped before yourdfpy parses, and a visual whose geometry yourdfpy
cannot read is dropped with a note. The poses the simulation uses (joint and
inertial ``<origin>``) are computed again with ``rotations.pose_matrix``: yourdfpy's come from
the C library's sin and cos and BLAS, which round differently on other machines
(docs/physics.md#reproducibility).
"""

import io
import logging
import math
from pathlib import Path

import numpy as np
from lxml import etree

from affine_joint_sim.rotations import pose_matrix
from affine_joint_sim.scene import SceneError
from affine_joint_sim.urdf.collisions import read_collisions

__all__ = ['read_urdf', 'read_xml', 'JOINT_TYPES']

# URDF's joint types (urdfdom); the converter says what it does with each
JOINT_TYPES = ('revolute', 'continuous', 'prismatic', 'fixed', 'floating', 'planar')
_XACRO = 'http://www.ros.org/wiki/xacro'
_GEOMETRIES = ('box', 'cylinder', 'sphere', 'mesh')      # what yourdfpy reads


def read_xml(path, kind: str):
    """(the bytes, the lxml root element) of the XML file at ``path``, entities and network
    off; SceneError naming the file if it cannot be read (a ``kind`` file) or parsed."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise SceneError(f'{path}: cannot read {kind} file ({exc.strerror})') from None
    parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_comments=True)
    try:
        return data, etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise SceneError(f'{path}: not valid XML: {exc.msg}') from None


def read_urdf(path):
    """The URDF text, its yourdfpy ``Robot``, its collisions (``LinkCollision`` list) and
    notes about visuals that were dropped; SceneError naming the file (and line)."""
    data, root = read_xml(path, 'URDF')
    _check_elements(path, root)
    encoding = root.getroottree().docinfo.encoding or 'utf-8'
    try:
        text = data.decode(encoding)
    except (UnicodeDecodeError, LookupError) as exc:
        raise SceneError(f'{path}: not {encoding} text as it declares ({exc})') from None
    collisions = read_collisions(root)
    notes = _drop_unused_geometry(root)
    robot = _parse(path, etree.tostring(root))
    _portable_origins(root, robot)
    return text, robot, collisions, [f'{path}: {note}' for note in notes]


def _portable_origins(root, robot) -> None:
    """Replace the origins of ``robot``'s joints and inertials by the portable poses of the
    same ``<origin xyz rpy>`` (yourdfpy has parsed and checked them already)."""
    joints = {joint.name: joint for joint in robot.joints}
    links = {link.name: link for link in robot.links}
    for element in root.findall('joint'):
        joint, origin = joints.get(element.get('name')), element.find('origin')
        if joint is not None and origin is not None:
            joint.origin = _pose(origin)
    for element in root.findall('link'):
        link, origin = links.get(element.get('name')), element.find('inertial/origin')
        if link is not None and link.inertial is not None and origin is not None:
            link.inertial.origin = _pose(origin)


def _pose(origin) -> np.ndarray:
    return pose_matrix([float(v) for v in origin.get('xyz', '0 0 0').split()],
                       [float(v) for v in origin.get('rpy', '0 0 0').split()])


def _drop_unused_geometry(root) -> list[str]:
    """Remove ``<collision>`` elements (read already) and visuals yourdfpy cannot read; notes
    on the latter."""
    notes = []
    for link in root.iterchildren('link'):
        for collision in link.findall('collision'):
            link.remove(collision)
        for visual in link.findall('visual'):
            geometry = visual.find('geometry')
            shapes = [] if geometry is None else [
                el for el in geometry if isinstance(el.tag, str)]
            problem = None
            if len(shapes) != 1:
                problem = f'{len(shapes)} shapes in its <geometry>, expected one'
            elif shapes[0].tag not in _GEOMETRIES:
                problem = f'<{shapes[0].tag}> geometry'
            elif shapes[0].tag == 'mesh' and not shapes[0].get('filename'):
                problem = '<mesh> without a filename'
            if problem:
                link.remove(visual)
                notes.append(f'link {link.get("name")!r}: a visual (line {visual.sourceline}) '
                             f'with {problem} is not drawn')
    return notes


def _check_elements(path, root) -> None:
    """The root is <robot>, no xacro is left, every link and joint is named, every joint has
    a known type and names its parent and child links."""
    if root.tag != 'robot':
        raise SceneError(f'{path}: not a URDF: the root element is <{root.tag}>, expected '
                         '<robot>')
    for element in root.iter():
        for key, value in element.attrib.items():
            if '$(' in value or '${' in value:
                raise SceneError(f'{path}:{element.sourceline}: <{element.tag} {key}="{value}">'
                                 ' is an unexpanded xacro or launch substitution: expand the '
                                 f'file first (xacro {path.name} > robot.urdf)')
    if any(isinstance(el.tag, str) and el.tag.startswith('{' + _XACRO) for el in root.iter()):
        raise SceneError(f'{path}: contains xacro macros: expand it first '
                         f'(xacro {path.name} > robot.urdf)')
    if root.find('link') is None:
        raise SceneError(f'{path}: the robot has no <link>')
    for element in root.iterchildren('link', 'joint'):
        where = f'{path}:{element.sourceline}: <{element.tag}>'
        if not element.get('name', '').strip():
            raise SceneError(f'{where} has no name attribute')
        if element.tag == 'link':
            continue
        where = f'{where} {element.get("name")!r}'
        kind = element.get('type')
        if kind not in JOINT_TYPES:
            raise SceneError(f'{where}: type {kind!r} is not a URDF joint type '
                             f'({", ".join(JOINT_TYPES)})')
        for side in ('parent', 'child'):
            tag = element.find(side)
            if tag is None or not tag.get('link'):
                raise SceneError(f'{where} needs <{side} link="..."/>')
    _check_numbers(path, root)


# The numeric attributes the simulator reads: (element path under <link> or <joint>, attribute,
# how many numbers, required, whether ±inf is valid).
_NUMBERS = {
    'joint': [('origin', 'xyz', 3, False, False), ('origin', 'rpy', 3, False, False),
              ('axis', 'xyz', 3, True, False), ('limit', 'lower', 1, False, True),
              ('limit', 'upper', 1, False, True), ('limit', 'effort', 1, False, True),
              ('limit', 'velocity', 1, False, True), ('dynamics', 'damping', 1, False, False),
              ('dynamics', 'friction', 1, False, False)],
    'link': [('inertial/origin', 'xyz', 3, False, False),
             ('inertial/origin', 'rpy', 3, False, False),
             ('inertial/mass', 'value', 1, True, False),
             *[('inertial/inertia', key, 1, True, False)
               for key in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')],
             ('visual/origin', 'xyz', 3, False, False), ('visual/origin', 'rpy', 3, False, False),
             ('visual/geometry/box', 'size', 3, True, False),
             ('visual/geometry/cylinder', 'radius', 1, True, False),
             ('visual/geometry/cylinder', 'length', 1, True, False),
             ('visual/geometry/sphere', 'radius', 1, True, False)],
}


def _check_numbers(path, root) -> None:
    """Every numeric attribute the simulator reads is there when required and holds as many
    finite numbers as it should (±inf only for limits); else one line naming the file, line,
    element and its link or joint."""
    for owner in root.iterchildren('link', 'joint'):
        name = f'{owner.tag} {owner.get("name")!r}'
        for where, key, count, required, infinite in _NUMBERS[owner.tag]:
            for element in owner.findall(where):
                value = element.get(key)
                spot = f'{path}:{element.sourceline}: <{element.tag}> of {name}'
                if value is None:
                    if required:
                        raise SceneError(f'{spot} needs {key}="..." ({count} number'
                                         f'{"s" if count > 1 else ""})')
                    continue
                try:
                    numbers = [float(v) for v in value.split()]
                except ValueError:
                    numbers = None
                if numbers is None or len(numbers) != count or not all(
                        math.isfinite(v) or (infinite and not math.isnan(v)) for v in numbers):
                    kind = 'numbers' if count > 1 else 'number'
                    raise SceneError(f'{spot}: {key}="{value}" must be {count} finite {kind}'
                                     + (' (or ±inf)' if infinite else ''))


def _parse(path, data: bytes):
    import yourdfpy

    logging.getLogger('yourdfpy').setLevel(logging.CRITICAL)   # its errors are re-raised here
    try:
        urdf = yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False,
                                  load_collision_meshes=False)
    except (ValueError, KeyError, TypeError, AttributeError, IndexError) as exc:
        raise SceneError(f'{path}: malformed URDF ({type(exc).__name__}: {exc})') from None
    return urdf.robot
