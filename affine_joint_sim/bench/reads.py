"""``bench reads``: what a controller's reads cost beside the step.

Each packaged scene runs under a joint PD law that holds its initial angles (kp, kd per joint;
none for scenes without commanded joints), and every step the loop reads what a controller
reads: ``angles``, ``velocities``, ``link_transforms``, ``stats``, then ``set_torques``; and
what a contact sensor or a contact marker reads, ``contacts``. Each call is timed on its own
(perf_counter around it; the PD law's own arithmetic is the controller's, not timed) after a
settling run, and reported in µs and as a share of the step (the step timed the same way).
The target: the controller's five calls together at most a quarter of a step, a contact read
at most one step. Writes reads.md and reads.csv.
"""

import time
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.resources import config_dir

__all__ = ['CONTROLLER_READS', 'FULL', 'QUICK', 'Settings', 'add_parser', 'read_costs', 'run']

KP, KD = 100.0, 10.0            # N·m/rad, N·m·s/rad: the packaged demo's PD law
CONTROLLER_READS = ('angles', 'velocities', 'link_transforms', 'stats', 'set_torques')


class Settings(NamedTuple):
    scenes: tuple               # packaged scene names (msg_configs/scenes)
    settle: int                 # steps before timing
    steps: int                  # timed steps


FULL = Settings(scenes=('quadruped', 'grasp', 'pile'), settle=300, steps=500)
QUICK = Settings(scenes=('quadruped',), settle=50, steps=50)


def read_costs(scene_name: str, settle: int, steps: int) -> dict:
    """Mean µs of one step and of each read over ``steps`` steps of the packaged scene
    ``scene_name`` under the holding PD law, after ``settle`` steps."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    with warnings.catch_warnings():
        warnings.simplefilter('ignore')     # clamped torques are not measured here
        sim = Stepper(Scene.load(config_dir() / 'scenes' / f'{scene_name}.yaml'))
        hold = np.array(sim.angles)[sim.command_joint_index]
        reads = {name: (lambda n=name: getattr(sim, n)) for name in CONTROLLER_READS[:-1]}
        reads['contacts'] = lambda: sim.contacts
        spent = dict.fromkeys(['step', *reads, 'set_torques'], 0.0)
        for k in range(settle + steps):
            start = time.perf_counter()
            sim.step()
            clock = {'step': time.perf_counter() - start}
            for name, read in reads.items():
                start = time.perf_counter()
                read()
                clock[name] = time.perf_counter() - start
            index = sim.command_joint_index
            command = KP * (hold - sim.angles[index]) - KD * sim.velocities[index]
            start = time.perf_counter()
            sim.set_torques(command)
            clock['set_torques'] = time.perf_counter() - start
            if k >= settle:
                for name, seconds in clock.items():
                    spent[name] += seconds
    row = {'scene': scene_name, 'joints': len(sim.command_joint_names),
           'contacts_at_end': len(sim.contacts)}
    row.update({f'{name}_us': 1e6 * seconds / steps for name, seconds in spent.items()})
    row['controller_us'] = sum(row[f'{name}_us'] for name in CONTROLLER_READS)
    row['controller_share'] = row['controller_us'] / row['step_us']
    row['contacts_share'] = row['contacts_us'] / row['step_us']
    return row


COLUMNS = [Column('scene', 'scene'), Column('joints', 'commanded joints'),
           Column('contacts_at_end', 'contacts'), Column('step_us', 'step [µs]', '{:.1f}'),
           *(Column(f'{name}_us', f'{name} [µs]', '{:.1f}') for name in CONTROLLER_READS),
           Column('controller_share', 'controller reads / step', '{:.3f}'),
           Column('contacts_us', 'contacts [µs]', '{:.1f}'),
           Column('contacts_share', 'contacts / step', '{:.2f}')]


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Every scene of ``settings`` (CPU only: ``devices`` is not used); writes reads.md and
    reads.csv and prints them."""
    rows = [read_costs(name, settings.settle, settings.steps) for name in settings.scenes]
    text = ('## Reads: what a controller and a contact sensor read, beside the step '
            '(float64, CPU)\n\n'
            f'Mean over {settings.steps} steps after {settings.settle}, each call timed on its '
            f'own; the scene held by a joint PD law (kp {KP:g}, kd {KD:g}). Controller reads: '
            + ', '.join(CONTROLLER_READS) + ' together.\n\n'
            + markdown_table(rows, COLUMNS) + '\n')
    publish(results, 'reads', text, rows)


def add_parser(sections) -> None:
    add_section(
        sections, 'reads', run, FULL, QUICK,
        help="what a controller's reads and a contact read cost beside the step",
        description='Time angles, velocities, link_transforms, stats, set_torques and '
                    'contacts on packaged scenes under a holding PD law; write reads.md and '
                    'reads.csv into --results.',
        quick_help=f'{", ".join(QUICK.scenes)}, {QUICK.steps} steps')
