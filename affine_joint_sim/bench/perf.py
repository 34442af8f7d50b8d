"""``bench perf``: µs per step against the targets of issue 7, and where the time goes.

Each case runs several times from its initial state under fixed commands: plain runs give the
median µs/step; runs that time every Warp launch and sync call give the launches and
host↔device syncs per step and where the time goes (``timing.measure_steps``). The CPU targets
(dt = 0.01 s, float64, default tolerance) are printed beside reference figures measured on the
project's machine and, where MuJoCo is installed, beside MuJoCo timed in the same run on the
same chain. Each case runs its scene's own integrator: the pendulum scene and the generated
chains (``chain_scene``) pin bdf1, the other packaged scenes use the default bdf2.
"""

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, NamedTuple

from affine_joint_sim.bench.mujoco_ref import MujocoChain
from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.resources import packaged_scenes, scene_path

__all__ = ['Case', 'TARGETS', 'add_parser', 'case', 'default_names', 'measure', 'run']

CHAIN_ANGLE = 0.5   # [rad] tilt at release of generated chains: they swing instead of hanging


@dataclass(frozen=True)
class Case:
    """A measured case: a scene (built on demand), its commands (joint -> torque [N·m]) and,
    for targets, the CPU target [µs/step], the reference figures of issue 7 and the chain
    that MuJoCo runs as a reference in the same run."""

    name: str
    scene: Callable
    commands: dict = field(default_factory=dict)
    target_us: float | None = None
    reference: str | None = None
    mujoco: MujocoChain | None = None


def _packaged(name):
    def load():
        from affine_joint_sim.scene import Scene
        return Scene.load(scene_path(name))
    return load


def _chain(links):
    def load():
        from affine_joint_sim.chain import chain_scene
        return chain_scene(links, angle=CHAIN_ANGLE)
    return load


TARGETS = {
    'pendulum': Case('pendulum', _packaged('pendulum'), {'shoulder': 2.0}, 50.0,
                     'MuJoCo ≈ 2.5 µs; Newton (Warp) 250–2500 µs',
                     MujocoChain(1, 1.0, 0.1, 1.0, torque=2.0)),
    'arm': Case('arm', _packaged('arm'), {}, 150.0),
    'chain64': Case('chain64', _chain(64), {}, 2000.0, 'MuJoCo ≈ 38 µs',
                    MujocoChain(64, 0.5, 0.05, 1.0, angle=CHAIN_ANGLE)),
}
LOADS = ('pendulum: 2 N·m on the shoulder; arm: falling from upright, no torque; '
         f'chain<N>: released {CHAIN_ANGLE} rad from vertical; other scenes: their own commands')


class Settings(NamedTuple):
    steps: int      # steps per run
    repeats: int    # timed runs (median reported)


FULL, QUICK = Settings(300, 7), Settings(50, 3)


def case(name: str) -> Case:
    """The case called ``name``: a target, ``chain<N>`` (N links) or a packaged scene."""
    if name in TARGETS:
        return TARGETS[name]
    match = re.fullmatch(r'chain(\d+)', name)
    return Case(name, _chain(int(match[1])) if match else _packaged(name))


def measure(item: Case, device: str, settings: Settings) -> dict:
    """One table row: the case's sizes, timing, counts and target verdict on ``device``."""
    from affine_joint_sim.bench.mujoco_ref import mujoco_us
    from affine_joint_sim.bench.timing import measure_steps
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(item.scene(), device=device)
    timing = measure_steps(sim, item.commands, settings.steps, settings.repeats)
    target = item.target_us if sim.device.is_cpu else None
    verdict = None if target is None else ('pass' if timing['us_per_step'] <= target else 'FAIL')
    mujoco = (mujoco_us(item.mujoco, settings.steps, settings.repeats)
              if item.mujoco is not None and sim.device.is_cpu else None)
    return {'scene': item.name, 'device': str(sim.device), 'bodies': len(sim.body_names),
            'joints': len(sim.joint_names), **timing,
            'target_us': target, 'verdict': verdict, 'mujoco_us': mujoco,
            'reference': item.reference}


TARGET_COLUMNS = [
    Column('scene', 'scene'), Column('device', 'device'), Column('bodies', 'bodies'),
    Column('joints', 'joints'), Column('us_per_step', 'µs/step', '{:.1f}'),
    Column('target_us', 'target µs', '≤ {:g}'), Column('verdict', ''),
    Column('launches_per_step', 'launches/step', '{:g}'),
    Column('syncs_per_step', 'host↔device syncs/step', '{:g}'),
    Column('newton_iterations', 'Newton it./step', '{:.2f}'),
    Column('mujoco_us', 'MuJoCo µs (this run)', '{:.1f}'),
    Column('reference', 'reference (issue 7, this machine)')]
PROFILE_COLUMNS = [
    Column('scene', 'scene'), Column('device', 'device'),
    Column('us_per_step', 'µs/step', '{:.1f}'),
    Column('launch_us', 'in launch calls (CPU: the kernel)', '{:.1f}'),
    Column('sync_us', 'in syncs', '{:.1f}'),
    Column('other_us', 'Python and the rest', '{:.1f}')]


def run(results: Path, devices: list[str], settings: Settings, names=()) -> None:
    """Measure ``names`` (default: ``default_names()``) on ``devices``; print the tables,
    write ``perf.md`` and ``perf.csv``."""
    rows = [measure(case(name), device, settings)
            for device in devices for name in names or default_names()]
    text = (f'## Speed per step (median of {settings.repeats} runs of {settings.steps} steps)\n\n'
            f'Loads: {LOADS}.\n\n{markdown_table(rows, TARGET_COLUMNS)}\n\n'
            '## Where the time goes (µs/step: medians of runs that time every Warp launch and '
            'sync call, which adds ~0.5 µs)\n\n'
            f'{markdown_table(rows, PROFILE_COLUMNS)}\n')
    publish(results, 'perf', text, rows)


def default_names() -> list[str]:
    """The targets, then every other packaged scene."""
    return list(TARGETS) + [name for name in packaged_scenes() if name not in TARGETS]


def add_parser(sections) -> None:
    parser = add_section(
        sections, 'perf', run, FULL, QUICK, extra=('cases',),
        help='µs/step against the targets, launches and syncs per step',
        description='Time cases (default: the targets, then every packaged scene) and write '
                    'perf.md and perf.csv into --results. A case is a target, a packaged '
                    'scene, or chain<N> (N links).',
        quick_help=f'{QUICK.steps} steps x {QUICK.repeats} runs instead of '
                   f'{FULL.steps} x {FULL.repeats}')
    parser.add_argument('cases', nargs='*', help='case names (default: all)')
