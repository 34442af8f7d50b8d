"""``affine-joint-sim replay BAG... [--workers N | --ray ADDRESS] [--report FILE]``.

Ctrl-C or SIGTERM stops it (``stopping``): the bags replayed so far are reported (and written
to --report), the others are cancelled, and it exits 130 or 143.
"""

import importlib.util
import os
import sys
import time
from pathlib import Path

from affine_joint_sim.fleet.bags import expand_bags
from affine_joint_sim.fleet.executors import RAY_HINT, LostJob, run_pool, run_ray, run_serial
from affine_joint_sim.fleet.jobs import failed_result, replay_job
from affine_joint_sim.fleet.report import table, write_report
from affine_joint_sim.fleet.stopping import Stopped, stoppable
from affine_joint_sim.progress import Progress, print_above

__all__ = ['main', 'workers_for', 'executor_for']


def workers_for(requested: int | None, jobs: int) -> int:
    """Processes to use: as asked, else one per CPU; never more than there are jobs."""
    return max(1, min(requested or os.cpu_count() or 1, jobs))


def executor_for(workers: int | None, ray: str | None, jobs: int, warned):
    """(executor(function, jobs, progress) -> results, how it runs, in words): Ray at ``ray``,
    else ``workers`` processes (default one per CPU), else this process for one; the warnings
    of each job go to ``warned(job, line)``. RuntimeError: Ray asked for, not installed."""
    if ray:
        if importlib.util.find_spec('ray') is None:
            raise RuntimeError(RAY_HINT)
        return (lambda function, todo, progress: run_ray(function, todo, ray, progress,
                                                         warned), f'Ray at {ray}')
    count = workers_for(workers, jobs)
    if count == 1:
        return (lambda function, todo, progress: run_serial(function, todo, progress, warned),
                'this process')

    def pool(function, todo, progress):
        return run_pool(function, todo, count, progress,
                        lambda message: print_above(f'note: {message}'), warned)

    return pool, f'{count} worker processes'


def main(args) -> int:
    """Replay every bag named; exit 0 when all are within --tol, 1 when one diverged, 2 when
    one could not be read (each listed; the others are still done), 128 + the signal's number
    when stopped."""
    report = Path(args.report) if args.report else None
    if report is not None and (report.suffix.lower() not in ('.json', '.csv')
                               or not report.parent.is_dir()):
        print(f'affine-joint-sim replay: error: --report {report}: must be a .json or .csv '
              'file in an existing directory', file=sys.stderr)
        return 2
    bags, problems = expand_bags([str(b) for b in args.bag])
    jobs = [{'bag': str(b), 'tol': args.tol, 'scene': args.scene, 'device': args.device}
            for b in bags]
    bar, not_passed, finished = Progress(len(jobs)), [0], {}

    def tick(result):
        result = _as_result(result)
        finished[result['bag']] = result
        not_passed[0] += result['status'] != 'pass'
        bar.show(f'{not_passed[0]} not passed; last {Path(result["bag"]).name}')
        bar.advance()

    start, stop = time.perf_counter(), None
    try:
        executor, how = executor_for(args.workers, args.ray, len(jobs), _warned)
        bar.show(f'starting ({how})')
        with stoppable():
            results = [_as_result(r) for r in executor(replay_job, jobs, tick)]
    except RuntimeError as exc:
        print(f'affine-joint-sim replay: error: {exc}', file=sys.stderr)
        return 2
    except Stopped as stopped:
        sys.stderr.write('\n')                    # the progress bar's line ends
        stop, results = stopped, [finished[j['bag']] for j in jobs if j['bag'] in finished]
    wall = time.perf_counter() - start
    done = len(results)
    results += [failed_result(arg, why) for arg, why in problems]
    counts = {s: sum(r['status'] == s for r in results) for s in ('pass', 'fail', 'error')}
    print(table(results))
    what = (f'stopped by {stop.name}: {done} of {len(jobs)} bags replayed (the others '
            'cancelled)' if stop else f'{len(results)} bags')
    print(f'{what} on {how} in {wall:.1f} s (sum of job times '
          f'{sum(r["seconds"] for r in results):.1f} s): {counts["pass"]} within --tol '
          f'{args.tol:g}, {counts["fail"]} above, {counts["error"]} unreadable')
    if report is not None:
        write_report(report, results, {'tol': args.tol, 'executor': how, 'wall_seconds': wall,
                                       **counts, 'stopped_by': stop.name if stop else None})
        print(f'report: {report.resolve()}')
    if stop:
        return stop.exit_status
    return 2 if counts['error'] else 1 if counts['fail'] else 0


def _warned(job: dict, line: str) -> None:
    """A warning of a bag's replay, on its own line, naming the bag."""
    print_above(f'warning: {job["bag"]}: {line}')


def _as_result(result) -> dict:
    """A replay result; a job its executor lost is its bag's error."""
    return failed_result(result.job['bag'], result.why) if isinstance(result, LostJob) \
        else result
