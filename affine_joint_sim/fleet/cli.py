"""``affine-joint-sim replay BAG... [--workers N | --ray ADDRESS] [--report FILE]``."""

import os
import sys
import time
from pathlib import Path

from affine_joint_sim.fleet.bags import expand_bags
from affine_joint_sim.fleet.executors import LostJob, run_pool, run_ray, run_serial
from affine_joint_sim.fleet.jobs import failed_result, replay_job
from affine_joint_sim.fleet.report import table, write_report
from affine_joint_sim.progress import Progress

__all__ = ['main', 'workers_for', 'executor_for']


def workers_for(requested: int | None, jobs: int) -> int:
    """Processes to use: as asked, else one per CPU; never more than there are jobs."""
    return max(1, min(requested or os.cpu_count() or 1, jobs))


def executor_for(workers: int | None, ray: str | None, jobs: int):
    """(executor(function, jobs, progress) -> results, how it runs, in words): Ray at ``ray``,
    else ``workers`` processes (default one per CPU), else this process for one."""
    if ray:
        return (lambda function, todo, progress: run_ray(function, todo, ray, progress),
                f'Ray at {ray}')
    count = workers_for(workers, jobs)
    if count == 1:
        return run_serial, 'this process'

    def pool(function, todo, progress):
        return run_pool(function, todo, count, progress,
                        lambda message: print(f'\nnote: {message}', file=sys.stderr))

    return pool, f'{count} worker processes'


def main(args) -> int:
    """Replay every bag named; exit 0 when all are within --tol, 1 when one diverged, 2 when
    one could not be read (each listed; the others are still done)."""
    report = Path(args.report) if args.report else None
    if report is not None and (report.suffix.lower() not in ('.json', '.csv')
                               or not report.parent.is_dir()):
        print(f'affine-joint-sim replay: error: --report {report}: must be a .json or .csv '
              'file in an existing directory', file=sys.stderr)
        return 2
    bags, problems = expand_bags([str(b) for b in args.bag])
    jobs = [{'bag': str(b), 'tol': args.tol, 'scene': args.scene, 'device': args.device}
            for b in bags]
    bar, not_passed = Progress(len(jobs)), [0]

    def tick(result):
        result = _as_result(result)
        not_passed[0] += result['status'] != 'pass'
        bar.show(f'{not_passed[0]} not passed; last {Path(result["bag"]).name}')
        bar.advance()

    start = time.perf_counter()
    try:
        executor, how = executor_for(args.workers, args.ray, len(jobs))
        results = [_as_result(r) for r in executor(replay_job, jobs, tick)]
    except RuntimeError as exc:
        print(f'affine-joint-sim replay: error: {exc}', file=sys.stderr)
        return 2
    wall = time.perf_counter() - start
    results += [failed_result(arg, why) for arg, why in problems]
    counts = {s: sum(r['status'] == s for r in results) for s in ('pass', 'fail', 'error')}
    print(table(results))
    print(f'{len(results)} bags on {how} in {wall:.1f} s (sum of job times '
          f'{sum(r["seconds"] for r in results):.1f} s): {counts["pass"]} within --tol '
          f'{args.tol:g}, {counts["fail"]} above, {counts["error"]} unreadable')
    if report is not None:
        write_report(report, results, {'tol': args.tol, 'executor': how, 'wall_seconds': wall,
                                       **counts})
        print(f'report: {report.resolve()}')
    return 2 if counts['error'] else 1 if counts['fail'] else 0


def _as_result(result) -> dict:
    """A replay result; a job its executor lost is its bag's error."""
    return failed_result(result.job['bag'], result.why) if isinstance(result, LostJob) \
        else result
