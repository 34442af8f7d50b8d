"""Stepper behaviour against closed forms, an ODE reference and conservation laws."""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.control_script import ControlScript, command_stepper, packaged_scripts
from affine_joint_sim.sim_warnings import SimulationWarning
from helpers.physics import arm_with_fingers

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
PACKAGED = sorted(p.stem for p in SCENES.glob('*.yaml'))


def pinned_link(torque_model='lever_arm', gravity=(0.0, 0.0, 0.0), dt=1e-3, axis=(1, 0, 0),
                angle_mode='wrapped', **solver):
    """A 1 kg box link 0.1×0.1×1 m hanging from a fixed base; hinge at the origin."""
    half = 0.05 * np.asarray(axis, dtype=float)
    return Scene.from_dict({
        'dt': dt, 'gravity': list(gravity), 'solver': solver,
        'bodies': [{'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0,
                    'fixed': True},
                   {'name': 'link', 'shape': {'box': [0.1, 0.1, 1.0]}, 'mass': 1.0,
                    'position': [0.0, 0.0, -0.5]}],
        'joints': [{'name': 'hinge', 'parent': 'base', 'child': 'link', 'x0': list(-half),
                    'x1': list(half), 'torque_model': torque_model,
                    'angle_mode': angle_mode}]})


I_PIN = 1.0 * (0.1 ** 2 + 1.0 ** 2) / 12 + 1.0 * 0.5 ** 2   # box about the hinge [kg·m²]


def run(sim, steps):
    angles = []
    for _ in range(steps):
        sim.step()
        angles.append(sim.angles.copy())
    return np.array(angles)


@pytest.mark.parametrize('torque_model', ['lever_arm', 'generalized'])
def test_pinned_link_constant_torque_matches_closed_form(torque_model):
    sim = Stepper(pinned_link(torque_model))
    tau = 0.5
    sim.set_torque('hinge', tau)
    run(sim, 500)
    expected = tau * sim.time ** 2 / (2 * I_PIN)
    assert sim.angles[0] == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize('torque_model', ['lever_arm', 'generalized'])
@pytest.mark.parametrize('axis', [(1, 0, 0), (-1, 0, 0), (0, 1, 0)])
def test_positive_torque_increases_angle(torque_model, axis):
    sim = Stepper(pinned_link(torque_model, axis=axis, dt=0.01))
    sim.set_torque('hinge', 1.0)
    angles = run(sim, 10)[:, 0]
    assert np.all(np.diff(angles) > 0) and angles[0] > 0


def rk4_angle(acceleration, t_end, dt=1e-4):
    """θ(t_end) of θ̈ = acceleration(θ, θ̇) from rest at θ = 0, by RK4 with step dt [s]."""
    def f(y):
        return np.array([y[1], acceleration(y[0], y[1])])

    y = np.zeros(2)
    for _ in range(round(t_end / dt)):
        k1 = f(y)
        k2 = f(y + dt / 2 * k1)
        k3 = f(y + dt / 2 * k2)
        k4 = f(y + dt * k3)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y[0]


def _pendulum_reference(tau, t_end):
    """I θ̈ = τ − m g d sin θ (d = 0.5 m, m = 1 kg) from rest."""
    return rk4_angle(lambda th, w: (tau - 9.81 * 0.5 * math.sin(th)) / I_PIN, t_end)


def test_bdf1_pendulum_with_torque_converges_first_order():
    tau, t_end = 2.0, 1.0
    reference = _pendulum_reference(tau, t_end)
    errors = []
    for dt in (0.01, 0.005, 0.0025):
        sim = Stepper(pinned_link('lever_arm', gravity=(0, 0, -9.81), dt=dt, integrator='bdf1'))
        sim.set_torque('hinge', tau)
        run(sim, round(t_end / dt))
        errors.append(abs(sim.angles[0] - reference))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[0] < 0.1
    assert np.all((orders > 0.8) & (orders < 1.3)), (errors, orders)


def test_bdf2_pendulum_with_torque_converges_second_order():
    # BDF2 with the torque in q̃ (docs/physics.md#prediction), started by one BDF1 step; tight
    # Newton tolerance so that the solver does not mask the integrator's error
    tau, t_end = 2.0, 1.0
    reference = _pendulum_reference(tau, t_end)
    errors = []
    for dt in (0.02, 0.01, 0.005):
        sim = Stepper(pinned_link('generalized', gravity=(0, 0, -9.81), dt=dt,
                                  integrator='bdf2', newton_tol=1e-7))
        sim.set_torque('hinge', tau)
        run(sim, round(t_end / dt))
        errors.append(abs(sim.angles[0] - reference))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[1] < 1e-3
    assert np.all(orders > 1.8), (errors, orders)


def free_pair(torque_model, dt=0.01):
    """Two free 1 kg cubes 0.6 m apart, hinged about world z through the origin, no gravity."""
    cube = {'shape': {'box': [0.2, 0.2, 0.2]}, 'mass': 1.0}
    return Scene.from_dict({
        'gravity': [0, 0, 0], 'dt': dt,
        'bodies': [dict(cube, name='left', position=[-0.3, 0, 0]),
                   dict(cube, name='right', position=[0.3, 0, 0])],
        'joints': [{'name': 'hinge', 'parent': 'left', 'child': 'right', 'x0': [0, 0, -0.1],
                    'x1': [0, 0, 0.1], 'torque_model': torque_model, 'torque': 1.0}]})


def _run_tracking_momentum(sim, steps):
    """Total linear momentum Σ m ṗ after each step [N·s] (p is each body's COM)."""
    momentum = []
    for _ in range(steps):
        sim.step()
        momentum.append(sum(m * v[:3] for m, v in zip(sim._host.body_mass, sim.body_qdot)))
    return np.array(momentum)


def test_free_pair_generalized_torque_injects_no_momentum():
    sim = Stepper(free_pair('generalized', dt=0.0025))
    momentum = _run_tracking_momentum(sim, 80)
    lever_scale = 2 * 1.0 * sim.time / 0.3        # what lever_arm would inject [N·s]
    assert np.abs(momentum).max() <= 1e-9 * lever_scale
    assert sim.angles[0] == pytest.approx(_free_pair_reference(1.0, sim.time), rel=0.015)


def _free_pair_reference(tau, t_end):
    """Relative angle θ = 2φ of the symmetric free pair, from its 1-DOF Lagrangian.

    Each cube turns by ±φ about the hinge, which slides so that the COMs stay on the x axis:
    (I_cm + m d² sin²φ) φ̈ + m d² sinφ cosφ φ̇² = τ, with m = 1 kg, d = 0.3 m.
    """
    i_cm, md2 = 1.0 * (0.04 + 0.04) / 12, 1.0 * 0.09

    def acceleration(phi, omega):
        s, c = math.sin(phi), math.cos(phi)
        return (tau - md2 * s * c * omega ** 2) / (i_cm + md2 * s * s)

    return 2 * rk4_angle(acceleration, t_end)


def test_free_pair_lever_arm_injects_the_seed_formulas_momentum():
    # lever_arm pushes both COMs along +y with τ/|r| each (|r| = 0.3 m): the pair translates,
    # does not turn, and gains p_y = 2 τ t / |r| exactly (internal forces conserve momentum).
    sim = Stepper(free_pair('lever_arm'))
    momentum = _run_tracking_momentum(sim, 20)
    assert momentum[-1][1] == pytest.approx(2 * 1.0 * sim.time / 0.3, rel=1e-9)
    assert abs(momentum[-1][0]) < 1e-12 and abs(momentum[-1][2]) < 1e-12
    assert abs(sim.angles[0]) < 1e-9


def wheel(torque_model, angle_mode='continuous', dt=1e-3, torque=1.0):
    data = Scene.from_yaml(SCENES / 'wheel.yaml').model_dump(exclude_none=True)
    data['dt'] = dt
    data['joints'][0].update(torque_model=torque_model, angle_mode=angle_mode, torque=torque)
    return Scene.from_dict(data)


def test_wheel_generalized_spins_lever_arm_warns_and_does_nothing():
    sim = Stepper(wheel('generalized'))
    run(sim, 300)
    i_axis = 2.0 * 0.3 ** 2 / 2
    assert sim.angles[0] == pytest.approx(1.0 * sim.time ** 2 / (2 * i_axis), rel=0.01)
    with pytest.warns(SimulationWarning, match='lies on the joint axis'):
        lever = Stepper(wheel('lever_arm'))
    run(lever, 300)
    assert abs(lever.angles[0]) < 1e-9


def test_wrapped_angle_crosses_pi_and_continuous_passes_two_pi():
    continuous = Stepper(wheel('generalized', 'continuous', torque=20.0))
    wrapped = Stepper(wheel('generalized', 'wrapped', torque=20.0))
    cont = run(continuous, 300)[:, 0]
    wrap = run(wrapped, 300)[:, 0]
    assert cont[-1] > 2 * math.pi and np.all(np.diff(cont) > 0)
    assert np.all((wrap > -math.pi) & (wrap <= math.pi))
    assert np.any(np.diff(wrap) < -math.pi), 'the wrapped angle must jump from +π to −π'
    np.testing.assert_allclose(np.angle(np.exp(1j * cont)), wrap, atol=1e-9)
    np.testing.assert_allclose(continuous.velocities, np.diff(cont)[-1] / 1e-3, rtol=1e-9)


def test_commands_act_on_exactly_the_next_step():
    a, b = Stepper(pinned_link(dt=0.01)), Stepper(pinned_link(dt=0.01))
    run(a, 5)
    run(b, 5)
    a.set_torque('hinge', 3.0)
    assert np.array_equal(a.angles, b.angles)
    a.step()
    b.step()
    assert a.angles[0] > b.angles[0] and a.efforts[0] == 3.0 and b.efforts[0] == 0.0
    a.set_enabled('hinge', False)
    q_a = a.body_q.copy()
    a.step()
    assert a.efforts[0] == 0.0
    c = Stepper(pinned_link(dt=0.01))
    c.set_enabled('hinge', False)
    c.set_torque('hinge', 5.0)
    d = Stepper(pinned_link(dt=0.01))
    np.testing.assert_array_equal(run(c, 20), run(d, 20))
    assert not np.array_equal(q_a, a.body_q)


def test_bad_commands_are_rejected_and_limits_clamp():
    data = pinned_link().model_dump(exclude_none=True)
    data['joints'][0]['effort_limit'] = 2.0
    sim = Stepper(Scene.from_dict(data))
    with pytest.raises(ValueError, match="'hinge'"):
        sim.set_torque('hinge', float('nan'))
    with pytest.raises(ValueError, match='finite'):
        sim.set_torque('hinge', float('inf'))
    with pytest.raises(KeyError, match='valid: hinge'):
        sim.set_torque('elbow', 1.0)
    with pytest.warns(SimulationWarning, match='effort_limit 2'):
        sim.set_torque('hinge', -5.0)
    sim.step()
    assert sim.efforts[0] == -2.0


def test_clamped_torques_are_counted_and_said_once_per_joint_until_reset():
    """A controller whose command saturates every step is told once per joint, not every
    call; clamp_totals counts every value clamped (per environment), resets included."""
    data = pinned_link().model_dump(exclude_none=True)
    data['joints'][0]['effort_limit'] = 2.0
    sim = Stepper(Scene.from_dict(data), num_envs=3)
    with pytest.warns(SimulationWarning, match=r"'hinge' \(effort_limit 2 N·m\)"):
        sim.set_torques([[5.0], [1.0], [-9.0]])
    with warnings.catch_warnings():
        warnings.simplefilter('error')                  # said already: counted, not said
        sim.set_torques([-7.0])
        sim.set_torque('hinge', 3.0)
    assert sim.clamp_totals == {'hinge': 4} and np.array_equal(sim.torques[:, 0], [2.0] * 3)
    sim.reset()
    with pytest.warns(SimulationWarning, match='effort_limit 2'):
        sim.set_torque('hinge', np.array([-3.0, 0.5, 2.0]))
    assert sim.clamp_totals == {'hinge': 5} and np.array_equal(sim.torques[:, 0], [-2.0, 0.5, 2.0])


def test_an_infinite_torque_is_refused_on_a_joint_without_an_effort_limit():
    """|±Inf| is not below an infinite limit: set_torques' one comparison must not pass it."""
    sim = Stepper(pinned_link())
    for value in (math.inf, -math.inf):
        with pytest.raises(ValueError, match='torque must be finite for hinge'):
            sim.set_torques([value])
    assert sim.torques[0] == 0.0


@pytest.mark.parametrize('scene_name', PACKAGED)
def test_packaged_scene_converges_every_step_with_small_joint_gap(scene_name):
    """Under small constant torques, or the scene's own control script where it has one
    (without it the grasp arm collapses onto the cube: that impact is README.md#grasping's)."""
    sim = Stepper(Scene.from_yaml(SCENES / f'{scene_name}.yaml'))
    script = ControlScript.load(scene_name) if scene_name in packaged_scripts() else None
    for k, name in enumerate(sim.command_joint_names):
        sim.set_torque(name, 0.5 * (-1) ** k)
    worst_gap = 0.0
    for _ in range(200):
        if script is not None:
            command_stepper(sim, script)
        sim.step()
        stats = sim.stats
        assert stats['converged'], stats
        assert stats['line_search_failures'] == 0
        worst_gap = max(worst_gap, stats['joint_gap'])
        assert np.all(np.isfinite(sim.body_q))
    assert worst_gap < 5e-4   # [m]: joints act as springs of stiffness K/dt²


def test_active_terms_list_only_what_the_scene_uses():
    sim = Stepper(pinned_link())
    assert sim.stats['active_terms'] == ['inertia', 'orthogonality', 'joints']
    sim.set_torque('hinge', 1.0)
    assert sim.stats['active_terms'][-1] == 'torque'
    sim.set_enabled('hinge', False)
    assert 'torque' not in sim.stats['active_terms']
    assert 'gravity' in Stepper(pinned_link(gravity=(0, 0, -9.81))).stats['active_terms']
    lone = Scene.from_dict({'gravity': [0, 0, 0], 'bodies': [
        {'name': 'box', 'shape': {'sphere': {'radius': 0.1}}, 'density': 500.0}]})
    assert Stepper(lone).stats['active_terms'] == ['inertia', 'orthogonality']


def test_free_body_flies_ballistically_and_spins_rigidly():
    scene = Scene.from_dict({'dt': 0.01, 'solver': {'integrator': 'bdf1'}, 'bodies': [
        {'name': 'ball', 'shape': {'sphere': {'radius': 0.1}}, 'mass': 1.0,
         'linear_velocity': [1.0, 0.0, 5.0], 'angular_velocity': [0.0, 0.0, 0.5]}]})
    sim = Stepper(scene)
    run(sim, 100)
    t = sim.time
    # implicit Euler on a constant force: z = v t − g t (t + dt) / 2
    np.testing.assert_allclose(sim.body_q[0, :3],
                               [t, 0, 5 * t - 9.81 * t * (t + 0.01) / 2], atol=1e-9)
    a = sim.body_q[0, 3:].reshape(3, 3)
    np.testing.assert_allclose(a @ a.T, np.eye(3), atol=1e-5)


def test_reset_restores_initial_state_and_time():
    sim = Stepper(pinned_link(gravity=(0, 0, -9.81), dt=0.01))
    first = run(sim, 30)
    sim.reset()
    assert sim.time == 0.0
    np.testing.assert_array_equal(run(sim, 30), first)


@pytest.mark.parametrize('threads', [2, 3])
def test_environments_stepped_on_several_threads_equal_one_thread_bit_for_bit(threads):
    """Each thread steps its own share of the environments at once (one launch each, the
    GIL released): the states, statistics and problem counts are those of one launch."""
    scene = Scene.from_yaml(SCENES / 'double_pendulum.yaml')
    runs = {}
    for count in (1, threads):
        sim = Stepper(scene, num_envs=5, threads=count, on_problem=lambda message: None)
        sim.set_torque('shoulder', np.array([0.0, 1.5, -3.0, 1e308, 2.0]))  # env 3 overflows
        for _ in range(20):
            sim.step()
        runs[count] = sim
    one, many = runs[1], runs[threads]
    assert many.stats['launches_per_step'] == threads and one.stats['launches_per_step'] == 1
    np.testing.assert_array_equal(many.body_q, one.body_q)
    for name, value in one.stats.items():
        if name != 'launches_per_step':
            np.testing.assert_array_equal(many.stats[name], value)
    assert many.problem_totals == one.problem_totals and one.problem_totals['non_finite'] == 20


def test_threads_must_be_a_positive_integer():
    with pytest.raises(ValueError, match='threads must be a positive integer or None'):
        Stepper(SCENES / 'pendulum.yaml', num_envs=2, threads=0)


def test_batched_envs_equal_single_runs_bit_for_bit():
    scene = Scene.from_yaml(SCENES / 'double_pendulum.yaml')
    torques = np.array([0.0, 1.5, -3.0])
    batch = Stepper(scene, num_envs=3)
    batch.set_torque('shoulder', torques)
    batch.set_enabled('elbow', np.array([True, False, True]))
    batch.set_torque('elbow', 1.0)
    for _ in range(50):
        batch.step()
    assert batch.angles.shape == (3, 2) and batch.body_q.shape == (3, 3, 12)
    for k in range(3):
        single = Stepper(scene)
        single.set_torque('shoulder', torques[k])
        single.set_torque('elbow', 1.0)
        single.set_enabled('elbow', k != 1)
        for _ in range(50):
            single.step()
        np.testing.assert_array_equal(batch.angles[k], single.angles)
        np.testing.assert_array_equal(batch.body_q[k], single.body_q)


def test_float32_tracks_float64():
    data = pinned_link(gravity=(0, 0, -9.81), dt=0.01).model_dump(exclude_none=True)
    data['solver'] = {'precision': 'float32', 'newton_tol': 1e-3}
    single = Stepper(Scene.from_dict(data))
    double = Stepper(pinned_link(gravity=(0, 0, -9.81), dt=0.01))
    for sim in (single, double):
        sim.set_torque('hinge', 2.0)
        run(sim, 100)
    assert single.angles[0] == pytest.approx(double.angles[0], abs=2e-3)


def test_float32_runs_a_robot_with_near_massless_links():
    # the Schur complement of a finger's stiff hinge cancels a parent pivot to rounding; float32
    # factored it into NaN and rejected every step (the robot stood frozen); later the fingers
    # spun until joints aliased (20 steps of 100 rejected, the shoulder 0.70 rad instead of
    # 0.29). The fingers' own steps still need not converge in float32 (the load says so)
    with pytest.warns(SimulationWarning, match='float32 does not resolve'):
        single = Stepper(arm_with_fingers('float32'), on_problem=lambda message: None)
    double = Stepper(arm_with_fingers('float64'), on_problem=lambda message: None)
    for sim in (single, double):
        sim.set_torque('shoulder', 1.0)
        for _ in range(100):
            sim.step()
            assert not sim.stats['step_rejected']
    assert single.angles[0] == pytest.approx(double.angles[0], abs=1e-4)


def test_largest_step_effort_turns_the_link_by_the_aliasing_limit_in_one_step():
    sim = Stepper(pinned_link(dt=0.01))
    bound = sim.step_effort_bounds[0]
    assert bound == pytest.approx(0.9 * math.pi * I_PIN / 0.01 ** 2, rel=1e-12)
    prismatic = Scene.from_dict({'bodies': [
        {'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0, 'fixed': True},
        {'name': 'cube', 'shape': {'box': [0.1, 0.2, 0.3]}, 'mass': 2.0}],
        'joints': [{'name': 's', 'type': 'prismatic', 'parent': 'base', 'child': 'cube',
                    'x0': [0, 0, 0], 'x1': [1, 0, 0]}]})
    assert Stepper(prismatic).step_effort_bounds[0] == pytest.approx(2.0 * 0.3 / 0.01 ** 2)


def test_set_torques_sets_every_command_joint_at_once_like_set_torque():
    """An array in command_joint_names order, per environment or for all: the same bits as
    setting each joint by name."""
    scene = Scene.from_yaml(SCENES / 'gantry.yaml')
    rng = np.random.default_rng(5)
    by_name, at_once = Stepper(scene, num_envs=3), Stepper(scene, num_envs=3)
    for _ in range(3):
        values = rng.uniform(-2.0, 2.0, (3, len(by_name.command_joint_names)))
        for k, name in enumerate(by_name.command_joint_names):
            by_name.set_torque(name, values[:, k])
        at_once.set_torques(values)
        for sim in (by_name, at_once):
            for _ in range(10):
                sim.step()
    assert np.array_equal(by_name.body_q, at_once.body_q)
    at_once.set_torques(np.ones(len(at_once.command_joint_names)))     # every environment
    at_once.step()
    assert np.array_equal(at_once.efforts[:, at_once.command_joint_index],
                          np.ones((3, len(at_once.command_joint_names))))
    with pytest.raises(ValueError, match=r'expected shape \(2,\) or \(3, 2\)'):
        at_once.set_torques([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match='torque must be finite for rail'):
        at_once.set_torques([math.nan, 0.0])


def test_link_transforms_are_each_bodys_polar_rotation_times_the_links_pose():
    """``link_transforms`` (one replay of the frame kernel over every environment's links)
    against the polar decomposition by SVD of each body's A (``poses.rigid_transforms``)
    times the link's pose on its body: the packaged quadruped's 17 links, two environments
    driven apart, after it has landed and swung (its A strained by the contact)."""
    from affine_joint_sim.poses import LinkFrames, rigid_transforms
    scene = Scene.load(SCENES / 'quadruped.yaml')
    sim = Stepper(scene, num_envs=2)
    swing = np.where(np.arange(len(sim.command_joint_names)) % 3 == 1, 2.0, -1.0)
    sim.set_torques(np.stack([swing, -swing]))
    for _ in range(200):
        sim.step()
    links = LinkFrames(scene)
    bodies = rigid_transforms(sim.body_q)                   # (2, n_bodies, 4, 4)
    expected = bodies[:, links.body] @ links.local
    assert not np.allclose(expected[0], expected[1], atol=1e-3)     # two different states
    np.testing.assert_allclose(sim.link_transforms, expected, rtol=0.0, atol=1e-12)
    kept = sim.link_transforms                  # a copy: the next read does not change it
    kept[...] = 0.0
    np.testing.assert_allclose(sim.link_transforms, expected, rtol=0.0, atol=1e-12)
