"""Joint family against independent truth: prismatic, fixed, limits, damping and drives.

Truth: closed forms of a slider (incline, constant force), the equilibrium of a cubic limit
penalty or a drive spring against a load (physical stiffness = incremental-potential term / dt²),
the exponential decay of a damped pendulum, an RK4 ODE of the rigid compound pendulum, energy
that passive steps may only dissipate, angular momentum that internal forces conserve, and
batched runs equal to single runs bit for bit.
"""

import math

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.physics.host.mass import body_mass_properties
from test_stepper import rk4_angle

G = 9.81
BASE = {'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0, 'fixed': True}
LINK_I = 1.0 * (0.1 ** 2 + 1.0 ** 2) / 12 + 0.25        # 1 kg, 1 m box about its end [kg·m²]


def brentq(f, a, b, tol=1e-14):
    """A root of f in [a, b] by bisection (f(a), f(b) of opposite signs)."""
    fa = f(a)
    while b - a > tol:
        m = 0.5 * (a + b)
        if (f(m) > 0) == (fa > 0):
            a, fa = m, f(m)
        else:
            b = m
    return 0.5 * (a + b)


def pendulum(dt=0.01, gravity=(0.0, 0.0, -G), **joint):
    """A 1 kg 0.1×0.1×1 m link hanging from a hinge about world x at the origin."""
    return Scene.from_dict({'dt': dt, 'gravity': list(gravity), 'bodies': [
        BASE, {'name': 'link', 'shape': {'box': [0.1, 0.1, 1.0]}, 'mass': 1.0,
               'position': [0.0, 0.0, -0.5]}],
        'joints': [dict({'name': 'hinge', 'parent': 'base', 'child': 'link',
                         'x0': [-0.05, 0, 0], 'x1': [0.05, 0, 0],
                         'torque_model': 'generalized'}, **joint)]})


def slider(axis=(1.0, 0.0, 0.0), dt=1e-3, gravity=(0.0, 0.0, -G), **joint):
    """A 2 kg cube on a prismatic joint along ``axis`` through its centre, from a fixed base."""
    x0 = np.array([0.5, 0.0, 0.0])
    return Scene.from_dict({'dt': dt, 'gravity': list(gravity), 'bodies': [
        BASE, {'name': 'cube', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 2.0,
               'position': list(x0)}],
        'joints': [dict({'name': 'slide', 'type': 'prismatic', 'parent': 'base', 'child': 'cube',
                         'x0': list(x0), 'x1': list(x0 + 0.1 * np.asarray(axis))}, **joint)]})


def run(sim, steps):
    for _ in range(steps):
        sim.step()
    return sim


def test_slider_on_an_incline_follows_half_g_sin_alpha_t_squared():
    alpha = 0.3
    sim = run(Stepper(slider(axis=(math.cos(alpha), 0.0, math.sin(alpha)))), 500)
    assert sim.joint_types == ['prismatic']
    # the ABD model floor: the joint's penalty sag and BDF2 at dt = 1e-3, measured 6e-6
    assert sim.angles[0] == pytest.approx(-0.5 * G * math.sin(alpha) * sim.time ** 2, rel=1e-4)
    assert sim.stats['joint_gap'] < 1e-6


@pytest.mark.parametrize('force', [3.0, -2.0])
def test_force_command_gives_f_t_squared_over_2m(force):
    sim = Stepper(slider(gravity=(0, 0, 0)))
    sim.set_torque('slide', force)
    run(sim, 400)
    assert sim.angles[0] == pytest.approx(force * sim.time ** 2 / 4.0, rel=1e-4)
    assert sim.efforts[0] == force
    # the reported velocity is Δx/dt of the last step: the mid-step value
    assert sim.velocities[0] == pytest.approx(force * (sim.time - 0.5e-3) / 2.0, rel=1e-4)


def angular_momentum(sim, scene) -> np.ndarray:
    """Σ m p × ṗ + Σ_j s_j (A e_j) × (Ȧ e_j) about the world origin [kg·m²/s] (an affine body's
    ∫ρ x × ẋ dV, COM-centred rest frame with S = diag(s))."""
    total = np.zeros(3)
    for b, body in enumerate(scene.bodies):
        q, v = sim.body_q[b], sim.body_qdot[b]
        a, a_dot = q[3:].reshape(3, 3), v[3:].reshape(3, 3)
        s = body_mass_properties(body).second_moment
        total += body.mass * np.cross(q[:3], v[:3]) + sum(
            s[j] * np.cross(a[:, j], a_dot[:, j]) for j in range(3))
    return total


def test_a_force_between_free_bodies_off_their_centre_line_adds_no_angular_momentum():
    """The force pair of a prismatic joint acts at one point: internal, it turns nothing.
    A finger's slide 0.2 m off its hand's centre of mass gained f·h·t of angular momentum when
    the pair acted at the two centres of mass (Panda's fingers pushed its wrist)."""
    force, height, steps = 1.0, 0.2, 200
    scene = Scene.from_dict({'dt': 1e-3, 'gravity': [0, 0, 0], 'bodies': [
        {'name': 'hand', 'shape': {'box': [0.2, 0.2, 0.2]}, 'mass': 4.0},
        {'name': 'finger', 'shape': {'box': [0.02, 0.02, 0.1]}, 'mass': 0.05,
         'position': [0.0, 0.0, height]}],
        'joints': [{'name': 'slide', 'type': 'prismatic', 'parent': 'hand', 'child': 'finger',
                    'x0': [0, 0, 0.1], 'x1': [0.1, 0, 0.1]}]})
    sim = run(Stepper(scene), 0)
    sim.set_torque('slide', force)
    run(sim, steps)
    assert sim.angles[0] > 0.3                       # the finger slid
    spurious = force * height * sim.time             # 0.04 with the pair at the two COMs
    # measured 2.9e-5: BDF2's own drift of angular momentum
    assert np.abs(angular_momentum(sim, scene)).max() < 1e-2 * spurious


def _limit_equilibrium(load, limit, dt):
    """x above ``upper`` where the limit's force 3s((x−u)/w)²/(w dt²) balances ``load(x)``."""
    lower, upper, s = limit['lower'], limit['upper'], limit['strength']
    w = upper - lower

    def balance(x):
        return 3 * s * ((x - upper) / w) ** 2 / (w * dt ** 2) - load(x)
    return brentq(balance, upper, upper + w)


def test_prismatic_limit_stops_the_slider_where_the_penalty_balances_the_force():
    limit = {'lower': -0.1, 'upper': 0.2, 'strength': 10.0}
    sim = Stepper(slider(gravity=(0, 0, 0), dt=0.01, limit=limit, damping=20.0, torque=5.0))
    run(sim, 1500)
    expected = _limit_equilibrium(lambda x: 5.0, limit, 0.01)
    assert expected > 0.2 and sim.angles[0] == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize('upper', [0.5, 7.0])   # 7 rad: a multi-turn limit beyond 2π
def test_revolute_limit_balances_torque_and_gravity(upper):
    limit = {'lower': -1.0, 'upper': upper, 'strength': 1.0}
    tau, gravity = (8.0, -G) if upper < 1 else (2.0, 0.0)
    sim = Stepper(pendulum(gravity=(0, 0, gravity), limit=limit, damping=2.0, torque=tau,
                           angle_mode='continuous'))
    run(sim, 3000)
    expected = _limit_equilibrium(lambda x: tau + gravity * 0.5 * math.sin(x), limit, 0.01)
    assert sim.angles[0] == pytest.approx(expected, abs=1e-5)


def test_a_limit_held_against_a_load_converges_without_halving_to_the_same_state():
    # Entered from outside, the cubic penalty makes Newton halve its overshoot each iteration
    # (the tangent φ'' is too stiff above the solution depth); joint_terms.limit_secant takes
    # the secant towards the depth the halving heads for. Measured: 359 iterations over these
    # 60 steps, 486 with the tangent alone; the state is the same to the Newton tolerance.
    limit = {'lower': -0.3, 'upper': 0.3, 'strength': 1e5}

    def pressed(**solver):
        data = pendulum(limit=limit, torque=5.0).model_dump(exclude_none=True)
        data['solver'].update(solver)
        sim = Stepper(Scene.from_dict(data))
        iterations, peak = 0, 0.0
        for _ in range(60):
            sim.step()
            iterations += int(sim.stats['newton_iterations'])
            peak = max(peak, sim.angles[0])
        return sim, iterations, peak

    sim, iterations, peak = pressed()
    tight, _, _ = pressed(newton_tol=1e-8)
    assert peak > 0.3, 'the run must press into the limit'
    assert sim.angles[0] == pytest.approx(tight.angles[0], abs=1e-4)   # 2e-5 either way
    assert iterations <= 400


def pendulum_bdf1(**joint):
    """The pendulum under BDF1, whose steps provably dissipate (BDF2's two-step velocity lets
    the measured energy rise for a few steps after a command changes)."""
    data = pendulum(**joint).model_dump(exclude_none=True)
    data['solver']['integrator'] = 'bdf1'
    return Scene.from_dict(data)


def test_passive_bounces_on_limits_never_gain_energy():
    sim = Stepper(pendulum_bdf1(limit={'lower': -0.3, 'upper': 0.3, 'strength': 0.5}))
    q = sim.body_q.copy()
    sim.set_torque('hinge', 10.0)          # kick it into the limits, then let it bounce
    run(sim, 20)
    sim.set_torque('hinge', 0.0)
    sim.step()
    energies, peak = [sim.energy], 0.0
    for _ in range(600):
        sim.step()
        energies.append(sim.energy)
        peak = max(peak, abs(sim.angles[0]))
    assert peak > 0.3, 'the run must press into a limit'
    assert np.all(np.diff(energies) <= 1e-9 * abs(energies[0])) and not np.allclose(q, sim.body_q)


def test_damped_small_oscillations_decay_at_c_over_2i():
    c = 0.05
    sim = Stepper(pendulum(dt=1e-3, damping=c))
    sim.set_torque('hinge', 0.5)
    run(sim, 50)
    sim.set_torque('hinge', 0.0)
    angles = np.array([run(sim, 1).angles[0] for _ in range(6000)])
    peaks = [i for i in range(1, len(angles) - 1)
             if angles[i] > angles[i - 1] and angles[i] >= angles[i + 1] and angles[i] > 0]
    rate = math.log(angles[peaks[0]] / angles[peaks[-1]]) / ((peaks[-1] - peaks[0]) * 1e-3)
    assert rate == pytest.approx(c / (2 * LINK_I), rel=0.03)


def test_damping_never_injects_energy():
    sim = Stepper(pendulum_bdf1(damping=0.5))
    sim.set_torque('hinge', 5.0)
    run(sim, 30)
    sim.set_torque('hinge', 0.0)
    energies = [run(sim, 1).energy for _ in range(300)]
    assert np.all(np.diff(energies) <= 1e-9 * abs(energies[0]))
    assert energies[-1] < energies[0] - 0.1


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_a_velocity_target_spins_the_joint_up_at_c_over_i_to_that_speed(integrator):
    """The damping pulls the speed toward the commanded v: I ω' = c (v − ω) without gravity,
    which the integrators step as ω_{n+1} = (ω_n + a v) / (1 + a) (BDF1, a = c dt / I) and
    ω_{n+1} = (4 ω_n − ω_{n−1} + 2 a v) / (3 + 2 a) (BDF2, after a first BDF1 step, its
    history starting there: ω_{n−1} = ω_n in the first BDF2 step). A body
    spinning under BDF1 also loses speed to BDF1's own damping, which ends it below v (0.4 %
    at ω dt = 0.015 here). Back to v = 0 it brakes; a joint without damping refuses a speed."""
    c, v, dt = 2.0, 1.5, 0.01
    scene = pendulum(gravity=(0, 0, 0), damping=c)
    scene = scene.model_copy(update={'solver': scene.solver.model_copy(
        update={'integrator': integrator})})
    sim = Stepper(scene)
    sim.set_velocity_target('hinge', v)
    speeds = np.array([run(sim, 1).velocities[0] for _ in range(300)])
    a = c * dt / LINK_I
    expected = [v * a / (1.0 + a)] * 2
    for _ in range(299):
        expected.append((expected[-1] + a * v) / (1.0 + a) if integrator == 'bdf1' else
                        (4.0 * expected[-1] - expected[-2] + 2.0 * a * v) / (3.0 + 2.0 * a))
    expected = np.array(expected[1:])     # from the first step's ω
    if integrator == 'bdf1':
        assert np.abs(speeds[:20] - expected[:20]).max() < 1e-3 * v
        assert speeds[-1] == pytest.approx(v, rel=5e-3)
    else:
        assert np.abs(speeds - expected).max() < 1e-4 * v
        assert speeds[-1] == pytest.approx(v, rel=1e-5)
    assert sim.velocity_targets[0] == v
    sim.set_velocity_target('hinge', 0.0)
    assert abs(run(sim, 300).velocities[0]) < 1e-3 * v
    sim.reset()
    assert sim.velocity_targets[0] == 0.0
    with pytest.raises(ValueError, match="joint 'hinge' has no damping"):
        Stepper(pendulum(gravity=(0, 0, 0))).set_velocity_target('hinge', v)


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_joint_friction_holds_below_its_torque_and_slides_at_the_excess_above(integrator):
    """Coulomb friction f on the hinge (no gravity): under τ < f the joint creeps at the speed
    where the smoothed friction's viscous part balances τ, v = ε_v (1 − √(1 − τ/f)) (f0' of
    IPC's f0 at the step's slip, ε_v = SLIP_SPEED); under τ > f it accelerates at (τ − f)/I;
    left alone it decelerates at f/I and stops. (BDF1's own damping of a spinning body takes
    0.3 % off the acceleration at ω dt ≈ 0.015.)"""
    from affine_joint_sim.physics.stages.joint_terms import SLIP_SPEED

    f = 1.0
    scene = pendulum(gravity=(0, 0, 0), friction=f)
    scene = scene.model_copy(update={'solver': scene.solver.model_copy(
        update={'integrator': integrator})})
    sim = Stepper(scene)
    sim.set_torque('hinge', 0.5 * f)
    run(sim, 200)
    creep = SLIP_SPEED * (1.0 - math.sqrt(0.5))
    assert sim.velocities[0] == pytest.approx(creep, rel=1e-3)
    sim.set_torque('hinge', 2.0 * f)
    start = sim.velocities[0]
    speeds = np.array([run(sim, 1).velocities[0] for _ in range(50)])
    slope = np.polyfit(np.arange(10, 50) * 0.01, speeds[10:], 1)[0]
    tolerance = 5e-3 if integrator == 'bdf1' else 1e-3
    assert slope == pytest.approx((2.0 * f - f) / LINK_I, rel=tolerance) and speeds[0] > start
    sim.set_torque('hinge', 0.0)
    top = sim.velocities[0]
    speeds = np.array([run(sim, 1).velocities[0] for _ in range(60)])
    slope = np.polyfit(np.arange(5, 20) * 0.01, speeds[5:20], 1)[0]
    assert slope == pytest.approx(-f / LINK_I, rel=tolerance) and top > 0.5
    assert abs(speeds[-1]) < SLIP_SPEED and np.all(speeds > -SLIP_SPEED)
    assert 'friction' in sim.stats['active_terms']


def test_drive_settles_where_its_spring_balances_gravity_and_retargets_next_step():
    strength_ratio, dt = 0.005, 0.01
    sim = Stepper(pendulum(drive={'target': 0.5, 'strength_ratio': strength_ratio},
                           damping=1.0))
    run(sim, 1500)
    stiffness = strength_ratio * (1000.0 * 0.2 ** 3 + 1.0) / dt ** 2      # K/dt² [N·m/rad]
    expected = brentq(lambda x: stiffness * (0.5 - x) - G * 0.5 * math.sin(x), 0.0, 0.5)
    assert 0.5 - expected > 1e-3 and sim.angles[0] == pytest.approx(expected, abs=1e-6)
    before = sim.angles[0]
    sim.set_target('hinge', -0.5)
    sim.step()
    assert sim.angles[0] < before - 1e-3
    sim.set_drive_enabled('hinge', False)      # off: gravity swings it back down
    sim.set_target('hinge', 2.0)
    assert run(sim, 100).angles[0] < 0.5


def welded_pendulum(**changes):
    return Scene.from_dict(dict({'dt': 1e-3, 'bodies': [
        BASE,
        {'name': 'upper', 'shape': {'box': [0.1, 0.1, 0.5]}, 'mass': 1.0,
         'position': [0, 0, -0.25]},
        {'name': 'lower', 'shape': {'box': [0.1, 0.1, 0.5]}, 'mass': 2.0,
         'position': [0, 0, -0.75]}],
        'joints': [{'name': 'hinge', 'parent': 'base', 'child': 'upper', 'x0': [-0.05, 0, 0],
                    'x1': [0.05, 0, 0], 'torque_model': 'generalized', 'torque': 3.0},
                   {'name': 'weld', 'type': 'fixed', 'parent': 'upper', 'child': 'lower'}]},
        **changes))


def test_welded_compound_pendulum_matches_the_rigid_pendulum():
    sim = run(Stepper(welded_pendulum()), 1000)
    inertia = sum(m * (0.1 ** 2 + 0.5 ** 2) / 12 + m * d ** 2 for m, d in ((1, 0.25), (2, 0.75)))
    moment = G * (1 * 0.25 + 2 * 0.75)
    expected = rk4_angle(lambda th, w: (3.0 - moment * math.sin(th)) / inertia, sim.time)
    assert sim.angles[0] == pytest.approx(expected, rel=5e-3)
    assert sim.angles[1] == 0.0 and sim.velocities[1] == 0.0 and sim.efforts[1] == 0.0
    # the weld holds: centres and frames of the two bodies move together (bound: 1e-5 m, rad)
    t = sim.body_transforms
    relative = np.linalg.inv(t[1]) @ t[2]
    assert np.allclose(relative[:3, 3], [0, 0, -0.5], atol=1e-5)
    assert np.allclose(relative[:3, :3], np.eye(3), atol=1e-5)


def every_joint_type():
    data = welded_pendulum(dt=0.01).model_dump(exclude_none=True)
    data['bodies'].append({'name': 'cube', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 0.5,
                           'position': [0.3, 0, -0.9]})
    data['joints'][0].update(limit={'lower': -0.4, 'upper': 0.4}, damping=0.1,
                             drive={'target': 0.2, 'strength_ratio': 1.0})
    data['joints'].append({'name': 'slide', 'type': 'prismatic', 'parent': 'lower',
                           'child': 'cube', 'x0': [0.3, 0, -0.9], 'x1': [0.4, 0, -0.9],
                           'limit': {'lower': -0.1, 'upper': 0.05}, 'damping': 1.0,
                           'drive': {'target': 0.02}})
    return Scene.from_dict(data)


def test_batched_equals_single_runs_bit_for_bit_with_every_joint_type():
    scene = every_joint_type()
    torques = np.array([1.0, -2.0, 0.5])
    batch = Stepper(scene, num_envs=3)
    batch.set_torque('slide', torques)
    batch.set_target('hinge', torques / 10)
    singles = [Stepper(scene) for _ in torques]
    for sim, tau in zip(singles, torques):
        sim.set_torque('slide', tau)
        sim.set_target('hinge', tau / 10)
    run(batch, 100)
    for k, sim in enumerate(singles):
        run(sim, 100)
        assert np.array_equal(batch.body_q[k], sim.body_q)
        assert np.array_equal(batch.angles[k], sim.angles)
    assert set(batch.stats['active_terms']) >= {'limits', 'drives', 'damping'}
    assert batch.stats['converged'].all()


def test_commands_to_the_wrong_joint_are_refused():
    sim = Stepper(every_joint_type())
    with pytest.raises(ValueError, match='fixed'):
        sim.set_torque('weld', 1.0)
    with pytest.raises(ValueError, match='finite'):
        sim.set_target('hinge', float('nan'))
    with pytest.raises(ValueError, match='has no drive; joints with a drive: hinge, slide'):
        sim.set_target('weld', 0.0)


@pytest.mark.parametrize('dt', [1e-3, 1e-2])
def test_a_limit_skipped_where_it_cannot_be_reached_changes_no_bit(dt):
    """A limited joint with no other coordinate term skips its limit wherever a bound on its
    bodies' turn since the step's start keeps it inside (physics.stages.joint_terms
    ``limit_idle``): a link whipped into its limit and back moves bit for bit as with a
    disabled drive beside the limit (exact zeros too, but never skipped)."""
    def run(drive):
        joint = {'name': 'hinge', 'parent': 'base', 'child': 'link', 'x0': [0.0, -0.05, 0.0],
                 'x1': [0.0, 0.05, 0.0], 'limit': {'lower': -0.3, 'upper': 0.3}}
        if drive:
            joint['drive'] = {'enabled': False}
        sim = Stepper(Scene.from_dict({'dt': dt, 'gravity': [0.0, 0.0, -9.81], 'bodies': [
            {'name': 'base', 'fixed': True, 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0},
            {'name': 'link', 'shape': {'box': [0.04, 0.04, 0.4]}, 'mass': 0.5,
             'position': [0.0, 0.0, -0.2]}], 'joints': [joint]}))
        angles = []
        for n in range(round(0.6 / dt)):
            sim.set_torque('hinge', 3.0 if n * dt < 0.3 else -3.0)
            sim.step()
            angles.append(sim.angles[0])
        return np.array(angles)
    skipped = run(drive=False)
    np.testing.assert_array_equal(skipped, run(drive=True))
    assert skipped.max() > 0.3 - 1e-3 and skipped.min() < -0.3 + 1e-3    # both limits met
