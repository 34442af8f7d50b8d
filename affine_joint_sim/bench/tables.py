"""The sweep's markdown tables: their columns, and the rows that the order fits use."""

from affine_joint_sim.bench.analysis import fitted_orders
from affine_joint_sim.bench.report import Column

__all__ = ['COLUMNS', 'order_rows', 'order_series_rows']

_KNOBS = [Column('integrator', 'integrator'), Column('dt', 'dt [s]', '{:g}'),
          Column('newton_tol', 'newton_tol', '{:g}'), Column('precision', 'precision'),
          Column('device', 'device')]
_COST = [Column('error_rad', 'error [rad]', '{:.2e}'),
         Column('us_per_step', 'µs/step', '{:.1f}'),
         Column('ms_per_sim_s', 'ms per simulated s', '{:.1f}')]
COLUMNS = {
    'run': _KNOBS + _COST + [
        Column('newton_iterations', 'Newton it./step', '{:.2f}'),
        Column('joint_gap_m', 'joint gap [m]', '{:.1e}'),
        Column('energy_drift_rel', 'energy drift / KE_max', '{:.1e}'),
        Column('converged_pct', 'converged [%]', '{:.1f}')],
    'reach': [Column('target', 'error ≤ [rad]', '{:g}')] + _KNOBS + _COST,
    'order': [Column('integrator', 'integrator'), Column('order', 'fitted order', '{:.2f}'),
              Column('dt_range', 'dt [s]'), Column('error_range', 'error [rad]')],
}


def order_series_rows(rows: list[dict]) -> list[dict]:
    """Rows for log error against log dt: the stepper in float64 at its tightest tolerance on
    the first device, and every MuJoCo row."""
    ours = [row for row in rows if row['newton_tol'] is not None
            and row['precision'] == 'float64']
    if not ours:
        return [row for row in rows if row['newton_tol'] is None]
    tightest = min(row['newton_tol'] for row in ours)
    device = ours[0]['device']
    return [row for row in rows if row['newton_tol'] is None or (
        row in ours and row['newton_tol'] == tightest and row['device'] == device)]


def order_rows(rows: list[dict], floor: float) -> list[dict]:
    """One table row per integrator of ``order_series_rows(rows)``: the order fitted above
    ``floor`` [rad], and the dt and error ranges."""
    series = order_series_rows(rows)
    table = []
    for integrator, order in fitted_orders(series, floor).items():
        mine = sorted((r['dt'], r['error_rad']) for r in series
                      if r['integrator'] == integrator)
        table.append({'integrator': integrator, 'order': order,
                      'dt_range': f'{mine[-1][0]:g} … {mine[0][0]:g}',
                      'error_range': f'{mine[-1][1]:.1e} … {mine[0][1]:.1e}'})
    return table
