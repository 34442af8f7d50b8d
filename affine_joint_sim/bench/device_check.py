"""Every GPU check in one run and one table: ``python -m affine_joint_sim.bench.device_check``.

A lent GPU comes with minutes, not hours, and without a CPU compiler or a package index, so the
work is split (``make gpu-prep`` does the first two steps):

1. ``register()`` builds every GPU step kernel variant (both precisions, each kind of contact:
   ``VARIANTS``) exactly as a Stepper on a GPU does; the workplace's gpu-prep hook then
   compiles them for sm_90 ahead of time (Warp module hashes must match, or the device
   compiles again).
2. ``reference OUT.npz`` (CPU) writes the CPU float64 joint trajectories of the scenes.
3. ``run --reference OUT.npz`` (on the device) prints one markdown table: per scene and
   precision, the largest joint-coordinate difference from the CPU float64 run over
   ``STEPS`` steps, batched against single environments on the device, then µs/step and
   env-steps/s for every N: a full ``step()`` (a graph replay and a wait for the problem
   counts, what a user's loop gets) and the kernel graph alone replayed back to back (the
   difference is what the host side costs); then the step kernels' resources.

``resources [DIR]`` (CPU, after step 1) prints what each compiled step kernel needs per thread
(``bench.cubin``): registers, stack frame in local memory, code size, and the warps per SM
that its registers allow: the predictions to check a GPU run against. ``inlining`` (CPU, no
compile) prints each variant's functions as NVVM compiles them (``bench.inlining``).

Scenes (BDF2): ``pendulum`` (one 1 kg 0.1×0.1×1 m link), ``chain6`` (six such links), 2 N·m
on every joint, dt 0.01; the packaged 6-joint ``arm`` (1 N·m on every joint, dt 0.01); with
contact, so that every step kernel variant runs, the packaged ``quadruped`` folding onto the
ground without torques (half-spaces, dt 0.001), the ``ramp``'s box sliding down a fixed box (a
static shape, dt 0.01; no joints: its bodies' positions are compared) and the ``gripper``
squeezing its box with 1.5 N per finger (pairs of bodies, dt 0.001).
``run --device cpu`` runs the same checks on the CPU (the tests do, with small N).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from affine_joint_sim.bench.report import Column, markdown_row, markdown_table

__all__ = ['ENVS', 'STEPS', 'register', 'modules', 'scenes', 'reference', 'check', 'main']

ENVS = (1, 1024, 16384, 65536, 262144)
STEPS = 300
PRECISIONS = ('float64', 'float32')
AGREE = 1e-9        # rad: the bound on CUDA float64 against CPU float64

# Peers on an H100 with the same scenes (issue 16), env-steps/s and µs/step at N = 1.
PEERS = ('peers (H100, CUDA graphs): Newton Featherstone 3.6e8 env-steps/s (pendulum, 65536 '
         'worlds), MJX 4.4e7 (chain6; Featherstone 7e6); Newton XPBD 8.0e8 / 1.4e8 but ~1.8 rad '
         'off on the pendulum; one environment: Newton 43–53 µs/step, MJX 127 µs/step')
COLUMNS = [Column('scene', 'scene'), Column('precision', 'precision'), Column('envs', 'N'),
           Column('us_per_step', 'µs/step', '{:.3g}'),
           Column('env_steps_per_s', 'env-steps/s', '{:.3g}'),
           Column('graph_us_per_step', 'graph µs/step', '{:.3g}'),
           Column('graph_env_steps_per_s', 'graph env-steps/s', '{:.3g}'),
           Column('newton_iterations', 'Newton it./step', '{:.3g}'),
           Column('error', 'largest Δq vs CPU f64 [rad, m]', '{:.3g}'),
           Column('agreeing_steps', f'steps within {AGREE:g}', '{}'),
           Column('batched_minus_single', 'batched − single', '{:.3g}'),
           Column('note', 'note')]


# The step kernel variants a Stepper may load (kernels.step_kernels), by the contact a scene
# has: none, points on half-spaces only, with static shapes and meshes too, or between moving
# bodies too
VARIANTS = (('none', {'contact': False}), ('half-spaces', {'shapes': False}),
            ('world', {'bodies': False}), ('bodies', {'bodies': True}))


def step_variants():
    """(precision, contact, the types namespace) of every step kernel variant a Stepper
    loads."""
    import warp as wp

    from affine_joint_sim.physics.kernels import step_kernels

    for precision, scalar in (('float64', wp.float64), ('float32', wp.float32)):
        for contact, kind in VARIANTS:
            yield precision, contact, step_kernels(scalar, **kind)


def register() -> None:
    """Build every step kernel a Stepper loads."""
    for _ in step_variants():
        pass


def modules() -> list[str]:
    """The Warp module names of the step kernel variants: what ``make gpu-prep`` compiles for
    sm_90, the same modules the CPU compiles."""
    return [t.step.module.name for _, _, t in step_variants()]


def scenes(precision: str) -> dict:
    """name → (Scene, torque [N·m] on every joint) of the checked scenes."""
    from affine_joint_sim.chain import chain_scene
    from affine_joint_sim.resources import scene_path
    from affine_joint_sim.scene import Scene

    def chain(links):
        return chain_scene(links, link_length=1.0, section=0.1, integrator='bdf2',
                           precision=precision)

    def packaged(name):
        scene = Scene.load(scene_path(name))
        return scene.model_copy(update={'solver': scene.solver.model_copy(
            update={'integrator': 'bdf2', 'precision': precision})})

    return {'pendulum': (chain(1), 2.0), 'chain6': (chain(6), 2.0), 'arm': (packaged('arm'), 1.0),
            'quadruped': (packaged('quadruped'), 0.0), 'ramp': (packaged('ramp'), 0.0),
            'gripper': (packaged('gripper'), 1.5)}


def _stepper(scene, torque, device, envs=None, torques=None, said=None):
    """A Stepper with ``torque`` (or per-env ``torques``) on every joint; the problems it
    reports go into the set ``said`` (their messages without the time), not to warnings."""
    from affine_joint_sim.stepper import Stepper

    def heard(message):
        if said is not None:
            said.add(message.split(': ', 1)[-1].split(' (')[0])

    sim = Stepper(scene, device=device, num_envs=envs, on_problem=heard, threads=1)  # one graph
    for name in sim.command_joint_names:
        sim.set_torque(name, torque if torques is None else torques)
    return sim


def _angle_errors(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per step, the largest difference [rad] of two runs' wrapped joint angles (steps, joints):
    a joint passing ±π in one run only differs by its distance, not 2π (the gripper's
    prismatic coordinates [m] stay far below π, where the wrap never acts)."""
    return np.max(np.abs(np.remainder(a - b + np.pi, 2.0 * np.pi) - np.pi), axis=-1)


def _agreeing_steps(errors: np.ndarray) -> int:
    """Steps from the start whose errors stay within AGREE [rad]: the arm amplifies rounding (a
    1e-13 relative torque change is 7e-9 rad apart after 300 steps on the CPU), so rounding
    alone may end the agreement and the maximum over the run says little on its own."""
    over = np.flatnonzero(errors > AGREE)
    return int(over[0]) if over.size else len(errors)


def _coordinates(sim) -> np.ndarray:
    """The joint coordinates (envs…, joints) [rad, m], or of a scene without joints its bodies'
    positions (envs…, 3·bodies) [m]."""
    if sim.joint_names:
        return sim.angles.copy()
    q = np.array(sim.body_q)
    return q[..., :3].reshape(*q.shape[:-2], -1)


def _trajectory(sim, steps: int) -> np.ndarray:
    out = []
    for _ in range(steps):
        sim.step()
        out.append(_coordinates(sim))
    return np.array(out)


def reference(path: Path, steps: int = STEPS) -> None:
    """Write the CPU float64 joint trajectories (steps, joints) of every scene to ``path``."""
    runs = {name: _trajectory(_stepper(scene, torque, 'cpu'), steps)
            for name, (scene, torque) in scenes('float64').items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **runs)


def _timed(sim, seconds: float) -> tuple[float, float]:
    """(µs per full step, µs per replay of the kernel graph alone), each ~``seconds``."""
    import warp as wp

    start = time.perf_counter()
    sim.step()
    steps = max(3, round(seconds / max(time.perf_counter() - start, 1e-7)))
    start = time.perf_counter()
    for _ in range(steps):
        sim.step()
    full = (time.perf_counter() - start) / steps
    graph = sim._graphs[False]   # the kernel and the problem counts: no upload, no wait
    wp.synchronize_device(sim.device)
    start = time.perf_counter()
    for _ in range(steps):
        wp.capture_launch(graph)
    wp.synchronize_device(sim.device)
    return full * 1e6, (time.perf_counter() - start) / steps * 1e6


def _env_bytes(scene) -> int:
    """Device bytes one environment of ``scene`` takes (physics.host.fields.env_bytes)."""
    from affine_joint_sim.physics.host.fields import array_sizes, env_bytes
    from affine_joint_sim.physics.kernels import scalar_of, step_kernels
    from affine_joint_sim.physics.host.model import build_model

    return env_bytes(step_kernels(scalar_of(scene.solver.precision)),
                     array_sizes(build_model(scene), 1))


def _fits(per_env: int, envs: int, device) -> bool:
    """Whether ``envs`` environments of ``per_env`` bytes take at most half the device's free
    memory."""
    import warp as wp

    device = wp.get_device(device)
    return device.is_cpu or envs * per_env < device.free_memory / 2


def _row(name, precision, envs, **values) -> dict:
    return dict({'scene': name, 'precision': precision, 'envs': envs}, **values)


def check(device: str, ref: dict | None, envs: tuple, steps: int, seconds: float,
          deadline: float, emit) -> list[dict]:
    """Every check on ``device``; ``emit(row)`` is called as each row is measured."""
    rows = []
    for precision in PRECISIONS:
        for name, (scene, torque) in scenes(precision).items():
            if time.monotonic() > deadline:
                emit(_row(name, precision, '-', note='skipped: out of time'))
                continue
            said = set()        # problems any run of this scene reported: in the note column
            single = _trajectory(_stepper(scene, torque, device, said=said), steps)
            spread = torque * np.array([1.0, -0.5, 0.25])
            batch = _trajectory(_stepper(scene, torque, device, 3, spread, said), steps)
            singles = [_trajectory(_stepper(scene, tau, device, said=said), steps)
                       for tau in spread]
            errors = _angle_errors(single, ref[name]) if ref is not None else None
            same = max(_angle_errors(batch[:, k], s).max() for k, s in enumerate(singles))
            per_env = _env_bytes(scene)
            for n in envs:
                if time.monotonic() > deadline:
                    emit(_row(name, precision, n, note='skipped: out of time'))
                    continue
                if not _fits(per_env, n, device):
                    emit(_row(name, precision, n, note='skipped: memory'))
                    continue
                sim = _stepper(scene, torque, device, n, said=said)
                full, graph = _timed(sim, seconds)
                row = _row(name, precision, n, us_per_step=full,
                           env_steps_per_s=n / full * 1e6, graph_us_per_step=graph,
                           graph_env_steps_per_s=n / graph * 1e6,
                           newton_iterations=float(np.mean(sim.stats['newton_iterations'])),
                           error=errors.max() if errors is not None else float('nan'),
                           agreeing_steps=_agreeing_steps(errors) if errors is not None else None,
                           batched_minus_single=same,
                           note='; '.join(sorted(said)) or None)
                del sim
                rows.append(row)
                emit(row)
    return rows


SM_REGISTERS, SM_WARPS, WARP = 65536, 64, 32      # per SM of sm_90 (H100, H200)


def warps_per_sm(registers: int) -> int:
    """Warps an sm_90 SM holds at once when each thread needs ``registers`` registers (a warp's
    registers are allocated in units of 256; other limits, e.g. shared memory, aside)."""
    per_warp = -(-registers * WARP // 256) * 256
    return min(SM_WARPS, SM_REGISTERS // per_warp)


def resources(cache_dir) -> list[dict]:
    """Per precision and pair kind, the resources of the GPU step kernel's cubins under
    ``cache_dir`` (Warp's kernel cache layout: one folder per module identifier, under a
    folder per Warp version or not)."""
    from affine_joint_sim.bench.cubin import kernel_resources

    rows = []
    for precision, contact, t in step_variants():
        ident = t.step.module.get_module_identifier()
        for path in sorted(Path(cache_dir).glob(f'**/{ident}/*.cubin')):
            for kernel in kernel_resources(path):
                warps = warps_per_sm(kernel.registers)
                rows.append({'precision': precision, 'contact': contact, 'cubin': path.name,
                             'registers': kernel.registers, 'stack': kernel.frame_bytes,
                             'code': kernel.code_bytes / 1024, 'warps': warps,
                             'stack_per_sm': warps * WARP * kernel.frame_bytes / 2 ** 20})
    return rows


RESOURCE_COLUMNS = [Column('precision', 'precision'), Column('contact', 'contact'),
                    Column('cubin', 'cubin'),
                    Column('registers', 'registers'), Column('stack', 'stack B'),
                    Column('code', 'code KB', '{:.3g}'), Column('warps', 'warps/SM'),
                    Column('stack_per_sm', 'stack per SM MB', '{:.3g}')]


def inlining() -> list[dict]:
    """Per GPU step kernel variant, each function NVVM compiles on its own (bench.inlining):
    its Python statements after inlining and the copies of the contact distance functions in
    it."""
    from affine_joint_sim.bench.inlining import compiled, copies_of

    return [{'precision': precision, 'contact': contact,
             'function': key.removeprefix('build__locals__'), 'statements': unit.statements,
             **{name: copies_of(unit, name) for name in INLINED}}
            for precision, contact, t in step_variants()
            for key, unit in compiled(t.step).items()]


INLINED = ('pair_gap', 'shape_separation', 'triangle_weights')   # counted in inlining()
INLINING_COLUMNS = [Column('precision', 'precision'), Column('contact', 'contact'),
                    Column('function', 'function'),
                    Column('statements', 'statements inlined'),
                    *(Column(name, f'copies of {name}') for name in INLINED)]


def _resource_table(cache_dir) -> str:
    rows = resources(cache_dir)
    return markdown_table(rows, RESOURCE_COLUMNS) if rows else '(no step kernel cubins found)'


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='python -m affine_joint_sim.bench.device_check',
                                     description=__doc__.split('\n\n')[0])
    phases = parser.add_subparsers(dest='phase', required=True)
    ref = phases.add_parser('reference', help='write the CPU float64 trajectories')
    ref.add_argument('out', type=Path)
    res = phases.add_parser('resources', help='registers, stack and code of the step kernels')
    res.add_argument('dir', type=Path, nargs='?', default=Path('.gpu-extra/kernels'))
    phases.add_parser('modules', help='the Warp module names of the GPU step kernels, '
                      'one line (what make gpu-prep compiles)')
    phases.add_parser('inlining', help='the GPU step kernels with their calls inlined (no '
                      'compile): statements and copies of the contact distance per function')
    run = phases.add_parser('run', help='every check on --device, one table')
    run.add_argument('--device', default='cuda')
    run.add_argument('--reference', type=Path, help='npz from the reference phase')
    run.add_argument('--envs', default=','.join(map(str, ENVS)),
                     help='environment counts, comma-separated (default: %(default)s)')
    run.add_argument('--steps', type=int, default=STEPS, help='steps of the correctness runs')
    run.add_argument('--seconds', type=float, default=0.3, help='wall time per timed run')
    run.add_argument('--budget', type=float, default=420.0,
                     help='seconds after which the remaining N are skipped')
    args = parser.parse_args(argv)
    if args.phase == 'reference':
        reference(args.out)
        print(f'wrote {args.out}')
        return 0
    if args.phase == 'resources':
        print(_resource_table(args.dir))
        return 0
    if args.phase == 'modules':
        print(' '.join(modules()))
        return 0
    if args.phase == 'inlining':
        print(markdown_table(inlining(), INLINING_COLUMNS))
        return 0
    import warp as wp

    start = time.monotonic()
    device = wp.get_device(args.device)
    print(f'device: {device.name} ({device.alias}), Warp {wp.config.version}')
    ref = None
    if args.reference is not None:
        try:
            with np.load(args.reference) as data:
                ref = {name: data[name][:args.steps] for name in data.files}
        except (OSError, ValueError, EOFError, TypeError) as exc:   # TypeError: a .npy
            parser.error(f'--reference {args.reference}: not a reference written by the '
                         f'reference phase ({exc})')
        if min(len(r) for r in ref.values()) < args.steps:
            parser.error(f'--steps {args.steps}: {args.reference} holds '
                         f'{min(len(r) for r in ref.values())} steps per scene')
    print(markdown_table([], COLUMNS), flush=True)
    check(args.device, ref, tuple(int(n) for n in args.envs.split(',')), args.steps,
          args.seconds, start + args.budget,
          lambda row: print(markdown_row(row, COLUMNS), flush=True))
    print(f'\n{_resource_table(wp.config.kernel_cache_dir)}\n\n{PEERS}\n'
          f'total {time.monotonic() - start:.0f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
