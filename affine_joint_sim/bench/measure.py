"""One run of the sweep: a case at one setting, measured against the case's reference.

A row holds the knobs (scene, device, integrator, dt [s], newton_tol [m/s], precision) and
what they bought: ``error_rad`` (largest |θ − θ_ref| over joints and sample times, angles
compared modulo 2π), ``us_per_step`` (median of timed runs from the initial state, nothing
read in between), ``ms_per_sim_s`` (the same per simulated second), ``newton_iterations``
(mean per step), ``joint_gap_m`` (largest over the run), ``energy_drift_j`` (E(T) − E(0) minus
the work Σ τ Δθ of the torques: zero for an exact integrator, negative when it dissipates) and
``energy_drift_rel`` (that over the reference's largest kinetic energy), ``converged_pct``
and ``rejected_steps`` (the stepper's SimulationWarnings are silenced: these columns hold
them), ``envs`` (cases run together as one batched stepper's environments; µs/step is per
environment). MuJoCo rows carry the knobs they have and leave the rest empty.
"""

import warnings

import numpy as np

from affine_joint_sim.bench.cases import Case, Reference, with_settings
from affine_joint_sim.bench.timing import median_us

__all__ = ['MIN_TIMED_STEPS', 'angle_error', 'run_mujoco', 'run_stepper', 'run_stepper_batch']

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
    return run_stepper_batch([case], [reference], dt=dt, integrator=integrator,
                             newton_tol=newton_tol, precision=precision, device=device,
                             repeats=repeats)[0]


def run_stepper_batch(cases: list[Case], references: list[Reference], *, dt: float,
                      integrator: str, newton_tol: float, precision: str, device: str,
                      repeats: int) -> list[dict]:
    """Cases that differ only in their torques, as the environments of one batched stepper
    at one setting: a row per case. ``us_per_step`` is the batch's step time divided by the
    number of environments (column ``envs``)."""
    from affine_joint_sim.stepper import SimulationWarning, Stepper

    if len({(c.scene.model_dump_json(), c.duration) for c in cases}) != 1:
        raise ValueError('a batch shares its scene and duration; only torques may differ')
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', SimulationWarning)
        # one thread: a sweep's µs are per environment on one core (and its workers own the
        # other cores)
        sim = Stepper(with_settings(cases[0].scene, dt, integrator, newton_tol, precision),
                      device=device, num_envs=len(cases), threads=1)
        return _run_stepper(sim, cases, references, repeats)


def _run_stepper(sim, cases: list[Case], references: list[Reference], repeats: int) -> list:
    dt, solver, envs = sim.dt, sim.scene.solver, len(cases)
    steps = round(cases[0].duration / dt)
    torque = np.array([case.torque_vector() for case in cases])        # (envs, joints)
    commanded = [k for k in range(torque.shape[1]) if torque[:, k].any()]

    def start():
        sim.reset()
        for k in commanded:
            sim.set_torque(sim.joint_names[k], torque[:, k])

    us_per_step = median_us(sim.step, steps, _repeats(repeats, steps), setup=start) / envs
    start()
    sample_at = {round(t / dt) for t in cases[0].times}
    energy0, turned = sim.energy, np.zeros(torque.shape)
    angles, iterations, gap = [], np.zeros(envs), np.zeros(envs)
    converged, rejected = np.zeros(envs, dtype=int), np.zeros(envs, dtype=int)
    for n in range(1, steps + 1):
        sim.step()
        stats = sim.stats
        iterations += stats['newton_iterations']
        gap = np.maximum(gap, stats['joint_gap'])
        converged += stats['converged']
        rejected += stats['step_rejected']
        turned += sim.velocities * dt                  # Δθ of the multi-turn angle
        if n in sample_at:
            angles.append(sim.angles)
    drift = sim.energy - energy0 - np.sum(torque * turned, axis=1)
    return [{'scene': case.name, 'device': str(sim.device), 'integrator': solver.integrator,
             'dt': dt, 'newton_tol': solver.newton_tol, 'precision': solver.precision,
             'envs': envs, 'error_rad': angle_error([a[e] for a in angles], reference.angles),
             'us_per_step': us_per_step, 'ms_per_sim_s': us_per_step / dt / 1e3,
             'newton_iterations': float(iterations[e]) / steps, 'joint_gap_m': float(gap[e]),
             'energy_drift_j': float(drift[e]),
             'energy_drift_rel': (float(drift[e]) / reference.energy_scale
                                  if reference.energy_scale > 0.0 else float('nan')),
             'converged_pct': 100.0 * float(converged[e]) / steps,
             'rejected_steps': int(rejected[e])}
            for e, (case, reference) in enumerate(zip(cases, references))]


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
            'dt': dt, 'newton_tol': None, 'precision': 'float64', 'envs': 1,
            'error_rad': angle_error(angles, reference.angles), 'us_per_step': us_per_step,
            'ms_per_sim_s': us_per_step / dt / 1e3, 'newton_iterations': None,
            'joint_gap_m': None, 'energy_drift_j': None, 'energy_drift_rel': None,
            'converged_pct': None, 'rejected_steps': None}
