"""What runs around every job of a fleet command, wherever it runs (this process, a pool
worker, a Ray task): Warp set up quietly once per process, and the warnings the job raises
handed back with its result, so that the main process prints each on a line of its own that
names the job (rather than a worker writing into the progress bar, once per worker)."""

import warnings
from dataclasses import dataclass

from affine_joint_sim.quiet_warp import quiet_warp

__all__ = ['Outcome', 'run_job']


@dataclass(frozen=True)
class Outcome:
    """A job's result and its warnings, each 'Category: message' on one line."""

    result: object
    warnings: tuple[str, ...]


def run_job(function, job: dict) -> Outcome:
    """``function(**job)`` with Warp quiet and its warnings recorded (each once per place that
    raises it, as Python shows them)."""
    quiet_warp()
    with warnings.catch_warnings(record=True) as caught:
        result = function(**job)
    return Outcome(result, tuple(f'{w.category.__name__}: ' + ' '.join(str(w.message).split())
                                 for w in caught))
