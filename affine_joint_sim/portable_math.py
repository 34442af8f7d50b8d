"""Arithmetic whose results are the same bits on every x86-64 machine (NumPy and Python only).

The C library's sin, cos, atan2, ... and BLAS/LAPACK pick an implementation by CPU features
when they load (glibc's FMA and AVX2 variants, OpenBLAS's per-core kernels, NumPy's AVX-512
loops), so they may round differently on another machine. Everything that turns a scene into
the simulated model, and the kernels' own sin and atan2 (``physics.stages.kernel_math``), use these
instead: only +, −, ×, ÷ and √, which IEEE 754 rounds the same way everywhere, in a fixed
order. They are accurate to a few units in the last place (tested against the C library),
not correctly rounded: what they guarantee is the same result on every machine
(docs/physics.md#reproducibility).
"""

import math
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np

__all__ = ['SIN_COEFFICIENTS', 'COS_COEFFICIENTS', 'ATAN_COEFFICIENTS', 'HALF_PI',
           'TAN_PI_8', 'half_pi_parts', 'sin', 'cos', 'atan2', 'matmul', 'dot', 'norm',
           'cross', 'cbrt', 'symmetric_eigen']

# π to 100 digits: the splits of π/2 below need more bits than a float holds.
_PI = Decimal('3.14159265358979323846264338327950288419716939937510582097494459230781640628620'
              '899862803482534211706798')

# Taylor coefficients on the reduced ranges (|r| ≤ π/4 for sin and cos, |u| ≤ tan(π/32) for
# atan): the first omitted term is below 2⁻⁵³ of the result there.
SIN_COEFFICIENTS = tuple(float(Fraction((-1) ** n, math.factorial(2 * n + 1)))
                         for n in range(1, 9))     # r³ … r¹⁷
COS_COEFFICIENTS = tuple(float(Fraction((-1) ** n, math.factorial(2 * n)))
                         for n in range(1, 10))    # r² … r¹⁸
ATAN_COEFFICIENTS = tuple(float(Fraction((-1) ** n, 2 * n + 1)) for n in range(1, 9))
HALF_PI = float(_PI / 2)
TAN_PI_8 = math.sqrt(2.0) - 1.0
# log m = 2 artanh s = 2 (s + s³/3 + s⁵/5 + …), s = (m − 1)/(m + 1), |s| ≤ 3 − 2√2 for
# m in [√½, √2): the first omitted term (s²⁵/25) is below 2⁻⁵³ of the result there
LOG_COEFFICIENTS = tuple(float(Fraction(1, 2 * n + 1)) for n in range(1, 12))   # s² … s²²
_LN2 = Decimal('0.693147180559945309417232121458176568075500134360255254120680009493393621')
# ln 2 in two parts, the first with 32 bits so that k·LN2_HI is exact for |k| < 2²¹
LN2_HI = float(Fraction(round(Fraction(_LN2) * 2 ** 32), 2 ** 32))
LN2_LO = float(Fraction(_LN2) - Fraction(LN2_HI))


def half_pi_parts(bits: int) -> tuple[float, float, float]:
    """π/2 as p1 + p2 + p3, p1 and p2 with ``bits`` significant bits (Cody and Waite), so that
    k·p1 and k·p2 are exact for |k| < 2^(precision − bits) and x − k·p1 − k·p2 − k·p3 keeps
    the reduced argument's bits."""
    with localcontext() as ctx:
        ctx.prec = 80
        rest = _PI / 2
        parts = []
        for _ in range(2):
            mantissa, exponent = math.frexp(float(rest))
            part = math.ldexp(math.floor(math.ldexp(mantissa, bits)), exponent - bits)
            parts.append(part)
            rest -= Decimal(part)
        parts.append(float(rest))
    return tuple(parts)


_PARTS = half_pi_parts(33)


def _horner(z: float, coefficients) -> float:
    out = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        out = c + z * out
    return out


def _reduce(x: float) -> tuple[float, int]:
    """r ∈ [−π/4, π/4] and the quadrant k mod 4 with x = r + k·π/2 (|x| < 2²⁰·π/2)."""
    k = round(x / HALF_PI)
    r = ((x - k * _PARTS[0]) - k * _PARTS[1]) - k * _PARTS[2]
    return r, k % 4


def _sin_cos_reduced(r: float) -> tuple[float, float]:
    z = r * r
    return r + r * (z * _horner(z, SIN_COEFFICIENTS)), 1.0 + z * _horner(z, COS_COEFFICIENTS)


def sin(x: float) -> float:
    """sin x [x in rad, |x| < 1.6e6]."""
    r, quadrant = _reduce(float(x))
    s, c = _sin_cos_reduced(r)
    return (s, c, -s, -c)[quadrant]


def cos(x: float) -> float:
    """cos x [x in rad, |x| < 1.6e6]."""
    r, quadrant = _reduce(float(x))
    s, c = _sin_cos_reduced(r)
    return (c, -s, -c, s)[quadrant]


def atan2(y: float, x: float) -> float:
    """The angle of (x, y) in (−π, π] [rad]; 0 for (0, 0)."""
    ax, ay = abs(float(x)), abs(float(y))
    if ax == 0.0 and ay == 0.0:
        return 0.0
    t = min(ax, ay) / max(ax, ay)
    base = 0.0
    if t > TAN_PI_8:
        t, base = (t - 1.0) / (t + 1.0), 0.5 * HALF_PI
    for _ in range(2):                 # tan(a/2) = tan a / (1 + √(1 + tan² a))
        t = t / (1.0 + math.sqrt(1.0 + t * t))
    angle = base + 4.0 * (t + t * (t * t * _horner(t * t, ATAN_COEFFICIENTS)))
    if ay > ax:
        angle = HALF_PI - angle
    if x < 0.0:
        angle = 2.0 * HALF_PI - angle
    return -angle if y < 0.0 else angle


def cbrt(x: float) -> float:
    """The real cube root of x (Newton's iteration on a mantissa in [1/8, 1); Python's
    ``x ** (1/3)`` calls the C library's pow)."""
    x = float(x)
    if x == 0.0 or not math.isfinite(x):
        return x
    mantissa, exponent = math.frexp(abs(x))
    while exponent % 3:                  # x = mantissa · 2^exponent, exponent a multiple of 3
        mantissa, exponent = 0.5 * mantissa, exponent + 1
    root = 0.5 + 0.5 * mantissa
    for _ in range(8):
        root = root - (root * root * root - mantissa) / (3.0 * root * root)
    return math.copysign(math.ldexp(root, exponent // 3), x)


def matmul(a, b) -> np.ndarray:
    """a @ b for small matrices (or a matrix and a vector), summed in index order."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if b.ndim == 1:
        return (matmul(a, b[:, None]))[..., 0]
    if a.ndim == 1:
        return matmul(a[None, :], b)[0]
    out = a[..., :, 0:1] * b[..., 0:1, :]
    for k in range(1, a.shape[-1]):
        out = out + a[..., :, k:k + 1] * b[..., k:k + 1, :]
    return out


def dot(a, b) -> float:
    """a · b of two vectors, summed in index order."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    out = a[0] * b[0]
    for k in range(1, a.shape[0]):
        out = out + a[k] * b[k]
    return float(out)


def norm(a) -> float:
    """|a| of a vector."""
    return math.sqrt(dot(a, a))


def cross(a, b) -> np.ndarray:
    """a × b of two 3-vectors."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def symmetric_eigen(matrix, sweeps: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors (columns, det +1) of a symmetric 3×3 matrix.

    Cyclic Jacobi rotations until the off-diagonal entries vanish against the diagonal; each
    eigenvector's largest entry (the first of equals) is made positive, then the last one is
    flipped if needed for det +1, so the frame is one definite choice on every machine.
    """
    a = [[float(v) for v in row] for row in np.asarray(matrix, dtype=np.float64)]
    v = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    for _ in range(sweeps):
        if all(abs(a[p][q]) <= 1e-18 * (abs(a[p][p]) + abs(a[q][q]))
               for p, q in ((0, 1), (0, 2), (1, 2))):
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            if a[p][q] == 0.0:
                continue
            theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
            t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
            t = -t if theta < 0.0 else t
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):         # columns p, q of a·J
                akp, akq = a[k][p], a[k][q]
                a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
            for k in range(3):         # rows p, q of Jᵀ·(a·J)
                apk, aqk = a[p][k], a[q][k]
                a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
            for k in range(3):
                vkp, vkq = v[k][p], v[k][q]
                v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    order = sorted(range(3), key=lambda i: (a[i][i], i))
    values = np.array([a[i][i] for i in order])
    vectors = np.array([[v[k][i] for i in order] for k in range(3)])
    for i in range(3):
        column = vectors[:, i]
        if column[int(np.argmax(np.abs(column)))] < 0.0:
            vectors[:, i] = -column
    if dot(cross(vectors[:, 0], vectors[:, 1]), vectors[:, 2]) < 0.0:
        vectors[:, 2] = -vectors[:, 2]
    return values, vectors
