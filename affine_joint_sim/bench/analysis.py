"""What the sweep's rows say: Pareto fronts, the cheapest setting per accuracy, fitted orders.

Rows are the dicts of ``bench.measure``; cost is ``ms_per_sim_s`` (wall time per simulated
second, which is what a smaller dt really costs), accuracy is ``error_rad``.
"""

import math

from affine_joint_sim.bench.scaling import loglog_exponent

__all__ = ['ERROR_TARGETS', 'cheapest_reaching', 'fitted_orders', 'pareto_front']

ERROR_TARGETS = (1e-2, 1e-3, 1e-4)    # rad


def pareto_front(rows: list[dict], cost: str = 'ms_per_sim_s',
                 error: str = 'error_rad') -> list[dict]:
    """The rows no other row beats in both cost and error, by increasing cost."""
    front, best = [], math.inf
    for row in sorted(rows, key=lambda r: (r[cost], r[error])):
        if row[error] < best:
            front.append(row)
            best = row[error]
    return front


def cheapest_reaching(rows: list[dict], target: float,
                      cost: str = 'ms_per_sim_s') -> dict | None:
    """The cheapest row whose error is at most ``target`` [rad] (None if none reaches it)."""
    good = [row for row in rows if row['error_rad'] <= target]
    return min(good, key=lambda r: r[cost]) if good else None


def fitted_orders(rows: list[dict], floor: float = 0.0) -> dict:
    """Order p of error ∝ dt^p per integrator, fitted in log-log over its rows.

    Rows of one integrator are expected to differ only in dt. Errors at or below ``floor``
    [rad] (e.g. where the reference itself is no more accurate) are left out.
    """
    orders = {}
    for integrator in dict.fromkeys(row['integrator'] for row in rows):
        points = [(row['dt'], row['error_rad']) for row in rows
                  if row['integrator'] == integrator and row['error_rad'] > floor]
        if len(points) >= 2:
            orders[integrator] = loglog_exponent(*zip(*points))
    return orders
