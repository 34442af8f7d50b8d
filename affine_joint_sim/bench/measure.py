"""One run of the sweep: a case at one setting, measured against the case's reference.

A row holds the knobs (scene, device, integrator, dt [s], newton_tol [m/s], precision) and
what they bought: ``error_rad`` (largest |θ − θ_ref| over joints and sample times, angles
compared modulo 2π), ``us_per_step`` (median of timed runs from the initial state, nothing
read in between), ``ms_per_sim_s`` (the same per simulated second), ``newton_iterations``
(mean per step), ``joint_gap_m`` (largest over the run), ``energy_drift_j`` (E(T) − E(0) minus
the work Σ τ Δθ of the torques: zero for an exact integrator, negative when it dissipates) and
``energy_drift_rel`` (that over the reference's largest kinetic energy), ``converged_pct``
and ``rejected_steps`` (the stepper's SimulationWarnings are silenced: these columns hold
them). MuJoCo rows carry the knobs they have and leave the rest empty.
"""

import warnings

import numpy as np

from affine_joint_sim.bench.cases import Case, Reference, with_settings
from affine_joint_sim.bench.timing import median_us

__all__ = ['MIN_TIMED_STEPS', 'angle_error', 'run_mujoco', 'run_stepper']

MIN_TIMED_STEPS = 2000   # short runs are timed more often, so that every median spans as many


def angle_error(angles: np.ndarray, reference: np.ndarray) -> float:
    """Largest |θ − θ_ref| [rad], each difference taken modulo 2π into [0, π]."""
    return float(np.abs(np.angle(np.exp(1j * (np.asarray(angles) - reference)))).max())


def _repeats(repeats: int, steps: int) -> int:
    """At least ``repeats`` timed runs, and at least MIN_TIMED_STEPS steps timed in all."""
    return max(repeats, -(-MIN_TIMED_STEPS // steps))


def run_stepper(case: Case, reference: Reference, *, dt: float, integrator: str,
                newton_tol: float, precision: str, device: str, repeats: int) -> dict:
    """Simulate ``case`` with the stepper at one setting; time it and measure it."""
    from affine_joint_sim.stepper import SimulationWarning, Stepper

    with warnings.catch_warnings():
        warnings.simplefilter('ignore', SimulationWarning)
        return _run_stepper(Stepper(with_settings(case.scene, dt, integrator, newton_tol,
                                                  precision), device=device),
                            case, reference, repeats)


def _run_stepper(sim, case: Case, reference: Reference, repeats: int) -> dict:
    dt, solver = sim.dt, sim.scene.solver
    steps = round(case.duration / dt)

    def start():
        sim.reset()
        for name, torque in case.torques.items():
            sim.set_torque(name, torque)

    us_per_step = median_us(sim.step, steps, _repeats(repeats, steps), setup=start)
    start()
    sample_at = {round(t / dt) for t in case.times}
    torque = case.torque_vector()
    energy0, turned = sim.energy, np.zeros(len(torque))
    angles, iterations, gap, converged, rejected = [], 0, 0.0, 0, 0
    for n in range(1, steps + 1):
        sim.step()
        stats = sim.stats
        iterations += int(stats['newton_iterations'])
        gap = max(gap, float(stats['joint_gap']))
        converged += bool(stats['converged'])
        rejected += bool(stats['step_rejected'])
        turned += sim.velocities * dt                  # Δθ of the multi-turn angle
        if n in sample_at:
            angles.append(sim.angles)
    drift = sim.energy - energy0 - float(torque @ turned)
    return {'scene': case.name, 'device': str(sim.device), 'integrator': solver.integrator,
            'dt': dt, 'newton_tol': solver.newton_tol, 'precision': solver.precision,
            'error_rad': angle_error(angles, reference.angles), 'us_per_step': us_per_step,
            'ms_per_sim_s': us_per_step / dt / 1e3, 'newton_iterations': iterations / steps,
            'joint_gap_m': gap, 'energy_drift_j': drift,
            'energy_drift_rel': drift / reference.energy_scale,
            'converged_pct': 100.0 * converged / steps, 'rejected_steps': rejected}


def run_mujoco(case: Case, reference: Reference, *, dt: float, integrator: str,
               repeats: int) -> dict | None:
    """The same case in MuJoCo (``integrator``: ``Euler`` or ``RK4``), contacts off; None
    where MuJoCo is not installed or the case has no MuJoCo twin."""
    try:
        import mujoco
    except ImportError:
        return None
    if case.mujoco is None:
        return None
    model = mujoco.MjModel.from_xml_string(case.mujoco._replace(dt=dt).mjcf())
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f'mjINT_{integrator.upper()}')
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(model)
    steps = round(case.duration / dt)

    def start():
        mujoco.mj_resetData(model, data)
        data.qfrc_applied[0] = case.mujoco.torque

    us_per_step = median_us(lambda: mujoco.mj_step(model, data), steps,
                            _repeats(repeats, steps), setup=start)
    start()
    sample_at = {round(t / dt) for t in case.times}
    angles = []
    for n in range(1, steps + 1):
        mujoco.mj_step(model, data)
        if n in sample_at:
            angles.append(data.qpos.copy())
    return {'scene': case.name, 'device': 'cpu', 'integrator': f'mujoco_{integrator.lower()}',
            'dt': dt, 'newton_tol': None, 'precision': 'float64',
            'error_rad': angle_error(angles, reference.angles), 'us_per_step': us_per_step,
            'ms_per_sim_s': us_per_step / dt / 1e3, 'newton_iterations': None,
            'joint_gap_m': None, 'energy_drift_j': None, 'energy_drift_rel': None,
            'converged_pct': None, 'rejected_steps': None}
