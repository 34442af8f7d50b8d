"""``bench batch``: env-steps per second of ``Stepper(scene, num_envs=N)``, N = 1 … 65536.

Every environment gets its own shoulder torque (spread over ±1 N·m), so the per-env control
path is exercised. N grows by 4 until one step would take longer than ``max_step_s`` (on a
CPU that ends the scan early: there each thread steps its share of the environments in turn).
On the CPU every N runs on one thread and on every core the process may use.
"""

import time
from pathlib import Path
from typing import NamedTuple

from affine_joint_sim.bench.report import Column, loglog_plot, markdown_table, publish
from affine_joint_sim.bench.section import add_section

__all__ = ['ENVS', 'SCENES', 'add_parser', 'measure', 'run', 'scan']

ENVS = tuple(4 ** k for k in range(9))   # 1 … 65536
SCENES = ('pendulum', 'arm')


class Settings(NamedTuple):
    envs: tuple          # environment counts, ascending
    run_s: float         # wall time aimed at per timed run [s] (at least 3 steps)
    repeats: int         # timed runs (median reported)
    max_step_s: float    # no larger N once a step would take longer than this [s]


FULL, QUICK = Settings(ENVS, 0.05, 3, 0.05), Settings(ENVS[:5], 0.02, 3, 0.01)


def measure(scene_name: str, envs: int, device: str, settings: Settings,
            threads: int | None = None) -> dict:
    """One row: µs/step and env-steps/s of ``envs`` environments of a packaged scene stepped
    by ``threads`` CPU threads (None: the Stepper's default, one per core)."""
    import numpy as np

    from affine_joint_sim.bench.timing import measure_steps
    from affine_joint_sim.resources import scene_path
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(scene_path(scene_name), device=device, num_envs=envs, threads=threads)
    start = time.perf_counter()
    sim.step()
    steps = max(3, round(settings.run_s / (time.perf_counter() - start)))
    timing = measure_steps(sim, {'shoulder': np.linspace(-1.0, 1.0, envs)}, steps,
                           settings.repeats)
    return {'scene': scene_name, 'device': str(sim.device), 'envs': envs,
            'threads': sim.stats['launches_per_step'], 'steps': steps,
            'us_per_step': timing['us_per_step'],
            'env_steps_per_s': envs / timing['us_per_step'] * 1e6,
            'newton_iterations': timing['newton_iterations'],
            'launches_per_step': timing['launches_per_step'],
            'syncs_per_step': timing['syncs_per_step']}


def scan(scene_name: str, device: str, settings: Settings,
         threads: int | None = None) -> list[dict]:
    """Rows for growing N until the next step would exceed ``settings.max_step_s``."""
    rows = []
    for envs in settings.envs:
        if rows and rows[-1]['us_per_step'] * 1e-6 * envs / rows[-1]['envs'] > settings.max_step_s:
            break
        rows.append(measure(scene_name, envs, device, settings, threads))
    return rows


COLUMNS = [Column('scene', 'scene'), Column('device', 'device'), Column('envs', 'N envs'),
           Column('threads', 'threads'),
           Column('us_per_step', 'µs/step', '{:.1f}'),
           Column('env_steps_per_s', 'env-steps/s', '{:.3g}'),
           Column('newton_iterations', 'Newton it./step', '{:.2f}'),
           Column('launches_per_step', 'launches/step', '{:g}'),
           Column('syncs_per_step', 'host↔device syncs/step', '{:g}')]


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Scan N for every scene and device; write batch.md, batch.csv and batch.png."""
    groups = {(scene, device, threads): scan(scene, device, settings, threads)
              for device in devices for scene in SCENES
              for threads in ((1, None) if device == 'cpu' else (None,))}
    rows = [row for group in groups.values() for row in group]
    text = (f'## Batched environments (median of {settings.repeats} runs of about '
            f'{settings.run_s:g} s)\n\n{markdown_table(rows, COLUMNS)}\n')
    loglog_plot(results / 'batch.png',
                {f'{scene}, {device}' + {1: ', one thread', None: ''}[threads]:
                 ([r['envs'] for r in group], [r['env_steps_per_s'] for r in group])
                 for (scene, device, threads), group in groups.items()},
                'environments N', 'env-steps per second', 'Batched throughput')
    publish(results, 'batch', text, rows, ('batch.png',))


def add_parser(sections) -> None:
    add_section(sections, 'batch', run, FULL, QUICK,
                help='env-steps/s of N = 1 … 65536 batched environments',
                description='Time pendulum and arm with num_envs = 1, 4, … 65536 and write '
                            'batch.md, batch.csv and batch.png into --results.',
                quick_help=f'N up to {QUICK.envs[-1]}, shorter runs')
