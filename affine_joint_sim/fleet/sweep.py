"""``affine-joint-sim sweep SPEC.yaml --out DIR [--workers N | --ray ADDRESS]``: the bench's
speed/accuracy sweep over a declared grid (the spec: ``sweep_spec``), its settings run as
parallel jobs.

It writes what ``bench sweep`` writes (sweep.csv, sweep.md, the Pareto and order plots) into
--out, through the same code (``bench.sweep.run``), without the wheel's damping section. The
command profiles of one scene entry are one job per setting: the environments of one batched
stepper (``num_envs``), each compared with its own reference.

Before any job runs it checks the spec, says how many jobs there are (and warns above
``LARGE``), and computes every case's reference, with a progress bar (which also checks that
the rigid reference can model the case). Ctrl-C or SIGTERM stops it (``stopping``): the rows
of the jobs that finished go to sweep.csv, and it exits 130 or 143.
"""

import sys
from pathlib import Path

from affine_joint_sim.fleet.stopping import Stopped, stoppable
from affine_joint_sim.fleet.sweep_spec import check_devices, load_spec
from affine_joint_sim.progress import Progress, print_above

__all__ = ['main', 'LARGE']

LARGE = 1000   # jobs above which a sweep is warned about: ~twice the full `bench sweep` on a CPU


def main(args) -> int:
    """Run the sweep; 0, 2 with the problem on stderr, or 128 + a stop signal's number."""
    from affine_joint_sim.bench.sweep import Settings, run, setting_jobs
    from affine_joint_sim.fleet.cli import executor_for

    path = Path(args.spec)
    try:
        spec = load_spec(path)
        if args.ray in (None, 'local'):           # a cluster's devices are its hosts'
            check_devices(path, spec)
        settings = Settings(tuple(spec.dt), tuple(spec.integrator), tuple(spec.newton_tol),
                            tuple(spec.precision), None, spec.repeats, damping=False)
        jobs = len(setting_jobs(spec.batches(), settings, spec.device))
        executor, how = executor_for(args.workers, args.ray, jobs, _warned)
    except (ValueError, OSError, RuntimeError) as exc:
        return _error(exc)
    batches = len(spec.batches())
    _say(f'{jobs} jobs ({_cases(batches)} × {jobs // batches} settings) on {how}')
    if jobs > LARGE:
        _say(f'warning: {jobs} jobs is a large sweep (above {LARGE}): Ctrl-C stops it and '
             'keeps the rows of the jobs done')
    finished = []
    try:
        with stoppable():
            try:
                _references(spec.batches())
            except ValueError as exc:             # a case the rigid reference cannot model
                return _error(exc)
            args.out.mkdir(parents=True, exist_ok=True)
            run(args.out, spec.device, settings, executor=_counting(executor, finished),
                batches=spec.batches())
    except Stopped as stop:
        return _stopped(stop, finished, jobs, args.out)
    print(f'ran on {how}')
    return 0


def _error(exc: Exception) -> int:
    """The problem, one line on stderr; exit status 2."""
    print(f'affine-joint-sim sweep: error: {str(exc).strip()}', file=sys.stderr)
    return 2


def _say(line: str) -> None:
    """What the sweep is doing, on stderr (stdout has its results)."""
    print(f'sweep: {line}', file=sys.stderr)


def _cases(count: int) -> str:
    """'1 case', '2 cases'."""
    return f'{count} case{"s" * (count != 1)}'


def _references(batches: list) -> None:
    """Every case's reference, computed here once (RK4: seconds for a large scene) so that a
    case it cannot model stops the sweep before any job runs."""
    from affine_joint_sim.bench.sweep import case_and_truth

    keys = [key for batch in batches for key in batch]
    _say(f'computing the rigid-body reference of {_cases(len(keys))} (each worker computes '
         'those of its jobs again)')
    bar = Progress(len(keys))
    for key in keys:
        bar.show(key if isinstance(key, str) else key[0])
        case_and_truth(key)
        bar.advance()


def _warned(job: dict, line: str) -> None:
    """A warning of a job, on its own line, naming the job's cases and setting."""
    from affine_joint_sim.bench.sweep import case_and_truth

    names = ', '.join(case_and_truth(key)[0].name for key in job['cases'])
    print_above(f'warning: {names} {job["device"]} {job["precision"]} {job["integrator"]} '
                f'dt {job["dt"]:g} newton_tol {job["newton_tol"]:g}: {line}')


def _counting(executor, finished: list):
    """``executor``, also appending each job's result to ``finished`` as it comes."""
    def counted(function, jobs, progress):
        def tick(result):
            finished.append(result)
            progress(result)

        return executor(function, jobs, tick)

    return counted


def _stopped(stop: Stopped, finished: list, jobs: int, out: Path) -> int:
    """Write the rows of the ``finished`` jobs to sweep.csv, say so; 128 + the signal."""
    from affine_joint_sim.bench.report import write_csv
    from affine_joint_sim.fleet.executors import LostJob

    sys.stderr.write('\n')                        # the progress bar's line ends
    rows = [row for result in finished if not isinstance(result, LostJob) for row in result]
    where = 'nothing written'
    if rows:
        write_csv(out / 'sweep.csv', rows)
        where = (f'their {len(rows)} rows are in {out / "sweep.csv"} (no sweep.md or plots: '
                 'they need every job)')
    print(f'stopped by {stop.name}: {len(finished)} of {jobs} jobs finished; {where}')
    return stop.exit_status
