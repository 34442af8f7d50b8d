"""Speed of the stepper on the packaged scenes: µs/step, launches/step, Newton iterations.

Wall-clock figures belong here, never in tests. The speed/accuracy sweep (dt, integrator,
tolerance, precision) extends this module.
"""

import time

import numpy as np

from affine_joint_sim.resources import packaged_scenes, scene_path
from affine_joint_sim.scene import Scene
from affine_joint_sim.stepper import Stepper

__all__ = ['bench_scene', 'main']


def bench_scene(name: str, device: str = 'cpu', steps: int = 2000) -> dict:
    """Time ``steps`` steps of a packaged scene (after warm-up) under its own commands."""
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


def main(args) -> int:
    rows = [bench_scene(name, args.device, args.steps) for name in (args.scenes or packaged_scenes())]
    print('| scene | device | bodies | joints | µs/step | launches/step | Newton it./step |')
    print('|---|---|---|---|---|---|---|')
    for r in rows:
        print(f"| {r['scene']} | {r['device']} | {r['bodies']} | {r['joints']} | "
              f"{r['us_per_step']:.1f} | {r['launches_per_step']} | {r['newton_iterations']:.2f} |")
    return 0
