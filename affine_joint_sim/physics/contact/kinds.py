"""The kinds of contact: the static shape kinds and the families of pairs between two moving
bodies, one descriptor each, the only list of them (no Warp, no NumPy).

A fixed body's collision geometry becomes static shapes (``contact.shapes``), each of a kind
here; a kind's code is its value in ``model.shape_kind``. A pair of two moving bodies is of a
family here; its code is what ``body_pair`` (host ``contact.pairs``, kernel
``contact.geometry``) returns for it, and its blocks follow ``BODY_FAMILIES`` (the points of
the first body against the faces of the other and back, then edges against edges). Every
place that tells them apart compares with these codes, never with a bare number: the model
build (``contact.shapes``, ``contact.primitives.static_surfaces``, ``contact.model``), the
host's pair numbering and near list (``contact.pairs``) and the kernel (``contact.geometry``,
``contact.terms``),
whose ``shape_kind`` and ``shape_size`` fields are documented from this table. The pairs with
a static side come first, numbered family by family: a contact point against each half-space
and static shape, a moving edge against each static edge, a moving face against each static
vertex (docs/architecture.md#adding-a-contact-primitive).
"""

from dataclasses import dataclass

__all__ = ['ShapeKind', 'SHAPE_KINDS', 'SHAPE_CODES', 'BOX', 'SPHERE', 'CAPSULE', 'CYLINDER',
           'TRIANGLE', 'BodyFamily', 'BODY_FAMILIES', 'POINT_FACE', 'EDGE_EDGE', 'TOUCH_CHUNK']


@dataclass(frozen=True)
class ShapeKind:
    """What a static shape kind is, as the host and the kernels see it."""

    name: str       # its geometry's kind in a scene; 'triangle': each triangle of a fixed mesh
    code: int       # its value in model.shape_kind (codes are 1, 2, ...)
    size: str       # what model.shape_size holds for it [m]


BOX = ShapeKind('box', 1, 'half sides')
SPHERE = ShapeKind('sphere', 2, '(ρ, 0, 0)')
CAPSULE = ShapeKind('capsule', 3, '(ρ, half length along its z, 0)')
CYLINDER = ShapeKind('cylinder', 4, '(ρ, half length along its z, 0)')
TRIANGLE = ShapeKind('triangle', 5, '(the largest distance of a vertex from its centroid, '
                     '0, 0)')

SHAPE_KINDS = (BOX, SPHERE, CAPSULE, CYLINDER, TRIANGLE)     # in code order
SHAPE_CODES = {kind.name: kind.code for kind in SHAPE_KINDS}


@dataclass(frozen=True)
class BodyFamily:
    """A family of pairs between two moving bodies."""

    name: str       # first side's primitive – the other body's
    code: int       # what body_pair returns for it (codes are 0, 1, ...)
    first: str      # the primitive of the first side ('point', 'edge'): body_first_<first>
    other: str      # the other side's ('face', 'edge'): body_first_<other>


POINT_FACE = BodyFamily('point–face', 0, 'point', 'face')
EDGE_EDGE = BodyFamily('edge–edge', 1, 'edge', 'edge')

BODY_FAMILIES = (POINT_FACE, EDGE_EDGE)                     # in code order

# pairs of bodies' pairs per entry of the model field touch_chunk, which finds a pair's pair of
# bodies (a box against a box numbers 336 pairs, a sphere against a sphere one)
TOUCH_CHUNK = 64
