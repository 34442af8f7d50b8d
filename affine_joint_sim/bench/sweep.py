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

import itertools
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


FULL = Settings((0.02, 0.01, 0.005, 0.002, 0.001, 0.0005), ('bdf1', 'bdf2'),
                (1e-2, 1e-4, 1e-6, 1e-8), ('float64', 'float32'), None, 3)
QUICK = Settings((0.02, 0.005, 0.001), ('bdf1', 'bdf2'), (1e-2, 1e-6), ('float64',),
                 ('pendulum', 'wheel'), 1)


def _grid(settings: Settings, devices: list[str]):
    """Every stepper setting, cheapest knobs last so a slow float32 run shows up early."""
    return list(itertools.product(devices, settings.precisions, settings.integrators,
                                  settings.tolerances, settings.dts))


def measure_case(case, settings: Settings, devices: list[str], progress: Progress):
    """All rows of one case: the stepper on the grid, MuJoCo's Euler and RK4 on the dts."""
    from affine_joint_sim.bench.cases import reference
    from affine_joint_sim.bench.measure import run_mujoco, run_stepper

    progress.show(f'{case.name}: reference')
    truth = reference(case)
    rows = []
    for device, precision, integrator, tol, dt in _grid(settings, devices):
        progress.show(f'{case.name} {device} {precision} {integrator} tol {tol:g} dt {dt:g}')
        rows.append(run_stepper(case, truth, dt=dt, integrator=integrator, newton_tol=tol,
                                precision=precision, device=device, repeats=settings.repeats))
        progress.advance()
    for integrator, dt in itertools.product(('Euler', 'RK4'), settings.dts):
        row = run_mujoco(case, truth, dt=dt, integrator=integrator, repeats=settings.repeats)
        if row is not None:
            rows.append(row)
    return truth, rows


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


def run(results: Path, devices: list[str], settings: Settings, cases=None) -> None:
    """Measure every case on the grid (only those named in ``cases``, if given); write CSV,
    markdown and plots; print where they are."""
    from affine_joint_sim.bench import damping
    from affine_joint_sim.bench.analysis import fitted_orders
    from affine_joint_sim.bench.cases import cases as all_cases
    from affine_joint_sim.bench.plots import order_plot, tradeoff_plot
    from affine_joint_sim.bench.report import write_csv
    from affine_joint_sim.bench.tables import order_series_rows

    if cases:
        settings = settings._replace(cases=tuple(cases))
    chosen = [c for c in all_cases() if settings.cases is None or c.name in settings.cases]
    progress = Progress(len(chosen) * len(_grid(settings, devices)))
    all_rows, sections = [], []
    for case in chosen:
        truth, rows = measure_case(case, settings, devices, progress)
        all_rows += rows
        sections.append(_summary(case.name, truth, rows))
        tradeoff_plot(results / f'sweep_{case.name}.png', rows,
                      f'{case.name}: error against cost, per knob')
        series, floor = order_series_rows(rows), fit_floor(truth)
        order_plot(results / f'order_{case.name}.png', series, fitted_orders(series, floor),
                   floor, f'{case.name}: convergence in dt')
    write_csv(results / 'sweep.csv', all_rows)
    sections.append(damping.run(results, settings.dts))
    text = '# Speed against accuracy\n\n' + '\n\n'.join(sections) + '\n'
    (results / 'sweep.md').write_text(text)
    print(text)
    print(f'sweep results: {results / "sweep.md"}, {results / "sweep.csv"}, '
          f'{results}/sweep_*.png, {results}/order_*.png, {results / "damping.md"}')



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
