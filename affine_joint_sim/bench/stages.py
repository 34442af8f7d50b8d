"""``bench stages``: where a step's time goes, stage by stage.

Each scene steps to a state of the kind it is run for (the piles falling 1 s into their bin,
the arm's grasp and the quadruped standing after 0.3 s, a robot without contact after 0.3 s),
times its next steps (µs/step, Newton iterations and line-search halvings per step), and then
runs each stage of its step kernel alone at that state, many times in one launch
(``physics.evaluate.stage_timer``): the incremental potential, the assembly with and without
the Hessian, the solve with and without factoring, and with contact the step bound, the
near list's gathering and the smallest distance (µs per call). A step calls the energy once
at its start and once per line-search trial, the assembly and the factoring solve once per
fresh Hessian, the gradient and the factored solve for the check on the last factors, the
step bound once per iteration and per line search, the gathering at least once (at its
start) and again where a body outruns its margin. float64, one CPU core. Writes stages.md and
stages.csv.
"""

import time
from dataclasses import dataclass
from pathlib import Path

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section

__all__ = ['FULL', 'QUICK', 'Settings', 'add_parser', 'profile', 'run']


@dataclass(frozen=True)
class Settings:
    scenes: tuple           # names of SCENES
    steps: int              # steps timed after the state is reached
    calls: int              # calls of a stage per timed launch


FULL = Settings(('pile of 27', 'pile of 64', 'arm6_gripper grasp', 'quadruped', 'arm6'), 50,
                200)
QUICK = Settings(('ramp', 'arm6'), 10, 20)


def _scenes() -> dict:
    """name → (a function making the Scene, seconds to step before measuring)."""
    from affine_joint_sim.bench.bodies import pile_scene
    from affine_joint_sim.resources import scene_path
    from affine_joint_sim.scene import Scene

    def packaged(name):
        return lambda: Scene.load(scene_path(name))

    return {'pile of 27': (lambda: Scene.from_dict(pile_scene(27)), 1.0),
            'pile of 64': (lambda: Scene.from_dict(pile_scene(64)), 1.0),
            'arm6_gripper grasp': (packaged('grasp'), 0.3),
            'quadruped': (packaged('quadruped'), 0.3),
            'ramp': (packaged('ramp'), 0.3),
            'arm6': (packaged('arm6'), 0.3)}


def profile(scene, seconds: float, steps: int, calls: int) -> dict:
    """One row: ``scene`` stepped ``seconds``, then ``steps`` steps timed and as many again
    for their Newton statistics, then each stage timed over ``calls`` calls at the state
    reached (µs per call; None for the contact stages of a scene without contact)."""
    import numpy as np
    import warp as wp

    from affine_joint_sim.physics.evaluate import CONTACT_STAGES, STAGE_NAMES, stage_timer
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(scene, threads=1)
    for _ in range(round(seconds / scene.dt)):
        sim.step()
    start = time.perf_counter()
    for _ in range(steps):
        sim.step()
    seconds = time.perf_counter() - start
    iterations, halvings = [], []
    for _ in range(steps):          # the next as many steps, read (not timed)
        sim.step()
        iterations.append(sim.stats['newton_iterations'])
        halvings.append(sim.stats['line_search_halvings'])
    row = {'us_per_step': seconds / steps * 1e6, 'newton': float(np.mean(iterations)),
           'halvings': float(np.mean(halvings)), 'contact': bool(sim._host.has_contact)}
    timer = stage_timer(sim._k)
    out = wp.zeros(1, dtype=sim._k.scalar)
    for which, name in enumerate(STAGE_NAMES):
        row[name] = None
        if name in CONTACT_STAGES and not row['contact']:
            continue
        args = [sim._model, sim._state, sim._control, sim._scratch, which]
        wp.launch(timer, dim=1, inputs=[*args, 1, out])      # compiled, and the scratch set
        best = float('inf')
        for _ in range(3):
            start = time.perf_counter()
            wp.launch(timer, dim=1, inputs=[*args, calls, out])
            wp.synchronize()
            best = min(best, (time.perf_counter() - start) / calls * 1e6)
        row[name] = best
    return row


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Profile each scene of ``settings`` on the CPU; write stages.md and stages.csv."""
    from affine_joint_sim.physics.evaluate import STAGE_NAMES

    scenes = _scenes()
    rows = []
    for name in settings.scenes:
        make, seconds = scenes[name]
        rows.append({'scene': name, **profile(make(), seconds, settings.steps,
                                              settings.calls)})
    columns = [Column('scene', 'scene'), Column('us_per_step', 'µs/step', '{:.0f}'),
               Column('newton', 'Newton it.', '{:.2f}'),
               Column('halvings', 'halvings', '{:.2f}')]
    columns += [Column(name, f'{name} µs', '{:.1f}') for name in STAGE_NAMES]
    text = ('## Where a step goes (bench stages)\n\nfloat64, one CPU core: µs/step and Newton '
            'iterations over the steps, then each stage alone at the state reached, µs '
            'per call (— : no contact).\n\n' + markdown_table(rows, columns) + '\n')
    publish(results, 'stages', text, rows)


def add_parser(sections) -> None:
    add_section(
        sections, 'stages', run, FULL, QUICK,
        help='where a step\'s time goes: each stage of the step kernel timed alone',
        description='Step piles, the arm\'s grasp, the quadruped and a robot without contact '
                    'to a typical state, then time each stage of the step kernel alone there '
                    '(energy, assembly, gradient, solves, step bound, near list, distances); '
                    'write stages.md and stages.csv into --results.',
        quick_help='the ramp and arm6, 10 steps, 20 calls a stage')
