"""Rotational damping of affine bodies at large rotation per step, on the packaged wheel.

An affine step moves A along a straight line (q̃ = q + dt q̇ leaves the rotations) and the
orthogonality energy pulls it back, so a fast-spinning body loses speed: the loss grows with
the rotation per step ω·dt. Two measurements, against closed forms:
- the wheel under its constant torque τ for ``SPIN_UP`` seconds: θ(T) and ω(T) against the
  rigid θ = τT²/(2I), ω = τT/I, per dt and integrator;
- the wheel spinning freely from ω: the fraction of its speed lost per step, per ω·dt.
Speeds are the stepper's ``velocities`` (Δθ/dt, the mean over the last step): they trail the
rigid ω(T) by dt/(2T) as well, 0.3% at dt = 0.02 s.
"""

import math
from pathlib import Path

import numpy as np

from affine_joint_sim.bench.cases import with_settings
from affine_joint_sim.bench.references import rigid_inertia
from affine_joint_sim.bench.report import Column, loglog_plot, markdown_table, write_csv
from affine_joint_sim.resources import scene_path

__all__ = ['free_spin_loss', 'spin_up', 'run']

SPIN_UP = 3.0                                        # s
DTS = (0.02, 0.01, 0.005, 0.002, 0.001, 0.0005)      # s
ROTATIONS_PER_STEP = (0.01, 0.03, 0.1, 0.3, 1.0)     # rad (ω·dt of the free spin)
TOL = 1e-6                                           # m/s: tight, so the method is measured


def _wheel(dt: float, integrator: str, torque: float, spin: float = 0.0):
    """The packaged wheel at ``dt`` with ``torque`` [N·m], spinning at ``spin`` [rad/s]."""
    from affine_joint_sim.scene import Scene

    data = Scene.from_yaml(scene_path('wheel')).model_dump(exclude_none=True)
    axis = np.subtract(data['joints'][0]['x1'], data['joints'][0]['x0'])
    data['joints'][0]['torque'] = torque
    data['bodies'][1]['angular_velocity'] = list(spin * axis / np.linalg.norm(axis))
    return with_settings(Scene.from_dict(data), dt, integrator, TOL, 'float64')


def spin_up(dt: float, integrator: str, duration: float = SPIN_UP) -> dict:
    """θ(T)/θ_rigid and ω(T)/ω_rigid of the wheel under its constant torque."""
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(_wheel(dt, integrator, torque=1.0))
    wheel = sim.scene.bodies[1]
    inertia = rigid_inertia(wheel.shape, wheel.mass)[2, 2]     # about the cylinder axis
    for _ in range(round(duration / dt)):
        sim.step()
    theta, omega = 1.0 * duration ** 2 / (2 * inertia), 1.0 * duration / inertia
    return {'integrator': integrator, 'dt': dt, 'omega_dt_end': omega * dt,
            'theta_ratio': float(sim.angles[0]) / theta,
            'omega_ratio': float(sim.velocities[0]) / omega,
            'lag': 1.0 - float(sim.angles[0]) / theta}


def free_spin_loss(rotation_per_step: float, integrator: str, dt: float = 0.01) -> dict:
    """Fraction of its speed the wheel, set spinning at ω = ``rotation_per_step``/dt, loses
    per step over steps 5 … 9 (after BDF2's start), and its rotation per step there [rad]."""
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(_wheel(dt, integrator, torque=0.0, spin=rotation_per_step / dt))
    turns = []
    for _ in range(10):
        sim.step()
        turns.append(float(sim.velocities[0]) * dt)
    return {'integrator': integrator, 'omega_dt': rotation_per_step,
            'first_step_rad': turns[0], 'window_rad': float(np.mean(turns[5:])),
            'loss_per_step': 1.0 - (turns[9] / turns[5]) ** (1.0 / 4)}


SPIN_COLUMNS = [Column('integrator', 'integrator'), Column('dt', 'dt [s]', '{:g}'),
                Column('omega_dt_end', 'rigid ω·dt at T [rad]', '{:.3f}'),
                Column('theta_ratio', 'θ(T)/θ_rigid', '{:.4f}'),
                Column('omega_ratio', 'ω(T)/ω_rigid', '{:.4f}')]
LOSS_COLUMNS = [Column('integrator', 'integrator'),
                Column('omega_dt', 'initial ω·dt [rad]', '{:g}'),
                Column('first_step_rad', 'first step turns [rad]', '{:.4f}'),
                Column('window_rad', 'turns per step, steps 6–10 [rad]', '{:.4f}'),
                Column('loss_per_step', 'speed lost per step', '{:.2e}')]


def run(results: Path, dts=DTS, rotations=ROTATIONS_PER_STEP) -> str:
    """Both measurements for BDF1 and BDF2; writes damping.md/.csv/.png, returns the text."""
    spin = [spin_up(dt, integrator) for integrator in ('bdf1', 'bdf2') for dt in dts]
    loss = [free_spin_loss(w, integrator) for integrator in ('bdf1', 'bdf2') for w in rotations]
    text = (f'## Rotational damping: the wheel (I = 0.09 kg·m²) under 1 N·m for {SPIN_UP:g} s, '
            'against the rigid closed form\n\n' + markdown_table(spin, SPIN_COLUMNS) +
            '\n\n## Free spin: speed lost per step against the rotation per step '
            '(dt = 0.01 s)\n\n' + markdown_table(loss, LOSS_COLUMNS) + '\n')
    (results / 'damping.md').write_text(text)
    write_csv(results / 'damping_spin_up.csv', spin)
    write_csv(results / 'damping_free_spin.csv', loss)
    series = {integrator: ([r['dt'] for r in spin if r['integrator'] == integrator],
                           [max(r['lag'], math.ulp(1.0)) for r in spin
                            if r['integrator'] == integrator])
              for integrator in ('bdf1', 'bdf2')}
    loglog_plot(results / 'damping.png', series, 'dt [s]', '1 − θ(T)/θ_rigid',
                f'Wheel under constant torque: lag behind the rigid angle at T = {SPIN_UP:g} s')
    return text
