"""The accuracy sweep's logic: its rigid-body reference against closed forms and conservation
laws, the Pareto front, the cheapest setting per target, the order fit, and one measured run.
No wall-clock figure is asserted."""

import math

import numpy as np
import pytest

from affine_joint_sim import Scene
from affine_joint_sim.bench.analysis import cheapest_reaching, fitted_orders, pareto_front
from affine_joint_sim.bench.cases import Case, reference
from affine_joint_sim.bench.measure import angle_error, run_stepper
from affine_joint_sim.bench.references import RigidTree
from affine_joint_sim.chain import chain_scene

G = 9.81


def test_small_swing_of_a_pendulum_has_the_linear_period():
    theta0 = 0.01                    # released 0.01 rad from hanging: θ(t) = −θ0 (1 − cos Ωt)
    tree = RigidTree(chain_scene(1, link_length=1.0, angle=theta0))
    inertia = 1.0 * (0.05 ** 2 + 1.0) / 12 + 0.25           # about the hinge [kg·m²]
    omega = math.sqrt(1.0 * G * 0.5 / inertia)
    times = np.array([0.2, 0.7, 1.3])
    angles, _ = tree.simulate([0.0], times, step=0.01)
    np.testing.assert_allclose(angles[:, 0], -theta0 * (1 - np.cos(omega * times)),
                               rtol=1e-4, atol=1e-9)


def test_wheel_under_constant_torque_follows_tau_t_squared_over_2i():
    tree = RigidTree(Scene.from_yaml('msg_configs/scenes/wheel.yaml'))
    times = np.array([0.5, 1.0, 3.0])
    angles, velocities = tree.simulate([1.0], times, step=0.05)   # RK4 is exact here
    inertia = 2.0 * 0.3 ** 2 / 2
    np.testing.assert_allclose(angles[:, 0], times ** 2 / (2 * inertia), rtol=1e-12)
    np.testing.assert_allclose(velocities[:, 0], times / inertia, rtol=1e-12)


def test_double_pendulum_equations_match_the_textbook_form():
    # two uniform rods (mass m, length L, COM at L/2, I = m(w² + L²)/12), relative angles
    tree = RigidTree(chain_scene(2, link_length=1.0))
    m, length, c = 1.0, 1.0, 0.5
    inertia = m * (0.05 ** 2 + length ** 2) / 12
    rng = np.random.default_rng(3)
    for _ in range(5):
        (t1, t2), (w1, w2), torque = rng.normal(0, 1.5, 2), rng.normal(0, 2, 2), rng.normal(0, 1, 2)
        cos2, sin2 = math.cos(t2), math.sin(t2)
        mass_matrix = np.array([
            [2 * inertia + m * c * c + m * (length ** 2 + c * c + 2 * length * c * cos2),
             inertia + m * (c * c + length * c * cos2)],
            [inertia + m * (c * c + length * c * cos2), inertia + m * c * c]])
        coriolis = m * length * c * sin2 * np.array([-(2 * w1 * w2 + w2 * w2), w1 * w1])
        gravity = G * np.array([m * c * math.sin(t1) + m * (length * math.sin(t1)
                                                            + c * math.sin(t1 + t2)),
                                m * c * math.sin(t1 + t2)])
        expected = np.linalg.solve(mass_matrix, torque - coriolis - gravity)
        np.testing.assert_allclose(tree.acceleration(np.array([t1, t2]), np.array([w1, w2]),
                                   torque), expected, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(tree.mass_matrix(np.array([t1, t2])), mass_matrix,
                                   rtol=1e-12)


def turret_arm() -> Scene:
    """A 3-D tree: a turret on a vertical yaw joint, an arm on a horizontal hinge, a hand
    rolling about the arm's long axis."""
    return Scene.from_dict({'bodies': [
        {'name': 'base', 'shape': {'box': [0.3, 0.3, 0.1]}, 'density': 1000.0, 'fixed': True},
        {'name': 'turret', 'shape': {'cylinder': {'radius': 0.1, 'length': 0.1}}, 'mass': 2.0,
         'position': [0, 0, 0.1]},
        {'name': 'arm', 'shape': {'box': [0.05, 0.05, 0.6]}, 'mass': 1.0,
         'position': [0.0, 0.0, 0.45], 'orientation': {'rpy': [0.0, 0.3, 0.0]}},
        {'name': 'hand', 'shape': {'box': [0.2, 0.04, 0.04]}, 'mass': 0.5,
         'position': [0.5 * math.sin(0.3), 0.0, 0.15 + 0.5 * math.cos(0.3)],
         'orientation': {'rpy': [0.0, 0.3, 0.0]}}],
        'joints': [
            {'name': 'yaw', 'parent': 'base', 'child': 'turret', 'x0': [0, 0, 0.05],
             'x1': [0, 0, 0.15], 'torque_model': 'generalized'},
            {'name': 'pitch', 'parent': 'turret', 'child': 'arm', 'x0': [0, -0.05, 0.15],
             'x1': [0, 0.05, 0.15], 'torque_model': 'generalized'},
            {'name': 'roll', 'parent': 'arm', 'child': 'hand', 'x0': [0, 0, 0.15],
             'x1': [0.5 * math.sin(0.3), 0.0, 0.15 + 0.5 * math.cos(0.3)],
             'torque_model': 'generalized'}]})


def test_3d_tree_conserves_energy_and_the_free_yaw_momentum():
    # τ on pitch and roll only: the work Σ τ Δθ is all the energy gained, and the momentum of
    # the free yaw joint (a cyclic coordinate: gravity has no moment about z) stays zero
    tree = RigidTree(turret_arm())
    torque = np.array([0.0, 0.4, 0.05])
    times = np.array([0.1, 0.2, 0.3])
    angles, velocities = tree.simulate(torque, times)
    start = tree.energy(np.zeros(3), np.zeros(3))
    for theta, omega in zip(angles, velocities):
        assert tree.energy(theta, omega) - start == pytest.approx(torque @ theta, abs=1e-9)
        assert abs((tree.mass_matrix(theta) @ omega)[0]) < 1e-10
    assert abs(velocities[-1, 0]) > 1e-3       # while the turret does turn


def test_rigid_tree_rejects_what_it_cannot_model():
    with pytest.raises(ValueError, match='rest'):
        RigidTree(Scene.from_dict({'bodies': [{'name': 'ball', 'shape': {'sphere': {'radius': 1}},
                                               'mass': 1.0, 'angular_velocity': [1, 0, 0]}]}))
    free_parent = chain_scene(2, torque_model='lever_arm')
    with pytest.raises(ValueError, match='lever_arm'):
        RigidTree(free_parent).simulate([0.0, 1.0], [0.1])


def test_pareto_front_keeps_only_undominated_rows_by_cost():
    rows = [{'ms_per_sim_s': c, 'error_rad': e} for c, e in
            [(1, 1e-1), (2, 1e-2), (2.5, 5e-2), (3, 1e-2), (4, 1e-4), (5, 1e-3)]]
    assert [(r['ms_per_sim_s'], r['error_rad']) for r in pareto_front(rows)] == [
        (1, 1e-1), (2, 1e-2), (4, 1e-4)]


def test_cheapest_reaching_a_target():
    rows = [{'ms_per_sim_s': c, 'error_rad': e} for c, e in [(1, 1e-1), (3, 1e-3), (2, 1e-3)]]
    assert cheapest_reaching(rows, 1e-2)['ms_per_sim_s'] == 2
    assert cheapest_reaching(rows, 1e-4) is None


def test_fitted_order_recovers_the_power_and_leaves_out_the_floor():
    dts = [0.02, 0.01, 0.005, 0.0025]
    rows = [{'integrator': 'first', 'dt': dt, 'error_rad': 3 * dt} for dt in dts]
    rows += [{'integrator': 'second', 'dt': dt, 'error_rad': max(7 * dt ** 2, 1e-4)}
             for dt in dts]
    orders = fitted_orders(rows, floor=1.5e-4)
    assert orders['first'] == pytest.approx(1.0)
    assert orders['second'] == pytest.approx(2.0)
    assert fitted_orders(rows)['second'] < 1.9     # with the floor point the fit bends


def test_angle_error_is_taken_modulo_two_pi():
    assert angle_error([[math.pi - 0.01]], np.array([[-math.pi + 0.01]])) == pytest.approx(0.02)


def test_a_measured_run_reports_bdf1_error_and_the_torques_work():
    # BDF1 on a pendulum under 2 N·m: first-order error, a negative energy drift (dissipation)
    case = Case('pendulum', Scene.from_yaml('msg_configs/scenes/pendulum.yaml'),
                {'shoulder': 2.0}, 0.3)
    truth = reference(case)
    coarse, fine = (run_stepper(case, truth, dt=dt, integrator='bdf1', newton_tol=1e-8,
                                precision='float64', device='cpu', repeats=1)
                    for dt in (0.01, 0.005))
    assert fine['error_rad'] < coarse['error_rad'] < 0.05
    assert fine['error_rad'] == pytest.approx(coarse['error_rad'] / 2, rel=0.15)
    assert coarse['energy_drift_j'] < 0 and coarse['converged_pct'] == 100.0
    assert truth.error_estimate < 1e-9
