"""The kernels' own sin and atan2 (physics.stages.kernel_math) against the C library, in both
precisions: a few units in the last place, and atan2's (−π, π] convention."""

import math

import numpy as np
import pytest
import warp as wp

from affine_joint_sim.physics.kernels import step_kernels

_KERNELS = {}


def _evaluate(scalar, x, y):
    """(sin x, atan2(y, x)) computed by the kernels' functions of precision ``scalar``."""
    if scalar not in _KERNELS:
        t = step_kernels(scalar)
        sin, atan2 = t.sin, t.atan2

        @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
        def probe(x: wp.array(dtype=scalar), y: wp.array(dtype=scalar),
                  sin_out: wp.array(dtype=scalar), atan2_out: wp.array(dtype=scalar)):
            i = wp.tid()
            sin_out[i] = sin(x[i])
            atan2_out[i] = atan2(y[i], x[i])

        _KERNELS[scalar] = probe
    dtype = np.float64 if scalar is wp.float64 else np.float32
    xs, ys = (wp.array(np.asarray(v, dtype=dtype), dtype=scalar) for v in (x, y))
    sin_out, atan2_out = (wp.zeros(len(x), dtype=scalar) for _ in range(2))
    wp.launch(_KERNELS[scalar], dim=len(x), inputs=[xs, ys, sin_out, atan2_out])
    return sin_out.numpy(), atan2_out.numpy()


@pytest.mark.parametrize('scalar, sin_ulps, atan2_ulps', [(wp.float64, 2.0, 4.0),
                                                          (wp.float32, 2.0, 4.0)])
def test_sin_and_atan2_are_within_a_few_ulps(scalar, sin_ulps, atan2_ulps):
    dtype = np.float64 if scalar is wp.float64 else np.float32
    rng = np.random.default_rng(4)
    x = np.concatenate([rng.uniform(-6.0, 6.0, 3000), rng.uniform(-1e-3, 1e-3, 300),
                        [-1.0, -2.0, 0.0, 1.0]]).astype(dtype)
    y = np.concatenate([rng.normal(size=3300), [0.0, -0.0, 0.0, -1.0]]).astype(dtype)
    sin, atan2 = _evaluate(scalar, x, y)
    for k in range(len(x)):
        xs, ys = float(x[k]), float(y[k])
        exact_sin, exact_atan2 = dtype(math.sin(xs)), dtype(math.atan2(ys, xs))
        if abs(exact_sin) > 1e-3:
            assert abs(sin[k] - exact_sin) <= sin_ulps * np.spacing(abs(exact_sin)), xs
        else:
            assert abs(sin[k] - exact_sin) <= 4 * np.finfo(dtype).eps * 1e-3, xs
        if ys != 0.0 or xs > 0.0:      # on the negative x axis libm gives −π for y = −0
            assert abs(atan2[k] - exact_atan2) <= atan2_ulps * np.spacing(abs(exact_atan2)), \
                (ys, xs)
    # (−π, π]: the negative x axis is +π whatever the sign of zero; (0, 0) is 0
    assert atan2[-4] == atan2[-3] == dtype(math.pi) and atan2[-2] == 0.0


def test_the_kernel_salt_digests_the_step_kernels_sources_and_no_host_code():
    from affine_joint_sim.physics import kernels
    from affine_joint_sim.physics.stages.kernel_math import kernel_sources

    files = kernel_sources((kernels.precision, *kernels._STAGES))
    names = {'/'.join(path.parts[-2:]) for path in files}
    # the joint types' modules (imported by name), the field tables and the contact kinds the
    # stages import, the portable math outside physics/
    assert {'joints/revolute.py', 'joints/prismatic.py', 'joints/fixed.py',
            'host/joint_kinds.py', 'host/fields.py', 'contact/geometry.py',
            'contact/terms.py', 'contact/kinds.py', 'stages/precision.py',
            'affine_joint_sim/portable_math.py'} <= names
    # editing the host's model build, the report or sensor kernels, or the package's entry
    # points keeps every compiled step kernel
    assert not names & {'host/model.py', 'contact/model.py', 'contact/pairs.py',
                        'contact/shapes.py', 'contact/report.py', 'stages/sensing.py',
                        'stages/frames.py', 'physics/kernels.py',
                        'affine_joint_sim/stepper.py',
                        'affine_joint_sim/scene.py'}
