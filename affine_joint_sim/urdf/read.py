"""Reading a URDF file: XML checks with line numbers, then yourdfpy's parse (no meshes).

yourdfpy parses the elements but reports a missing attribute as a bare ``KeyError``; the
checks here come first so that a user reads which element on which line is wrong.
"""

import io
import logging

from lxml import etree

from affine_joint_sim.scene import SceneError

__all__ = ['read_urdf', 'JOINT_TYPES']

# URDF's joint types (urdfdom); the converter says what it does with each
JOINT_TYPES = ('revolute', 'continuous', 'prismatic', 'fixed', 'floating', 'planar')
_XACRO = 'http://www.ros.org/wiki/xacro'


def read_urdf(path):
    """The URDF text and its yourdfpy ``Robot``; SceneError naming the file (and line)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f'{path}: cannot read URDF file ({exc.strerror})') from None
    parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_comments=True)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        raise SceneError(f'{path}: not valid XML: {exc.msg}') from None
    _check_elements(path, root)
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise SceneError(f'{path}: not UTF-8 text (byte {exc.start})') from None
    return text, _parse(path, data)


def _check_elements(path, root) -> None:
    """The root is <robot>, no xacro is left, every link and joint is named, every joint has
    a known type and names its parent and child links."""
    if root.tag != 'robot':
        raise SceneError(f'{path}: not a URDF: the root element is <{root.tag}>, expected '
                         '<robot>')
    if any(isinstance(el.tag, str) and el.tag.startswith('{' + _XACRO) for el in root.iter()):
        raise SceneError(f'{path}: contains xacro macros: expand it first '
                         f'(xacro {path.name} > robot.urdf)')
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
