"""The scalar and matrix types of one precision, and its constants, for the stage builders.

Each stage module (affine, ortho, joints, ...) has a ``build(t)`` that closes its Warp
functions over the namespace ``t`` made here, so float64 and float32 each get their own
functions and their own kernel module (``step.build`` uses ``module="unique"``): building one
precision never changes the other's module hash, so neither recompiles the other.
"""

import math
from types import SimpleNamespace

import numpy as np
import warp as wp

__all__ = ['types_for']


def types_for(scalar) -> SimpleNamespace:
    """Types and constants for ``scalar`` (wp.float64 or wp.float32)."""
    eps = float(np.finfo(np.float64 if scalar is wp.float64 else np.float32).eps)
    # Constants are computed here, in Python: a quotient written inside a kernel is evaluated in
    # float32 even when cast to float64 (Warp 1.19), which made BDF2's 4/3 − 1/3 = 1 + 3e-8.
    return SimpleNamespace(
        name=scalar.__name__, scalar=scalar,
        numpy_scalar=np.float64 if scalar is wp.float64 else np.float32,
        vec3=wp.types.vector(length=3, dtype=scalar),
        mat33=wp.types.matrix(shape=(3, 3), dtype=scalar),
        vec12=wp.types.vector(length=12, dtype=scalar),
        mat12=wp.types.matrix(shape=(12, 12), dtype=scalar),
        # six gradient rows of one body (a prismatic joint's axis residuals)
        mat6x12=wp.types.matrix(shape=(6, 12), dtype=scalar),
        zero=scalar(0.0), half=scalar(0.5), one=scalar(1.0), two=scalar(2.0),
        three=scalar(3.0), four=scalar(4.0),
        pi=scalar(math.pi), two_pi=scalar(2.0 * math.pi),
        # relative rounding of a sum of energy terms: the line search's "no increase"
        energy_roundoff=scalar(64.0 * eps),
        # one rounding unit (machine ε)
        unit_roundoff=scalar(eps),
        # relative rounding of a Newton update: below this times the scene's extent [m] (for
        # the dimensionless affine entries: times extent / shortest lever) it is rounding noise
        update_roundoff=scalar(16.0 * eps),
        # smallest Cholesky pivot relative to its block's largest diagonal entry: a block
        # singular to rounding (a near-massless link's rotation) is regularised, not factored
        # into NaN
        pivot_floor=scalar(max(1.0e-14, 16.0 * eps)),
        # the coupled solve's stopping rᵀM⁻¹r, relative to the right-hand side's: (10⁻⁶)² in
        # float64, 100 rounding units (about (3.4·10⁻³)²) in float32
        cg_goal=scalar(max(1.0e-12, 100.0 * eps)),
        # ‖AAᵀ − I‖² of a rotation rounded to this precision stays below this
        rigid_strain=scalar((16.0 * eps) * (16.0 * eps)))
