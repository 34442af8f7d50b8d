"""Speed of the stepper on the packaged scenes: µs/step, launches/step, Newton iterations."""

import time
from pathlib import Path

import numpy as np

from affine_joint_sim.resources import packaged_scenes, scene_path

__all__ = ['add_parser', 'bench_scene', 'run_default']


def bench_scene(name: str, device: str = 'cpu', steps: int = 2000) -> dict:
    """Time ``steps`` steps of a packaged scene (after warm-up) under its own commands."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(Scene.from_yaml(scene_path(name)), device=device)
    for _ in range(20):
        sim.step()
    start = time.perf_counter()
    for _ in range(steps):
        sim.step()
    elapsed = time.perf_counter() - start
    iterations = []
    for _ in range(200):
        sim.step()
        iterations.append(sim.stats['newton_iterations'])
    return {'scene': name, 'device': str(sim.device), 'bodies': len(sim.body_names),
            'joints': len(sim.joint_names), 'us_per_step': elapsed / steps * 1e6,
            'launches_per_step': sim.stats['launches_per_step'],
            'newton_iterations': float(np.mean(iterations))}


def _table(rows: list[dict]) -> str:
    lines = ['| scene | device | bodies | joints | µs/step | launches/step | Newton it./step |',
             '|---|---|---|---|---|---|---|']
    lines += [f"| {r['scene']} | {r['device']} | {r['bodies']} | {r['joints']} | "
              f"{r['us_per_step']:.1f} | {r['launches_per_step']} | {r['newton_iterations']:.2f} |"
              for r in rows]
    return '\n'.join(lines)


def _run(scenes, devices, steps) -> str:
    rows = [bench_scene(name, device, steps) for device in devices for name in scenes]
    return _table(rows)


def run_default(results: Path, devices: list[str]) -> None:
    """Time every packaged scene on every device; print and write ``perf.md``."""
    table = _run(packaged_scenes(), devices, 2000)
    print(table)
    (results / 'perf.md').write_text(table + '\n')


def add_parser(sections) -> None:
    parser = sections.add_parser('perf', help='µs/step of the packaged scenes',
                                 description='Print µs/step of packaged scenes.')
    parser.add_argument('scenes', nargs='*', help='scene names (default: all packaged)')
    parser.add_argument('--steps', type=int, default=2000, help='timed steps per scene')
    parser.set_defaults(bench_func=lambda args, devices: print(
        _run(args.scenes or packaged_scenes(), devices, args.steps)) or 0)
