"""``bench stages``: where a step's time goes, stage by stage.

Each scene steps to a state of the kind it is run for (the piles falling 1 s into their bin,
the arm's grasp and the quadruped standing after 0.3 s, a robot without contact after 0.3 s),
times its next steps (µs/step, Newton iterations and line-search halvings per step), counts
over as many again what each step called (``stats``: Hessians assembled and factored, gradients
tried on the last factors, energies, near-list gatherings), and then runs each stage of its
step kernel alone at that state, many times in one launch (``physics.evaluate.stage_timer``):
the incremental potential, the assembly with and without the Hessian, the solve with and
without factoring, and with contact the step bound, the near list's gathering and the
smallest distance (µs per call). A stage's share of a step is its calls per step times its
µs per call; what no count covers (the prediction, friction's lag, the step bounds, the
commit and the launch) is the rest. float64, one CPU core. Writes stages.md and stages.csv;
``bench contact`` and ``bench bodies`` print the same profile of their heaviest scenes.
"""

import time
from dataclasses import dataclass
from pathlib import Path

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section

__all__ = ['FULL', 'QUICK', 'Settings', 'add_parser', 'profile', 'profile_rows', 'profile_text',
           'run']


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

    piles = {f'pile of {n}': (lambda n=n: Scene.from_dict(pile_scene(n)), 1.0)
             for n in (8, 27, 64, 125)}
    return {**piles,
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
    counted = {name: [] for name in ('newton_iterations', 'line_search_halvings', *_CALLS)}
    for _ in range(steps):          # the next as many steps, read (not timed)
        sim.step()
        stats = sim.stats
        for name, values in counted.items():
            values.append(stats.get(name, 0))
    means = {name: float(np.mean(values)) for name, values in counted.items()}
    row = {'us_per_step': seconds / steps * 1e6, 'newton': means['newton_iterations'],
           'halvings': means['line_search_halvings'], 'contact': bool(sim._host.has_contact),
           **{f'{name} per step': means[name] for name in _CALLS}}
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
    return _shares(row)


# the statistics counting a stage's calls, and the stages (STAGE_NAMES) each call runs
_CALLS = {'hessians': ('assembly', 'factor and solve'),
          'gradient_tries': ('gradient', 'factored solve'),
          'energies': ('energy',),
          'near_gathers': ('near list',)}


def _shares(row: dict) -> dict:
    """``row`` with each counted stage's µs per step (its calls per step × µs per call), the
    distances' once per step with contact (the statistics), and the rest of the step."""
    accounted = 0.0
    for name, stages in _CALLS.items():
        share = sum(row[stage] or 0.0 for stage in stages) * row[f'{name} per step']
        row[f'{name} µs/step'] = share
        accounted += share
    row['distances µs/step'] = row['distances'] or 0.0
    accounted += row['distances µs/step']
    row['rest µs/step'] = row['us_per_step'] - accounted
    return row


def _columns() -> list:
    from affine_joint_sim.physics.evaluate import STAGE_NAMES

    columns = [Column('scene', 'scene'), Column('us_per_step', 'µs/step', '{:.0f}'),
               Column('newton', 'Newton it.', '{:.2f}'),
               Column('halvings', 'halvings', '{:.2f}')]
    columns += [Column(f'{name} per step', f'{name} /step', '{:.2f}') for name in _CALLS]
    columns += [Column(name, f'{name} µs', '{:.1f}') for name in STAGE_NAMES]
    columns += [Column(f'{name} µs/step', f'{name} µs/step', '{:.1f}')
                for name in (*_CALLS, 'distances', 'rest')]
    return columns


def profile_text(rows: list[dict]) -> str:
    """The markdown of profiled ``rows`` (scene and ``profile``'s row), with how to read it."""
    return ('float64, one CPU core: µs/step, Newton iterations and the calls of each counted '
            'stage per step (Hessians: assembly with factoring solve; gradient tries: gradient '
            'with factored solve; energies; near-list gatherings) over the steps, then each '
            'stage alone at the state reached, µs per call (— : no contact), and each counted '
            "stage's µs per step (calls × µs per call; the distances once a step with contact, "
            'for the statistics); rest: what they leave of the step (prediction, friction\'s '
            'lag, step bounds, commit, launch).\n\n' + markdown_table(rows, _columns()) + '\n')


def profile_rows(names, steps: int, calls: int) -> list[dict]:
    """``profile`` of each scene named (SCENES' names), one row each."""
    scenes = _scenes()
    rows = []
    for name in names:
        make, seconds = scenes[name]
        rows.append({'scene': name, **profile(make(), seconds, steps, calls)})
    return rows


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Profile each scene of ``settings`` on the CPU; write stages.md and stages.csv."""
    rows = profile_rows(settings.scenes, settings.steps, settings.calls)
    publish(results, 'stages', '## Where a step goes (bench stages)\n\n' + profile_text(rows),
            rows)


def add_parser(sections) -> None:
    add_section(
        sections, 'stages', run, FULL, QUICK,
        help='where a step\'s time goes: each stage of the step kernel timed alone',
        description='Step piles, the arm\'s grasp, the quadruped and a robot without contact '
                    'to a typical state, then time each stage of the step kernel alone there '
                    '(energy, assembly, gradient, solves, step bound, near list, distances); '
                    'write stages.md and stages.csv into --results.',
        quick_help='the ramp and arm6, 10 steps, 20 calls a stage')
