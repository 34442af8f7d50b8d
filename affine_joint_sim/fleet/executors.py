"""Running jobs: in this process, on a local process pool, or on a Ray cluster.

Every executor returns the results in the order of the jobs, whatever order they finish in, so
a report does not depend on the executor. A worker process that dies (killed, out of memory)
loses only its jobs: they are run again, up to ``RETRIES`` more times, on fresh workers (the
process pool) or by Ray's own task retries; a job still without a result is a ``LostJob``
naming what happened, and the other jobs complete.

Every job runs through ``worker.run_job`` (Warp quiet; its warnings come back with its result
and go to ``warned(job, line)``). An exception that ends the wait for results (``Stopped``:
Ctrl-C or SIGTERM) cancels the jobs not started and ends the pool's workers before it goes on
up, so that no worker outlives the command.
"""

import multiprocessing
import signal
from dataclasses import dataclass
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from affine_joint_sim.fleet.stopping import SIGNALS, ignore_interrupts
from affine_joint_sim.fleet.worker import run_job
from affine_joint_sim.progress import print_above

__all__ = ['run_serial', 'run_pool', 'run_ray', 'LostJob', 'RETRIES', 'RAY_HINT']

RETRIES = 2
RAY_HINT = "Ray is not installed: pip install -e '.[cluster]' (or use --workers N)"


@dataclass(frozen=True)
class LostJob:
    """In place of the result of a job that produced none: its arguments and why."""

    job: dict
    why: str


def _warn_unnamed(job: dict, line: str) -> None:
    """The default ``warned``: the warning alone (the caller gave no name to its jobs)."""
    print_above(f'warning: {line}')


def _result(outcome, job: dict, warned) -> object:
    """The result of a job's ``Outcome``, its warnings handed to ``warned`` first."""
    for line in outcome.warnings:
        warned(job, line)
    return outcome.result


def run_serial(function, jobs: list[dict], progress=None, warned=_warn_unnamed) -> list:
    """Each job in turn, here."""
    results = []
    for job in jobs:
        results.append(_result(run_job(function, job), job, warned))
        if progress:
            progress(results[-1])
    return results


def _end_workers(pool: ProcessPoolExecutor) -> None:
    """Cancel the jobs not started and kill the pool's worker processes now, rather than
    waiting for the jobs they run (what Python 3.14's ``terminate_workers`` does; 3.12 has
    only the pool's process table for it)."""
    processes = list((pool._processes or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()
    for process in processes:
        process.join()


def run_pool(function, jobs: list[dict], workers: int, progress=None, say=print,
             warned=_warn_unnamed) -> list:
    """The jobs on ``workers`` spawned processes (which ignore Ctrl-C: see ``stopping``); jobs
    of a worker that died run again (and ``say`` is told so)."""
    results = [None] * len(jobs)
    attempts = [0] * len(jobs)
    pending = list(range(len(jobs)))
    context = multiprocessing.get_context('spawn')
    while pending:
        broken = []
        with ProcessPoolExecutor(max_workers=min(workers, len(pending)), mp_context=context,
                                 initializer=ignore_interrupts) as pool:
            try:
                futures = {}
                for n, i in enumerate(pending):
                    try:
                        futures[pool.submit(run_job, function, jobs[i])] = i
                    except BrokenProcessPool:   # a worker died while jobs were handed out
                        broken = pending[n:]
                        break
                for i in broken:
                    attempts[i] += 1
                for future in as_completed(futures):
                    i = futures[future]
                    attempts[i] += 1
                    try:
                        results[i] = _result(future.result(), jobs[i], warned)
                    except BrokenProcessPool:
                        broken.append(i)
                        continue
                    except Exception as exc:    # the job raised: reported, the rest goes on
                        results[i] = LostJob(jobs[i], f'{type(exc).__name__}: {exc}')
                    if progress:
                        progress(results[i])
            except BaseException:               # Stopped, mostly: no worker outlives it
                _end_workers(pool)
                raise
        pending = []
        for i in broken:
            if attempts[i] <= RETRIES:
                pending.append(i)
            else:
                results[i] = LostJob(jobs[i], f'its worker pool broke {attempts[i]} times '
                                     'before the job finished (a worker process died)')
                if progress:
                    progress(results[i])
        if pending:
            say(f'a worker process died: {len(pending)} unfinished job(s) run again on fresh '
                'workers')
    return results


def run_ray(function, jobs: list[dict], address: str, progress=None,
            warned=_warn_unnamed) -> list:
    """The jobs as Ray tasks on the cluster at ``address`` ('local': a Ray started here for
    this run; 'auto': the one ``ray start`` runs on this machine), retried by Ray when a worker
    dies (Ray must be installed: ``fleet.cli.executor_for`` says so otherwise). Leaving, by
    the end or by ``Stopped``, shuts this driver down, and Ray ends the tasks of a driver that
    is gone."""
    import ray

    handlers = {number: signal.getsignal(number) for number in SIGNALS}
    ray.init(address=None if address == 'local' else address, include_dashboard=False,
             log_to_driver=False, ignore_reinit_error=True)
    for number, handler in handlers.items():    # a local Ray head installs its own SIGTERM
        signal.signal(number, handler)
    try:
        task = ray.remote(max_retries=RETRIES, retry_exceptions=False)(run_job)
        refs = [task.remote(function, job) for job in jobs]
        index = {ref: i for i, ref in enumerate(refs)}
        results = [None] * len(jobs)
        waiting = list(refs)
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            i = index[done[0]]
            try:
                results[i] = _result(ray.get(done[0]), jobs[i], warned)
            except Exception as exc:          # Ray's own: a task or its workers failed
                first_line = str(exc).splitlines()[0] if str(exc) else ''
                results[i] = LostJob(jobs[i], f'{type(exc).__name__}: {first_line}')
            if progress:
                progress(results[i])
        return results
    finally:
        ray.shutdown()
