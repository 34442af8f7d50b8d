"""Running jobs: in this process, on a local process pool, or on a Ray cluster.

Every executor returns the results in the order of the jobs, whatever order they finish in, so
a report does not depend on the executor. A worker process that dies (killed, out of memory)
loses only its jobs: they are run again, up to ``RETRIES`` more times, on fresh workers (the
process pool) or by Ray's own task retries; a job still without a result is a ``LostJob``
naming what happened, and the other jobs complete.
"""

import multiprocessing
from dataclasses import dataclass
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

__all__ = ['run_serial', 'run_pool', 'run_ray', 'LostJob', 'RETRIES', 'RAY_HINT']

RETRIES = 2
RAY_HINT = "Ray is not installed: pip install -e '.[cluster]' (or use --workers N)"


@dataclass(frozen=True)
class LostJob:
    """In place of the result of a job that produced none: its arguments and why."""

    job: dict
    why: str


def run_serial(function, jobs: list[dict], progress=None) -> list:
    """Each job in turn, here."""
    results = []
    for job in jobs:
        results.append(function(**job))
        if progress:
            progress(results[-1])
    return results


def run_pool(function, jobs: list[dict], workers: int, progress=None, say=print) -> list:
    """The jobs on ``workers`` spawned processes; jobs of a worker that died run again (and
    ``say`` is told so)."""
    results = [None] * len(jobs)
    attempts = [0] * len(jobs)
    pending = list(range(len(jobs)))
    context = multiprocessing.get_context('spawn')
    while pending:
        broken = []
        with ProcessPoolExecutor(max_workers=min(workers, len(pending)),
                                 mp_context=context) as pool:
            futures = {}
            for n, i in enumerate(pending):
                try:
                    futures[pool.submit(function, **jobs[i])] = i
                except BrokenProcessPool:   # a worker died while jobs were still handed out
                    broken = pending[n:]
                    break
            for i in broken:
                attempts[i] += 1
            for future in as_completed(futures):
                i = futures[future]
                attempts[i] += 1
                try:
                    results[i] = future.result()
                except BrokenProcessPool:
                    broken.append(i)
                    continue
                except Exception as exc:        # the job raised: reported, the rest goes on
                    results[i] = LostJob(jobs[i], f'{type(exc).__name__}: {exc}')
                if progress:
                    progress(results[i])
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


def run_ray(function, jobs: list[dict], address: str, progress=None) -> list:
    """The jobs as Ray tasks on the cluster at ``address`` ('local': a Ray started here for
    this run; 'auto': the one ``ray start`` runs on this machine), retried by Ray when a worker
    dies."""
    try:
        import ray
    except ImportError:
        raise RuntimeError(RAY_HINT) from None
    ray.init(address=None if address == 'local' else address, include_dashboard=False,
             log_to_driver=False, ignore_reinit_error=True)
    try:
        task = ray.remote(max_retries=RETRIES, retry_exceptions=False)(function)
        refs = [task.remote(**job) for job in jobs]
        index = {ref: i for i, ref in enumerate(refs)}
        results = [None] * len(jobs)
        waiting = list(refs)
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            i = index[done[0]]
            try:
                results[i] = ray.get(done[0])
            except Exception as exc:          # Ray's own: a task or its workers failed
                first_line = str(exc).splitlines()[0] if str(exc) else ''
                results[i] = LostJob(jobs[i], f'{type(exc).__name__}: {first_line}')
            if progress:
                progress(results[i])
        return results
    finally:
        ray.shutdown()
