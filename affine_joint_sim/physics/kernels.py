"""The physics pipeline of one precision, composed stage by stage into the step kernel.

``step_kernels(scalar)`` builds, once per scalar type (wp.float64 or wp.float32) and per
kind of contact (whether moving bodies touch each other), the types
and structs of ``fields``, then each stage's Warp functions in pipeline order: the portable
sin, atan2 and log and the kernels' compile options, affine kinematics, orthogonality, tree
solve, joints, joint terms, commands, contact geometry, contact, the coupled solve,
incremental potential, assembly, prediction, Newton, commit and the step kernel. Every stage
function is an attribute of the returned namespace, so tests can launch a stage on its own
(``physics.evaluate``).
"""

import functools
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics import joints
from affine_joint_sim.physics.solve import coupled_solve, newton, tree_solve
from affine_joint_sim.physics.stages import (affine, assemble, commands, commit, frames,
                                             joint_terms, kernel_math, mimic, ortho, potential,
                                             precision, prediction, sensing, step)
from affine_joint_sim.physics.contact import geometry as contact_geometry
from affine_joint_sim.physics.contact import report
from affine_joint_sim.physics.contact import terms as contact_terms
from affine_joint_sim.physics.host.fields import structs
from affine_joint_sim.physics.stages.kernel_math import source_salt

__all__ = ['step_kernels', 'scalar_of', 'frame_kernel', 'report_kernel', 'sensor_kernel']

_STAGES = (kernel_math, affine, ortho, tree_solve, joints, joint_terms, mimic, commands,
           contact_geometry, contact_terms, coupled_solve, potential, assemble, prediction, newton,
           commit, step)
_BUILT = {}
_FRAMES = {}
_REPORTS = {}
_SENSORS = {}


def step_kernels(scalar, bodies: bool = False, contact: bool = True,
                 shapes: bool = True) -> SimpleNamespace:
    """Types, structs, stage functions and the step kernel for ``scalar``, per kind of contact,
    each a kernel module of its own: without ``contact`` the step holds no contact code at all
    (``t.contact``); without ``shapes``, only the contact of points with half-spaces (no static
    shapes, meshes, edges or vertices: ``t.shapes``); with ``bodies``, the pipeline whose
    contact includes pairs of moving bodies (and the coupled solve) besides every static
    thing, so a scene whose bodies never touch each other runs code without any of it
    (``t.bodies``; all three compile-time switches of the stages). The big stages are compiled
    once each, out of line, on either device (physics.stages.out_of_line). The structs are those of
    the pipeline of the same pair kind (``bodies``) with every static thing, whatever
    ``contact`` and ``shapes``, so the report, frame and sensor kernels built from that
    pipeline take any of its variants."""
    contact = bool(contact)
    bodies = bool(bodies) and contact
    shapes = (bool(shapes) or bodies) and contact
    key = (scalar, bodies, contact, shapes)
    if key not in _BUILT:
        t = precision.types_for(scalar)
        t.bodies, t.contact, t.shapes = bodies, contact, shapes
        t.source_salt = _salt()
        t.structs = structs(t) if shapes else step_kernels(scalar, bodies).structs
        for stage in _STAGES:
            vars(t).update(vars(stage.build(t)))
        _BUILT[key] = t
    return _BUILT[key]


@functools.cache
def _salt() -> int:
    """The digest of the sources the step kernel is built from (kernel_math.source_salt)."""
    return source_salt((precision, *_STAGES))


def scalar_of(precision: str):
    """The Warp scalar type of a scene's solver.precision."""
    return wp.float64 if precision == 'float64' else wp.float32


def frame_kernel(scalar):
    """The frame-pose kernel of ``physics.stages.frames`` for ``scalar`` (built on first use)."""
    return _frames(scalar).frame_poses


def _frames(scalar):
    """``physics.stages.frames``'s namespace for ``scalar`` (built once)."""
    if scalar not in _FRAMES:
        _FRAMES[scalar] = frames.build(step_kernels(scalar))
    return _FRAMES[scalar]


def report_kernel(scalar, bodies: bool = False):
    """The contact report kernel of ``physics.contact.report`` for ``scalar`` and the pipeline with
    or without pairs of bodies (built on first use)."""
    return _report(scalar, bodies).contact_report


def _report(scalar, bodies: bool):
    """``physics.contact.report``'s namespace for ``scalar`` and the pair kind (built once)."""
    key = (scalar, bool(bodies))
    if key not in _REPORTS:
        _REPORTS[key] = report.build(step_kernels(scalar, bodies))
    return _REPORTS[key]


def sensor_kernel(scalar, bodies: bool = False, contact: bool = False):
    """The sensor kernel of ``physics.stages.sensing`` for ``scalar`` and the pipeline with or
    without pairs of bodies (its structs), with the contact sensors' code where ``contact``
    (built on first use)."""
    key = (scalar, bool(bodies), bool(contact))
    if key not in _SENSORS:
        _SENSORS[key] = sensing.build(step_kernels(scalar, bodies), _frames(scalar),
                                      _report(scalar, bodies).pair_contact if contact
                                      else None).sensor_readings
    return _SENSORS[key]
