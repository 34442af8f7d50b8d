"""``bench impacts``: what an impact does to energy, under the default contact.

A 1 kg box (0.1 m), ball (radius 5 cm) and cylinder (radius 5 cm, 0.1 m long, standing) are
dropped onto the ground from rest, their lowest point ``height`` above it, at several dt
under BDF1 and BDF2; then the packaged gripper arm with a free base falls flat from 0.4 m
(its links land one after another, joints free). Per run: the rebound (the highest the
lowest point, or the arm's centre of mass, rises once it turns up after the first contact,
above where it comes to rest) as a fraction of the fall, and the largest gain of mechanical energy
(``Stepper.energy``) in one step. A passive scene must never gain energy, and an impact
should be close to inelastic as in MuJoCo (restitution 0) and most robot simulators. The
contact damping ratio ``contact.damping`` is the knob: its curve is measured at the finest
dt, where the integrator itself damps least. Writes impacts.md and impacts.csv.
"""

import math
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.resources import config_dir

__all__ = ['FULL', 'QUICK', 'SHAPES', 'Settings', 'add_parser', 'arm_fall', 'drop', 'run']

G = 9.81                        # m/s²
SETTLE = 0.25                   # s run after the first contact: a 5 % rebound of 1 m lands
SHAPES = {'box': ({'box': [0.1, 0.1, 0.1]}, 0.05),
          'ball': ({'sphere': {'radius': 0.05}}, 0.05),
          'cylinder': ({'cylinder': {'radius': 0.05, 'length': 0.1}}, 0.05)}   # half height
ARM_DROP = 0.4                  # m: the arm's base starts this high, lying flat


class Settings(NamedTuple):
    heights: tuple              # m
    dts: tuple                  # s
    dampings: tuple             # contact.damping values of the knob's curve
    curve_dt: float             # s: the curve's dt
    curve_heights: tuple        # m


FULL = Settings(heights=(0.01, 0.2, 1.0), dts=(1e-4, 1e-3, 1e-2),
                dampings=(0.0, 0.1, 0.3, 1.0, 3.0), curve_dt=1e-4, curve_heights=(0.01, 0.2))
QUICK = Settings(heights=(0.01, 1.0), dts=(1e-3,), dampings=(0.0, 1.0), curve_dt=1e-4,
                 curve_heights=(0.01,))


def _run(sim, steps: int, height_of) -> tuple:
    """(heights after each step, mechanical energy before and after each step) of ``sim``."""
    heights, energy = [], [sim.energy]
    for _ in range(steps):
        sim.step()
        heights.append(height_of(sim))
        energy.append(sim.energy)
    return np.array(heights), np.array(energy)


def _rebound(heights: np.ndarray, first_contact: int) -> float:
    """How high [m] the trace rises, once it turns up after ``first_contact``, above where it
    ends (at rest); 0 if it never turns up. A body that sinks into the barrier's reach and
    creeps back out to its resting gap has not rebounded."""
    rising = np.flatnonzero(np.diff(heights[first_contact:]) > 0.0)
    if rising.size == 0:
        return 0.0
    return max(float(heights[first_contact + rising[0]:].max() - heights[-1]), 0.0)


def drop(shape: str, height: float, dt: float, integrator: str,
         damping: float | None = None) -> dict:
    """Drop ``shape`` (a key of SHAPES, 1 kg) from ``height`` [m] above the ground at ``dt``:
    its rebound as a fraction of the fall, the largest energy gain in one step and the fall's
    energy m g h [J], and the nearest it came to the ground [m]."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    geometry, half = SHAPES[shape]
    contact = {} if damping is None else {'damping': damping}
    scene = Scene.from_dict({
        'dt': dt, 'solver': {'integrator': integrator}, 'ground': {'height': 0.0},
        'contact': contact,
        'bodies': [{'name': shape, 'shape': geometry, 'mass': 1.0,
                    'position': [0.0, 0.0, half + height], 'collision': 'shape'}]})
    sim = Stepper(scene)
    fall = math.sqrt(2.0 * height / G)
    gaps, energy = _run(sim, round((fall + SETTLE) / dt) + 1,
                        lambda s: s.stats['min_distance'])
    first = int(np.argmax(gaps < scene.contact.d_hat))
    return {'shape': shape, 'height': height, 'dt': dt, 'integrator': integrator,
            'damping': scene.contact.damping, 'rebound': _rebound(gaps, first) / height,
            'max_gain': float(np.diff(energy).max()), 'fall_energy': G * height,
            'nearest': float(gaps.min())}


def arm_fall(dt: float, integrator: str) -> dict:
    """The packaged gripper arm (free base, joints free) lying flat, its base ARM_DROP above
    the ground: the rebound of its centre of mass as a fraction of its fall, the largest
    energy gain in one step and the fall's energy m g Δh [J]."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    with warnings.catch_warnings():
        warnings.simplefilter('ignore')     # the URDF's load notes are not measured here
        scene = Scene.from_urdf(config_dir() / 'robots' / 'arm6_gripper.urdf',
                                fixed_base=False, dt=dt,
                                base={'xyz': [0.0, 0.0, ARM_DROP], 'rpy': [0.0, math.pi / 2, 0.0]},
                                ground={'height': 0.0}, contact={},
                                solver={'integrator': integrator})
        sim = Stepper(scene)
    mass = np.array([body.mass for body in scene.bodies])
    start = float(sim.body_q[:, 2] @ mass / mass.sum())
    fall = math.sqrt(2.0 * ARM_DROP / G)
    heights, energy = _run(sim, round((fall + SETTLE) / dt) + 1,
                           lambda s: float(s.body_q[:, 2] @ mass / mass.sum()))
    first = int(np.argmax(np.diff(heights) > 0.0))       # the centre of mass stops falling
    fall = start - heights[first]
    return {'shape': 'arm6_gripper', 'height': fall, 'dt': dt, 'integrator': integrator,
            'damping': scene.contact.damping, 'rebound': _rebound(heights, first) / fall,
            'max_gain': float(np.diff(energy).max()), 'fall_energy': mass.sum() * G * fall,
            'nearest': sim.contact_record['min_distance']}


COLUMNS = [Column('shape', 'body'), Column('height', 'fall [m]', '{:g}'),
           Column('dt', 'dt [s]', '{:g}'), Column('integrator', 'integrator'),
           Column('damping', 'damping ζ', '{:g}'),
           Column('rebound', 'rebound / fall', '{:.4f}'),
           Column('max_gain', 'largest energy gain in a step [J]', '{:+.1e}'),
           Column('fall_energy', 'fall energy m g h [J]', '{:.3g}'),
           Column('nearest', 'nearest [m]', '{:.2e}')]


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Every drop and the arm's fall, then the damping curve (CPU only: ``devices`` is not
    used); writes impacts.md and impacts.csv and prints them."""
    rows = [drop(shape, height, dt, integrator) for integrator in ('bdf1', 'bdf2')
            for shape in SHAPES for height in settings.heights for dt in settings.dts]
    rows += [arm_fall(dt, integrator) for integrator in ('bdf1', 'bdf2')
             for dt in settings.dts if dt >= 1e-3]
    curve = [drop(shape, height, settings.curve_dt, 'bdf2', damping)
             for shape in SHAPES for height in settings.curve_heights
             for damping in settings.dampings]
    text = ('## Impacts: drops onto the ground under the default contact, float64\n\n'
            'Rebound: how high the lowest point (the arm: its centre of mass) rises, once it '
            'turns up after the first contact, above where it comes to rest, over the fall. '
            'Largest energy gain: '
            'the most the mechanical energy grew in one step (rounding is ~1e-12 J).\n\n'
            + markdown_table(rows, COLUMNS)
            + f'\n\n## The damping knob: rebound against contact.damping (BDF2, dt '
              f'{settings.curve_dt:g} s)\n\n' + markdown_table(curve, COLUMNS) + '\n')
    publish(results, 'impacts', text, rows + curve)


def add_parser(sections) -> None:
    add_section(
        sections, 'impacts', run, FULL, QUICK,
        help='energy and rebound of drops onto the ground, and the contact damping curve',
        description='Drop a box, a ball and a cylinder from several heights at several dt '
                    'under BDF1 and BDF2, let the gripper arm fall flat, and measure the '
                    'rebound against contact.damping; write impacts.md and impacts.csv into '
                    '--results.',
        quick_help=f'heights {", ".join(map(str, QUICK.heights))} m, dt '
                   f'{", ".join(map(str, QUICK.dts))} s')
