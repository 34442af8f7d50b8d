"""``bench sweep``: the speed/accuracy trade of every knob, measured against independent truth.

For each case of ``bench.cases`` (the packaged scenes under constant torques, a falling chain
and the URDF arm) every combination of dt, integrator, newton_tol, precision and device is
simulated, timed and compared with the case's rigid-body reference (``bench.measure``). With MuJoCo
installed (extra ``compare``) its Euler and RK4 run the chain cases at the same dts in the same
run. Writes ``sweep.csv`` (every run), ``sweep.md`` (per case: the cheapest setting reaching
1e-2/1e-3/1e-4 rad, fitted orders, the Pareto front), ``sweep_<case>.png`` (error against cost
per knob) and ``order_<case>.png`` (log error against log dt), plus the wheel's rotational
damping (``bench.damping``).
"""

import functools
import itertools
import sys
from pathlib import Path
from typing import NamedTuple

from affine_joint_sim.bench.section import add_section
from affine_joint_sim.progress import Progress

__all__ = ['FULL', 'QUICK', 'Settings', 'add_parser', 'run']


class Settings(NamedTuple):
    dts: tuple            # s
    integrators: tuple
    tolerances: tuple     # newton_tol [m/s]
    precisions: tuple
    cases: tuple | None   # case names (None: all)
    repeats: int          # timed runs per setting (median reported)
    damping: bool = True  # the wheel's rotational damping section too


FULL = Settings((0.02, 0.01, 0.005, 0.002, 0.001, 0.0005), ('bdf1', 'bdf2'),
                (1e-2, 1e-4, 1e-6, 1e-8), ('float64', 'float32'), None, 3)
QUICK = Settings((0.02, 0.005, 0.001), ('bdf1', 'bdf2'), (1e-2, 1e-6), ('float64',),
                 ('pendulum', 'wheel'), 1)


def _grid(settings: Settings, devices: list[str]):
    """Every stepper setting, cheapest knobs last so a slow float32 run shows up early."""
    return list(itertools.product(devices, settings.precisions, settings.integrators,
                                  settings.tolerances, settings.dts))


def setting_jobs(batches: list, settings: Settings, devices: list[str]) -> list[dict]:
    """One job per batch of cases (cases that differ only in their torques run as one batched
    stepper's environments) and setting of the grid: ``sweep_job``'s arguments."""
    return [dict(cases=list(batch), device=device, precision=precision,
                 integrator=integrator, newton_tol=tol, dt=dt, repeats=settings.repeats)
            for batch in batches
            for device, precision, integrator, tol, dt in _grid(settings, devices)]


@functools.lru_cache(maxsize=None)
def case_and_truth(key):
    """The case a key names (a bench case's name, or a (scene, torques, duration) tuple of
    ``bench.cases.custom_case``) and its reference, computed once per process."""
    from affine_joint_sim.bench.cases import cases, custom_case, reference

    case = (next(c for c in cases() if c.name == key) if isinstance(key, str) else
            custom_case(*key))
    return case, reference(case)


def sweep_job(cases: list, device: str, precision: str, integrator: str, newton_tol: float,
              dt: float, repeats: int) -> list[dict]:
    """The rows of one batch of cases at one setting, each against its truth."""
    from affine_joint_sim.bench.measure import run_stepper_batch

    found = [case_and_truth(key) for key in cases]
    return run_stepper_batch([c for c, _ in found], [t for _, t in found], dt=dt,
                             integrator=integrator, newton_tol=newton_tol,
                             precision=precision, device=device, repeats=repeats)


def mujoco_rows(case, truth, settings: Settings) -> list[dict]:
    """MuJoCo's Euler and RK4 on the dts, where the case has a MuJoCo twin and MuJoCo is
    installed."""
    from affine_joint_sim.bench.measure import run_mujoco

    rows = []
    for integrator, dt in itertools.product(('Euler', 'RK4'), settings.dts):
        row = run_mujoco(case, truth, dt=dt, integrator=integrator, repeats=settings.repeats)
        if row is not None:
            rows.append(row)
    return rows


def fit_floor(truth) -> float:
    """Errors below ten times the reference's own error estimate [rad] are not fitted."""
    return 10.0 * max(truth.error_estimate, 1e-15)


def _summary(case_name: str, truth, rows: list[dict]) -> str:
    from affine_joint_sim.bench.analysis import ERROR_TARGETS, cheapest_reaching, pareto_front
    from affine_joint_sim.bench.report import markdown_table
    from affine_joint_sim.bench.tables import COLUMNS, order_rows

    ours = [row for row in rows if not row['integrator'].startswith('mujoco')]
    reach = []
    for target, precision in itertools.product(ERROR_TARGETS, dict.fromkeys(
            row['precision'] for row in ours)):
        best = cheapest_reaching([row for row in ours if row['precision'] == precision], target)
        reach.append(dict(best or {'precision': precision}, target=target))
    orders = order_rows(rows, fit_floor(truth))
    return '\n\n'.join([
        f'## {case_name}\n\nReference: {truth.label} (its own error estimate '
        f'{truth.error_estimate:.1e} rad).',
        '### Cheapest setting reaching each error, per precision\n\n' + markdown_table(
            reach, COLUMNS['reach']),
        '### Fitted order (error ∝ dt^p; float64, tightest tolerance; MuJoCo for scale)\n\n'
        + markdown_table(orders, COLUMNS['order']),
        '### Pareto front (no other run is both cheaper and more accurate)\n\n'
        + markdown_table(pareto_front(ours), COLUMNS['run'])])


def run(results: Path, devices: list[str], settings: Settings, cases=None, executor=None,
        batches=None) -> None:
    """Measure every case on the grid (only those named in ``cases``, if given; ``batches``:
    lists of case keys to measure instead, each list run as one batched stepper); write CSV,
    markdown and plots; print where they are. ``executor(function, jobs, progress)`` runs the
    jobs (default: here, one after the other; ``affine-joint-sim sweep`` passes a process pool
    or Ray)."""
    from affine_joint_sim.bench import damping
    from affine_joint_sim.bench.analysis import fitted_orders
    from affine_joint_sim.bench.cases import cases as all_cases
    from affine_joint_sim.bench.plots import order_plot, tradeoff_plot
    from affine_joint_sim.bench.report import write_csv
    from affine_joint_sim.bench.tables import order_series_rows
    from affine_joint_sim.fleet.executors import LostJob, run_serial

    if cases:
        settings = settings._replace(cases=tuple(cases))
    if batches is None:
        batches = [[c.name] for c in all_cases()
                   if settings.cases is None or c.name in settings.cases]
    jobs = setting_jobs(batches, settings, devices)
    progress = Progress(len(jobs))
    progress.show('starting')

    def tick(rows):
        progress.show(rows.why if isinstance(rows, LostJob) else
                      f'{rows[0]["scene"]} {rows[0]["precision"]} {rows[0]["integrator"]} '
                      f'dt {rows[0]["dt"]:g}')
        progress.advance()

    results_of_jobs = (executor or run_serial)(sweep_job, jobs, tick)
    rows_of = {}
    for job, rows in zip(jobs, results_of_jobs):
        if isinstance(rows, LostJob):         # said, skipped
            print(f'sweep: no result for {job}: {rows.why}', file=sys.stderr)
            continue
        for key, row in zip(job['cases'], rows):
            rows_of.setdefault(key, []).append(row)
    all_rows, sections = [], []
    for key in (key for batch in batches for key in batch if key in rows_of):
        case, truth = case_and_truth(key)
        case_rows = list(rows_of[key])
        case_rows += mujoco_rows(case, truth, settings)
        all_rows += case_rows
        sections.append(_summary(case.name, truth, case_rows))
        tradeoff_plot(results / f'sweep_{case.name}.png', case_rows,
                      f'{case.name}: error against cost, per knob')
        series, floor = order_series_rows(case_rows), fit_floor(truth)
        order_plot(results / f'order_{case.name}.png', series, fitted_orders(series, floor),
                   floor, f'{case.name}: convergence in dt')
    write_csv(results / 'sweep.csv', all_rows)
    if settings.damping:
        sections.append(damping.run(results, settings.dts))
    text = '# Speed against accuracy\n\n' + '\n\n'.join(sections) + '\n'
    (results / 'sweep.md').write_text(text)
    print(text)
    print(f'sweep results: {results / "sweep.md"}, {results / "sweep.csv"}, '
          f'{results}/sweep_*.png, {results}/order_*.png'
          + (f', {results / "damping.md"}' if settings.damping else ''))


def add_parser(sections) -> None:
    parser = add_section(
        sections, 'sweep', run, FULL, QUICK, extra=('cases',),
        help='error against cost of dt, integrator, newton_tol, precision, device',
        description='Sweep the solver knobs on the packaged scenes and a falling chain; '
                    'measure error against a rigid-body reference, µs/step, Newton '
                    'iterations, joint gap and energy drift; write sweep.csv, sweep.md and '
                    'PNG plots into --results.',
        quick_help='a smoke run: pendulum and wheel, 3 dts, 2 tolerances, float64')
    parser.add_argument('--case', dest='cases', action='append', default=None,
                        help='only this case (repeatable): pendulum, double_pendulum, '
                             'chain8, wheel, arm, arm6 (the URDF arm)')
