"""A robot's SRDF: the link pairs its ``<disable_collisions>`` elements say never touch
(README.md#contact), as MoveIt's setup assistant writes them for adjacent links, links that
are always in collision, and links that can never meet."""

from pathlib import Path

from affine_joint_sim.scene import SceneError
from affine_joint_sim.urdf.read import read_xml

__all__ = ['DisabledPair', 'disabled_pairs']


class DisabledPair:
    """One ``<disable_collisions link1 link2>``: the two link names and its line."""

    def __init__(self, link1: str, link2: str, line: int):
        self.link1, self.link2, self.line = link1, link2, line


def disabled_pairs(path: Path) -> list[DisabledPair]:
    """The ``<disable_collisions>`` pairs of the SRDF at ``path``; SceneError naming the file
    (and line) if it cannot be read or an element lacks a link."""
    data, root = read_xml(path, 'SRDF')
    pairs = []
    for element in root.iter('disable_collisions'):
        links = [element.get('link1'), element.get('link2')]
        if not all(links):
            raise SceneError(f'{path}:{element.sourceline}: <disable_collisions> needs link1 '
                             'and link2')
        pairs.append(DisabledPair(*links, element.sourceline))
    return pairs
