"""portable_math against the C library and NumPy: accurate to a few units in the last place,
with the conventions the simulator relies on."""

import decimal
import math

import numpy as np
import pytest

from affine_joint_sim import portable_math as pm


def _ulps(value: float, reference: float) -> float:
    return abs(value - reference) / math.ulp(reference)


def test_sin_and_cos_are_within_two_ulps_of_the_c_library():
    rng = np.random.default_rng(0)
    xs = np.concatenate([rng.uniform(-10, 10, 4000), rng.uniform(-1e-3, 1e-3, 500),
                         rng.uniform(-1e5, 1e5, 500), [0.0, math.pi / 4, math.pi / 2, math.pi]])
    for x in xs:
        for ours, theirs in ((pm.sin(x), math.sin(x)), (pm.cos(x), math.cos(x))):
            if abs(theirs) > 1e-3:          # near a zero the absolute error is what counts
                assert _ulps(ours, theirs) <= 2.0, x
            else:
                assert abs(ours - theirs) <= 4e-16 * max(1.0, abs(x)), x


def test_atan2_is_within_four_ulps_and_in_minus_pi_to_pi():
    rng = np.random.default_rng(1)
    points = rng.normal(size=(5000, 2)) * np.exp(rng.uniform(-8, 8, (5000, 1)))
    for y, x in points:
        assert _ulps(pm.atan2(y, x), math.atan2(y, x)) <= 4.0, (y, x)
    assert pm.atan2(0.0, -1.0) == pm.atan2(-0.0, -1.0) == math.pi     # (−π, π]
    assert pm.atan2(0.0, 0.0) == 0.0
    assert pm.atan2(1.0, 0.0) == math.pi / 2 and pm.atan2(-1.0, 0.0) == -math.pi / 2


def test_half_pi_parts_sum_to_half_pi_and_multiply_exactly():
    for bits in (12, 33):
        p1, p2, p3 = pm.half_pi_parts(bits)
        assert p1 + p2 + p3 == math.pi / 2
        assert math.frexp(p1)[0] * 2 ** bits == int(math.frexp(p1)[0] * 2 ** bits)
        assert abs(p3) < 2.0 ** (-2 * bits + 1)


def test_products_equal_numpy_to_rounding():
    rng = np.random.default_rng(2)
    a, b, v = rng.normal(size=(4, 3)), rng.normal(size=(3, 5)), rng.normal(size=3)
    np.testing.assert_allclose(pm.matmul(a, b), a @ b, rtol=0, atol=1e-14)
    np.testing.assert_allclose(pm.matmul(a, v), a @ v, rtol=0, atol=1e-14)
    np.testing.assert_allclose(pm.matmul(v, b), v @ b, rtol=0, atol=1e-14)
    assert pm.dot(v, v) == pytest.approx(v @ v, rel=1e-15)
    np.testing.assert_array_equal(pm.cross(v, a[0]), np.cross(v, a[0]))


@pytest.mark.parametrize('seed', range(5))
def test_symmetric_eigen_diagonalises_with_one_definite_frame(seed):
    rng = np.random.default_rng(seed)
    m = rng.normal(size=(3, 3))
    m = m + m.T
    values, vectors = pm.symmetric_eigen(m)
    np.testing.assert_allclose(values, np.linalg.eigvalsh(m), rtol=0, atol=1e-13)
    np.testing.assert_allclose(vectors @ np.diag(values) @ vectors.T, m, rtol=0, atol=1e-13)
    np.testing.assert_allclose(vectors.T @ vectors, np.eye(3), rtol=0, atol=1e-14)
    assert np.linalg.det(vectors) > 0.0
    for column in vectors.T[:2]:            # the largest entry of each axis is positive
        assert column[np.argmax(np.abs(column))] > 0.0


def test_symmetric_eigen_of_a_diagonal_tensor_keeps_the_axes():
    """Equal moments (a symmetric link) leave nothing to choose: the given axes, sorted."""
    values, vectors = pm.symmetric_eigen(np.diag([2.0, 1.0, 2.0]))
    np.testing.assert_array_equal(values, [1.0, 2.0, 2.0])
    np.testing.assert_array_equal(np.abs(vectors), [[0, 1, 0], [1, 0, 0], [0, 0, 1]])
    assert np.linalg.det(vectors) == 1.0


def _exact_cbrt(x: float) -> float:
    """x^(1/3) rounded once from 40 significant digits: NumPy's cbrt is the C library's, whose
    last bit differs between machines (2 ulps from this one on some CPUs)."""
    with decimal.localcontext() as context:
        context.prec = 40
        return float(decimal.Decimal(x) ** (decimal.Decimal(1) / 3))


def test_cbrt_is_within_an_ulp_of_the_exact_cube_root():
    rng = np.random.default_rng(3)
    for x in np.concatenate([np.exp(rng.uniform(-40, 40, 3000)), [1.0, 8.0, 27.0, 1e-300]]):
        assert _ulps(pm.cbrt(x), _exact_cbrt(float(x))) <= 1.0, x
        assert pm.cbrt(-x) == -pm.cbrt(x)
    assert pm.cbrt(0.0) == 0.0 and pm.cbrt(8.0) == 2.0
