"""PNG plots of the sweep: error against cost per knob with the Pareto front, and the order plot.

Matplotlib is imported inside the functions only (``bench`` extra).
"""

from pathlib import Path

from affine_joint_sim.bench.analysis import pareto_front
from affine_joint_sim.bench.report import loglog_plot

__all__ = ['KNOBS', 'order_plot', 'tradeoff_plot']

KNOBS = ('dt', 'integrator', 'newton_tol', 'precision', 'device')
MUJOCO_MARKERS = {'mujoco_euler': 'x', 'mujoco_rk4': '+'}


def tradeoff_plot(path: Path, rows: list[dict], title: str) -> None:
    """Error [rad] against cost [ms per simulated s], one panel per knob that varies, points
    coloured by that knob; the stepper's Pareto front and MuJoCo's runs on every panel."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    ours = [row for row in rows if row['integrator'] not in MUJOCO_MARKERS]
    theirs = [row for row in rows if row['integrator'] in MUJOCO_MARKERS]
    knobs = [k for k in KNOBS if len({row[k] for row in ours}) > 1] or ['dt']   # one panel
    front = pareto_front(ours)
    fig, axes = plt.subplots(1, len(knobs), figsize=(4.2 * len(knobs), 4.2), sharey=True,
                             squeeze=False)
    for ax, knob in zip(axes[0], knobs):
        for value in sorted({row[knob] for row in ours}):
            chosen = [row for row in ours if row[knob] == value]
            ax.scatter([r['ms_per_sim_s'] for r in chosen], [r['error_rad'] for r in chosen],
                       s=14, alpha=0.75, label=f'{knob} {value:g}' if isinstance(value, float)
                       else f'{knob} {value}')
        ax.step([r['ms_per_sim_s'] for r in front], [r['error_rad'] for r in front], 'k-',
                where='post', lw=1, label='Pareto front')
        for integrator, marker in MUJOCO_MARKERS.items():
            chosen = [row for row in theirs if row['integrator'] == integrator]
            if chosen:
                ax.scatter([r['ms_per_sim_s'] for r in chosen], [r['error_rad'] for r in chosen],
                           marker=marker, color='k', s=40, label=integrator.replace('_', ' '))
        ax.set_xscale('log')
        ax.set_yscale('log')
        ax.set_xlabel('cost [ms of wall time per simulated s]')
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel('largest angle error [rad]')
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def order_plot(path: Path, rows: list[dict], orders: dict, floor: float, title: str) -> None:
    """log error against log dt per integrator, with the fitted order as a dashed guide and
    ``floor`` [rad], below which errors are not fitted, as a dashed line."""
    series, guides = {}, {}
    for integrator, order in orders.items():
        mine = sorted((row['dt'], row['error_rad']) for row in rows
                      if row['integrator'] == integrator)
        dts, errors = zip(*mine)
        series[integrator] = (dts, errors)
        scale = errors[-1] / dts[-1] ** order
        guides[f'{integrator}: fitted order {order:.2f}'] = (
            dts, [scale * dt ** order for dt in dts])
    dts = sorted({row['dt'] for row in rows})
    guides['not fitted below (10 × reference error)'] = ([dts[0], dts[-1]], [floor, floor])
    loglog_plot(path, series, 'dt [s]', 'largest angle error [rad]', title, guides)
