"""The ``affine-joint-sim`` command line (design.md §6)."""

import argparse
import sys
import time

from affine_joint_sim.resources import packaged_scenes, scene_path
from affine_joint_sim.scene import SceneError

__all__ = ['main']


def _torque(text: str) -> tuple[str, float]:
    name, sep, value = text.partition('=')
    try:
        if not sep:
            raise ValueError
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected JOINT=N·m, got {text!r}') from None


def _run(args) -> int:
    """Headless run of a scene with constant torques; prints angles and solver figures."""
    import numpy as np

    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    scene = Scene.from_yaml(scene_path(args.scene))
    sim = Stepper(scene, device=args.device)
    for name, value in args.torque:
        sim.set_torque(name, value)
    steps = round(args.duration / scene.dt)
    report_every = max(1, round(0.25 / scene.dt))
    iterations, gap, converged = [], 0.0, True
    print(f'{scene.name}: {len(sim.body_names)} bodies, joints {", ".join(sim.joint_names)}; '
          f'dt {scene.dt} s, {scene.solver.integrator}, {scene.solver.precision}, {sim.device}')
    print('    t [s]  ' + ''.join(f'{n + " [rad]":>18}' for n in sim.joint_names))
    start = time.perf_counter()
    for i in range(steps):
        sim.step()
        stats = sim.stats
        iterations.append(stats['newton_iterations'])
        gap = max(gap, stats['joint_gap'])
        converged &= stats['converged']
        if (i + 1) % report_every == 0 or i + 1 == steps:
            print(f'{sim.time:9.3f}  ' + ''.join(f'{a:18.6f}' for a in sim.angles))
    wall = time.perf_counter() - start
    print(f'{steps} steps ({sim.time:.3f} s simulated) in {wall:.3f} s wall: '
          f'{wall / max(steps, 1) * 1e6:.1f} µs/step including reporting, '
          f'{sim.time / wall:.0f}x real time')
    print(f'Newton iterations per step: mean {np.mean(iterations):.2f}, max {max(iterations)}; '
          f'every step converged: {converged}; largest joint gap {gap:.3g} m')
    return 0 if converged else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='affine-joint-sim',
        description='Affine-body revolute-joint simulator (ROS 2 Jazzy node and tools).')
    commands = parser.add_subparsers(dest='command', required=True)

    run = commands.add_parser('run', help='simulate a scene and print joint angles',
                              description='Simulate a scene with constant joint torques.')
    run.add_argument('--scene', default='pendulum',
                     help=f'scene file or packaged name ({", ".join(packaged_scenes())})')
    run.add_argument('--device', default='cpu', help='Warp device: cpu, cuda, cuda:N')
    run.add_argument('--duration', type=float, default=2.0, help='simulated seconds [s]')
    run.add_argument('--torque', type=_torque, action='append', default=[],
                     metavar='JOINT=N·m', help='constant torque on a joint (repeatable)')
    run.set_defaults(func=_run)

    from affine_joint_sim import bench as bench_sections
    bench = commands.add_parser('bench', help='speed and accuracy measurements',
                                description='Speed/accuracy measurements; with no section, '
                                            'every section writes into --results.')
    bench_sections.add_arguments(bench)
    bench.set_defaults(func=bench_sections.main)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (SceneError, KeyError, ValueError) as exc:
        print(f'affine-joint-sim: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
