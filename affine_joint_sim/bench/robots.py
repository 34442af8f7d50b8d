"""``bench robots``: public robots side by side with MuJoCo, against a fine reference.

Each robot of the zoo (``bench.zoo``: arms, a hand, a quadruped, humanoids from
example-robot-data, the extra ``zoo``), or any URDF named on the command line, runs fixed-base
from the same pose under the same constant torques (gravity compensation plus a push) for
``duration`` seconds at each dt, in this project and, with the extra ``compare``, in MuJoCo
(Euler and RK4, contacts off: ``bench.mujoco_urdf``). The reference is MuJoCo's RK4 at
``reference_dt``. Per robot and dt: our µs per step and per control-loop step (set every
torque, step, read the angles), Newton iterations, unconverged and rejected steps,
line-search failures, joints that leave their limits where the reference does not, the real
time factor, the largest joint error over the run of ours, MuJoCo Euler and MuJoCo RK4, and
where the robot has mimic joints (the Panda's second finger) the largest departure from their
rule, ours and MuJoCo Euler's (its equality);
without joint friction in both (whatever the URDF says), and again with a Coulomb friction on
every joint (``zoo.frictions``; MuJoCo's friction loss) against a reference with it.
"""

import statistics
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np

from affine_joint_sim.bench.report import Column, markdown_row, markdown_table, publish

__all__ = ['Settings', 'FULL', 'QUICK', 'measure_robot', 'run', 'add_parser']

LIMIT_SLACK = 1e-6      # rad | m beyond a limit that counts as leaving it


class Settings(NamedTuple):
    dts: tuple          # s, the steps compared
    duration: float     # s per run
    repeats: int        # timed runs (median reported)
    reference_dt: float  # s, MuJoCo RK4's step for the reference


FULL = Settings((1e-3, 1e-2, 1e-4), 0.5, 9, 1e-5)
QUICK = Settings((1e-3, 1e-2), 0.1, 1, 1e-4)
TIMED_STEPS = 500       # steps per timed run at most (dt 1e-4 runs 5000 for the error)


def _ours(scene, torques, steps: int) -> tuple[dict, dict]:
    """Our run of ``steps`` steps (coordinates every step and the counts), and our contestants
    for ``timing.interleaved_us``: 'ours' a step, 'loop' a control loop's turn (set_torques,
    step, angles), each from the start after a reset."""
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(scene)
    order = {j.name: k for k, j in enumerate(scene.joints)}
    command = np.array([torques[order[name]] for name in sim.command_joint_names])
    sim.set_torques(command)
    angles, iterations = [], 0
    for _ in range(steps):
        sim.step()
        angles.append(sim.angles)
        iterations += int(sim.stats['newton_iterations'])
    totals = sim.problem_totals

    def restart():
        sim.reset()
        sim.set_torques(command)

    def loop():
        sim.set_torques(command)
        sim.step()
        return sim.angles

    return ({'angles': np.array(angles), 'newton_iterations': iterations / steps,
             'unconverged': totals['not_converged'],
             'rejected': totals['non_finite'] + totals['angle_aliased'],
             'line_search_failures': totals['line_search_failures']},
            {'ours': (restart, sim.step), 'loop': (restart, loop)})


def _timings(contestants: dict, steps: int, repeats: int) -> dict:
    """µs per step of every contestant (median of its interleaved samples), and ×Euler: the
    median over the repeats of our sample over MuJoCo Euler's of the same repeat."""
    from affine_joint_sim.bench.timing import interleaved_us

    samples = interleaved_us(contestants, min(steps, TIMED_STEPS), repeats)
    out = {f'{name}_us': statistics.median(values) for name, values in samples.items()}
    if 'euler' in samples:
        out['vs_euler'] = statistics.median(
            [a / b for a, b in zip(samples['ours'], samples['euler'])])
    return out


def _limit_exits(scene, ours: np.ndarray, reference: np.ndarray | None) -> int:
    """Joints that leave their limits in ours where the reference stays inside them."""
    lower = np.array([-np.inf if j.limit is None else j.limit.lower for j in scene.joints])
    upper = np.array([np.inf if j.limit is None else j.limit.upper for j in scene.joints])

    def outside(x):
        return ((x < lower - LIMIT_SLACK) | (x > upper + LIMIT_SLACK)).any(axis=0)
    inside = np.ones(len(lower), dtype=bool) if reference is None else ~outside(reference)
    return int((outside(ours) & inside).sum())


def mimic_gap(scene, angles: np.ndarray) -> float | None:
    """The largest |x_f − m x_l − o| [rad | m] over ``angles`` (steps × scene joints) and the
    scene's mimic joints; None without any."""
    gaps = [np.abs(angles[:, k] - j.mimic.multiplier * angles[:, scene.joint_index(j.mimic.joint)]
                   - j.mimic.offset).max() for k, j in enumerate(scene.joints) if j.mimic]
    return float(max(gaps)) if gaps else None


def measure_robot(name: str, settings: Settings) -> list[dict]:
    """One row per dt of ``settings`` for robot ``name`` (a zoo name or a URDF path): without
    joint friction in both simulators (whatever the URDF says), and again with friction
    (``zoo.frictions``, MuJoCo's friction loss) against a reference with that friction."""
    from affine_joint_sim.bench import mujoco_urdf, zoo

    finest = min(settings.dts)
    samples = round(settings.duration / finest)
    scenes, torques = zoo.load(name, settings.dts)
    kinds = {'': np.zeros(len(torques)), 'friction_': zoo.frictions(scenes[finest])}
    peers = {}
    if mujoco_urdf.available():
        for kind, friction in kinds.items():
            peer = mujoco_urdf.MujocoRobot(zoo.urdf_path(name), scenes[finest],
                                           friction if kind else None)
            peers[kind] = peer, peer.run(torques, settings.reference_dt, 'rk4',
                                         round(settings.duration / settings.reference_dt),
                                         every=round(finest / settings.reference_dt))
    rows = []
    for dt, scene in scenes.items():
        steps = round(settings.duration / dt)
        every = round(dt / finest)
        row = {'robot': Path(name).stem, 'joints': len(scene.joints), 'dt': dt}
        contestants, plain, plain_truth = {}, None, None
        for kind, friction in kinds.items():
            ours, timed = _ours(zoo.with_friction(scene, friction), torques, steps)
            if kind:
                contestants['friction'] = timed['ours']
                row['friction_problems'] = (ours['unconverged'] + ours['rejected']
                                            + ours['line_search_failures'])
            else:
                contestants.update(timed)
                plain = ours
                row.update({key: value for key, value in ours.items() if key != 'angles'})
                row['mimic_gap'] = mimic_gap(scene, ours['angles'])
            if kind in peers:
                peer, reference = peers[kind]
                truth = reference[every - 1:samples:every]
                if not kind:
                    plain_truth = truth
                row[f'{kind}error'] = float(np.abs(ours['angles'] - truth).max())
                for integrator in ('euler', 'rk4') if not kind else ('euler',):
                    coordinates = peer.run(torques, dt, integrator, steps)
                    row[f'{kind}{integrator}_error'] = float(np.abs(coordinates - truth).max())
                    if not kind and integrator == 'euler':
                        row['euler_mimic_gap'] = mimic_gap(scene, coordinates)
                    if not kind:
                        contestants[integrator] = peer.timer(torques, dt, integrator)
        row.update(_timings(contestants, steps, settings.repeats))
        row['us_per_step'] = row.pop('ours_us')
        row['limit_exits'] = _limit_exits(scene, plain['angles'], plain_truth)
        row['realtime'] = dt / (row['us_per_step'] * 1e-6)
        rows.append(row)
    return rows


COLUMNS = [
    Column('robot', 'robot'), Column('joints', 'joints'), Column('dt', 'dt [s]', '{:g}'),
    Column('us_per_step', 'µs/step', '{:.0f}'), Column('loop_us', 'loop µs', '{:.0f}'),
    Column('euler_us', 'MuJoCo Euler µs', '{:.1f}'), Column('rk4_us', 'RK4 µs', '{:.1f}'),
    Column('vs_euler', '× Euler', '{:.1f}'),
    Column('newton_iterations', 'Newton it.', '{:.2f}'),
    Column('unconverged', 'unconverged'), Column('rejected', 'rejected'),
    Column('line_search_failures', 'LS failures'), Column('limit_exits', 'limit exits'),
    Column('realtime', '× real time', '{:.1f}'),
    Column('error', 'max error ours', '{:.2e}'), Column('euler_error', 'Euler', '{:.2e}'),
    Column('rk4_error', 'RK4', '{:.2e}'),
    Column('mimic_gap', 'mimic gap ours', '{:.1e}'),
    Column('euler_mimic_gap', 'Euler', '{:.1e}'),
    Column('friction_us', 'with friction: µs/step', '{:.0f}'),
    Column('friction_problems', 'unconverged, rejected, LS failures'),
    Column('friction_error', 'max error ours', '{:.2e}'),
    Column('friction_euler_error', 'Euler', '{:.2e}')]


def run(results: Path, devices: list[str], settings: Settings, names=()) -> None:
    """Measure ``names`` (default: the whole zoo); print the rows as they come, write
    robots.md and robots.csv."""
    from affine_joint_sim.bench import mujoco_urdf, zoo

    if not names and not zoo.installed():
        print("bench robots skipped: the zoo's URDFs come from example-robot-data, the extra "
              "'zoo' (.venv/bin/pip install -e '.[zoo]')")
        return
    names = list(names) or list(zoo.ROBOTS)
    for name in names:
        zoo.urdf_path(name)             # every name checked before the first long run
    print(markdown_table([], COLUMNS))
    rows = []
    for name in names:
        for row in measure_robot(name, settings):
            print(markdown_row(row, COLUMNS), flush=True)
            rows.append(row)
    peer = ('' if mujoco_urdf.available() else
            "MuJoCo is not installed (extra 'compare'): no peer, no reference, no errors.\n\n")
    text = (f'## Robots: {settings.duration:g} s fixed-base, gravity compensation + '
            f'{zoo.PUSH:g} rad/s² (m/s²) on every joint, from the same pose\n\n{peer}'
            f'Reference: MuJoCo RK4 at dt {settings.reference_dt:g}; errors: largest |q − q_ref| '
            'over every step and joint [rad | m]. µs: median of '
            f'{settings.repeats} runs of up to {TIMED_STEPS} steps on one core, ours and '
            "MuJoCo's timed in turn; × Euler: the median of the ratios of runs timed together; "
            'loop: set_torques + step + angles. Without joint friction in both simulators '
            '(whatever the URDF says); with friction: each joint\'s Coulomb friction '
            f'{zoo.FRICTION_SHARE:g} of its push |(M(q0) a)_k|, a = {zoo.PUSH:g} on every joint, '
            'ours and MuJoCo\'s '
            'friction loss, against MuJoCo RK4 with that friction.\n\n'
            + markdown_table(rows, COLUMNS) + '\n')
    publish(results, 'robots', text, rows)


def add_parser(sections) -> None:
    parser = sections.add_parser(
        'robots', help='public URDF robots beside MuJoCo against a fine reference',
        description='Run the zoo (or the robots named: zoo names or URDF files) fixed-base '
                    'from a pose inside their limits under gravity compensation plus a push, '
                    'in this project and in MuJoCo; write robots.md and robots.csv into '
                    '--results. The zoo needs the extra zoo, MuJoCo the extra compare.')
    parser.add_argument('--quick', action='store_true',
                        help=f'{QUICK.duration:g} s at dt {", ".join(map(str, QUICK.dts))}, '
                             f'reference dt {QUICK.reference_dt:g}, one timed run')
    parser.add_argument('robots', nargs='*', help='zoo names or URDF files (default: the zoo)')

    def bench(args, devices) -> int:
        from affine_joint_sim.bench import zoo
        from affine_joint_sim.bench.zoo import ZooError

        args.results.mkdir(parents=True, exist_ok=True)
        try:
            if not args.robots and not zoo.installed():
                zoo.urdf_path(next(iter(zoo.ROBOTS)))     # says what to install
            run(args.results, devices, QUICK if args.quick else FULL, args.robots)
        except ZooError as exc:
            print(f'error: {exc}', file=sys.stderr)
            return 2
        return 0

    parser.set_defaults(bench_func=bench)
