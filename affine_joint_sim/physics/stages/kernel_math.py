"""The kernels' sin, atan2 and log, the CPU compile options that keep every kernel's rounding the
same on every x86-64 machine (docs/physics.md#reproducibility), and the salt that ties a
compiled kernel to the physics sources it was built from.

Warp compiles CPU kernels for the host's instruction set and calls the C library for
transcendental functions. Both vary between machines: the C library picks its sin and atan2
by CPU features, and LLVM fuses a product and a sum into one FMA (one rounding instead of two)
wherever the host has FMA, in places that depend on how it vectorizes for that host. Here
sin, atan2 and log are built from +, −, ×, ÷ and √ (the algorithms and coefficients of
``affine_joint_sim.portable_math``), and ``kernel_options`` turns contraction off while
keeping the host's vector width: vector lanes round exactly like scalars, so only fusion
changed bits. The fma() that Warp's matrix products call is rounded once on every machine.
"""

import ast
import hashlib
import importlib
import importlib.util
import math
from pathlib import Path
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.portable_math import (ATAN_COEFFICIENTS, COS_COEFFICIENTS, HALF_PI,
                                            LN2_HI, LN2_LO, LOG_COEFFICIENTS,
                                            SIN_COEFFICIENTS, TAN_PI_8, half_pi_parts)

__all__ = ['build', 'kernel_options', 'kernel_sources', 'source_salt']

# No contraction of a·b + c into one FMA by the front end (Warp's fuse_fp=False stops the back
# end): an FMA only where the code asks for one (fma(), which is exactly rounded everywhere).
_NO_FUSION = '-ffp-contract=off'
# the CPU's optimization: clang's last -O wins over Warp's level (2, which CUDA keeps)
_CPU_LEVEL = '-O3'


def kernel_options() -> dict:
    """Warp module options of every kernel module: Warp's CPU compiler flags (the global
    setting: by default ``-march=native`` and its inlining and SLP options) without FMA
    contraction and at clang's ``-O3`` (after the level's ``-O2``: the same IEEE operations,
    README "Performance"); optimization level 2, on CUDA NVRTC's
    ``--Ofast-compile=min``, under which ptxas keeps a ``__noinline__`` function out of line
    (physics.stages.out_of_line; at level 3 it inlines every one of them again and took 6–8 minutes
    over the step kernel with pairs of bodies); and NVRTC's compile-time trace (a JSON file of
    each function's optimisation time beside the cubin; the CPU's compile ignores it), with
    which NVRTC finished the step kernel in about a minute where without it it had not in five
    (measured, not explained: docs/architecture.md, "The step kernel")."""
    flags = wp.config.cpu_compiler_flags
    flags = '-march=native' if flags is None else flags
    return {'cpu_compiler_flags': f'{flags} {_NO_FUSION} {_CPU_LEVEL}'.strip(), 'fuse_fp': False,
            'optimization_level': 2, 'compile_time_trace': True}


def kernel_sources(modules) -> list[Path]:
    """The source files a kernel is built from: those of ``modules`` (of a package, every file
    in its folder: the joint types' modules are imported by name) and of every module of this
    project they import, transitively (read from their import statements)."""
    files = set()
    todo = [file for module in modules for file in _files(Path(module.__file__))]
    while todo:
        file = todo.pop()
        if file not in files:
            files.add(file)
            todo.extend(Path(module.__file__) for module in _imported(file))
    return sorted(files)


def _files(path: Path) -> list[Path]:
    """A module's source file, or a package's every file."""
    return sorted(path.parent.glob('*.py')) if path.name == '__init__.py' else [path]


def _imported(file: Path) -> list:
    """The modules of this project that the source ``file`` imports (``from a import b``: b
    where it is a module, else a)."""
    names = []
    for node in ast.walk(ast.parse(file.read_text())):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names += [f'{node.module}.{alias.name}' if _is_module(f'{node.module}.{alias.name}')
                      else node.module for alias in node.names]
    own = __name__.split('.')[0]
    return [importlib.import_module(name) for name in set(names) if name.split('.')[0] == own]


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:         # a name a module defines, not a module
        return False


def source_salt(modules) -> int:
    """A 28-bit digest of the sources a kernel is built from (``kernel_sources``), for it to
    name (``wp.static(source_salt)``). Warp's module hash misses the functions a dispatcher
    picks by ``wp.static`` inside a loop over types (it keys them by the expression's text), so
    a changed joint type kept loading the kernel compiled before the change from Warp's cache;
    with the salt, any change to those sources recompiles the kernel, and a change to any other
    file (the host's model build, the report's or the sensors' kernel) keeps it."""
    digest = hashlib.sha256()
    for path in kernel_sources(modules):
        digest.update(path.read_bytes())
    return int(digest.hexdigest()[:7], 16)


def build(t) -> SimpleNamespace:
    """sin, atan2 and the kernel module options for the types namespace ``t``."""
    scalar, zero, one, four = t.scalar, t.zero, t.one, t.four
    two = t.two
    # π/2 in three parts whose products with the quadrant number are exact in this precision
    p1, p2, p3 = (scalar(p) for p in half_pi_parts(33 if scalar is wp.float64 else 12))
    half_pi, quarter_pi, pi = scalar(HALF_PI), scalar(0.5 * HALF_PI), scalar(2.0 * HALF_PI)
    inv_half_pi = scalar(1.0 / HALF_PI)
    tan_pi_8 = scalar(TAN_PI_8)
    s3, s5, s7, s9, s11, s13, s15, s17 = (scalar(c) for c in SIN_COEFFICIENTS)
    c2, c4, c6, c8, c10, c12, c14, c16, c18 = (scalar(c) for c in COS_COEFFICIENTS)
    a3, a5, a7, a9, a11, a13, a15, a17 = (scalar(c) for c in ATAN_COEFFICIENTS)
    l3, l5, l7, l9, l11, l13, l15, l17, l19, l21, l23 = (scalar(c) for c in LOG_COEFFICIENTS)
    ln2_hi, ln2_lo = scalar(LN2_HI), scalar(LN2_LO)
    sqrt_half, sqrt_two, two32, inv_two32 = (scalar(math.sqrt(0.5)), scalar(math.sqrt(2.0)),
                                             scalar(2.0 ** 32), scalar(2.0 ** -32))

    @wp.func
    def sin(x: scalar):
        """sin x [x in rad; |x| < 1e6 in float64, < 6e3 in float32]."""
        k = wp.round(x * inv_half_pi)
        r = ((x - k * p1) - k * p2) - k * p3
        z = r * r
        s = r + r * (z * (s3 + z * (s5 + z * (s7 + z * (s9 + z * (s11 + z * (
            s13 + z * (s15 + z * s17))))))))
        c = one + z * (c2 + z * (c4 + z * (c6 + z * (c8 + z * (c10 + z * (c12 + z * (
            c14 + z * (c16 + z * c18))))))))
        quadrant = int(k) % 4
        if quadrant < 0:
            quadrant = quadrant + 4
        out = s
        if quadrant == 1:
            out = c
        elif quadrant == 2:
            out = -s
        elif quadrant == 3:
            out = -c
        return out

    @wp.func
    def atan2(y: scalar, x: scalar):
        """The angle of (x, y) in (−π, π] [rad]; 0 for (0, 0)."""
        ax = wp.abs(x)
        ay = wp.abs(y)
        angle = zero
        if ax > zero or ay > zero:
            t = wp.min(ax, ay) / wp.max(ax, ay)
            base = zero
            if t > tan_pi_8:
                t = (t - one) / (t + one)
                base = quarter_pi
            for _ in range(2):     # tan(a/2) = tan a / (1 + √(1 + tan² a))
                t = t / (one + wp.sqrt(one + t * t))
            z = t * t
            angle = base + four * (t + t * (z * (a3 + z * (a5 + z * (a7 + z * (a9 + z * (
                a11 + z * (a13 + z * (a15 + z * a17)))))))))
            if ay > ax:
                angle = half_pi - angle
            if x < zero:
                angle = pi - angle
            if y < zero:
                angle = -angle
        return angle

    @wp.func
    def log(x: scalar):
        """ln x for finite x > 0: x = m 2^k with m in [√½, √2) by exact scalings by powers of
        two, then 2 artanh((m − 1)/(m + 1)) as a series (portable_math.LOG_COEFFICIENTS) plus
        k ln 2 in two parts."""
        m = x
        k = zero
        while m < inv_two32:
            m = m * two32
            k = k - scalar(32.0)
        while m > two32:
            m = m * inv_two32
            k = k + scalar(32.0)
        while m < sqrt_half:
            m = m * scalar(2.0)
            k = k - one
        while m >= sqrt_two:
            m = m * scalar(0.5)
            k = k + one
        s = (m - one) / (m + one)
        z = s * s
        series = two * s * (one + z * (l3 + z * (l5 + z * (l7 + z * (l9 + z * (l11 + z * (
            l13 + z * (l15 + z * (l17 + z * (l19 + z * (l21 + z * l23)))))))))))
        return (k * ln2_lo + series) + k * ln2_hi

    return SimpleNamespace(sin=sin, atan2=atan2, log=log, kernel_options=kernel_options())
