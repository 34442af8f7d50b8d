"""Newton (physics.newton): the warm start against a NumPy polar decomposition; where it
stops when rounding, not the tolerance, limits an update."""

import numpy as np
import pytest

from affine_joint_sim.chain import chain_scene
from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.stepper import Stepper
from helpers.physics import random_rotation
from test_joints import every_joint_type


def _polar(a):
    u, sigma, vt = np.linalg.svd(a)
    return u @ vt, vt.T @ np.diag(sigma) @ vt


def test_a_sheared_prediction_starts_from_its_rotation_times_the_last_stretch():
    stages = Stages(every_joint_type())
    rng = np.random.default_rng(9)
    q_n, q_tilde = stages.host.body_q0.copy(), stages.host.body_q0.copy()
    for b in range(stages.host.body_count):
        stretch = random_rotation(rng) @ np.diag(1 + rng.uniform(-1e-4, 1e-4, 3))
        q_n[b, 3:] = (random_rotation(rng) @ stretch).reshape(9)
        q_tilde[b, 3:] = (random_rotation(rng) @ np.diag(rng.uniform(0.9, 1.1, 3))
                          @ random_rotation(rng)).reshape(9)
    start = stages.warm_start(q_tilde, q_n)
    for b in range(stages.host.body_count):
        rotation = _polar(q_tilde[b, 3:].reshape(3, 3))[0]
        expected = rotation @ _polar(q_n[b, 3:].reshape(3, 3))[1]
        np.testing.assert_allclose(start[b, 3:].reshape(3, 3), expected, atol=1e-12)
        np.testing.assert_array_equal(start[b, :3], q_tilde[b, :3])


def test_a_prediction_that_adds_no_shear_is_kept_as_it_is():
    stages = Stages(every_joint_type())
    rng = np.random.default_rng(10)
    q_n = stages.host.body_q0.copy()
    q_tilde = q_n.copy()
    for b in range(stages.host.body_count):
        a = random_rotation(rng) @ np.diag(1 + rng.uniform(-1e-3, 1e-3, 3))
        q_n[b, 3:] = a.reshape(9)
        q_tilde[b, 3:] = (random_rotation(rng) @ a).reshape(9)      # same stretch, turned
    q_tilde[0, 3:] = random_rotation(rng).reshape(9)                 # a rotation exactly
    np.testing.assert_array_equal(stages.warm_start(q_tilde, q_n), q_tilde)


def _chain_run(steps, **solver):
    """Joint angles [rad] after each of ``steps`` steps of six 1 kg, 1 m links (reaching 6 m
    below the origin) with 2 N·m on every joint, and the Newton stats of every step."""
    scene = chain_scene(6, link_length=1.0, section=0.1, integrator='bdf2')
    sim = Stepper(scene.model_copy(update={'solver': scene.solver.model_copy(update=solver)}),
                  on_problem=lambda message: None)
    for name in sim.command_joint_names:
        sim.set_torque(name, 2.0)
    angles, stats = [], []
    for _ in range(steps):
        sim.step()
        angles.append(sim.angles.copy())
        stats.append(sim.stats)
    return np.array(angles), stats


def test_float32_far_from_the_origin_converges_where_float64_does():
    # 6 m out, float32 rounds a coordinate by ~5e-7 m: the Newton updates near the solution
    # and the energy changes they bring are of the size of that rounding. Judged by the
    # relative rounding of E alone, the line search rejected them and Newton spun to
    # newton_max_iter (before: 4 of 100 steps unconverged, 100+ line-search failures)
    single, stats = _chain_run(100, precision='float32')
    double, _ = _chain_run(100)
    assert all(s['converged'] for s in stats)
    assert sum(s['line_search_failures'] for s in stats) == 0
    assert np.abs(single - double).max() < 2e-3


@pytest.mark.parametrize('precision, tol', [('float64', 1e-13), ('float32', 1e-6)])
def test_a_tolerance_below_rounding_stops_at_the_rounding_floor(precision, tol):
    # newton_tol·dt below what the precision resolves at 6 m: Newton stops once its update
    # is rounding (16 ε of the chain's 6 m extent) instead of cycling to newton_max_iter
    # (before: float64 52, float32 100 of 100 steps unconverged), as accurate as a reachable
    # tolerance
    floor, stats = _chain_run(100, precision=precision, newton_tol=tol)
    reachable, _ = _chain_run(100, precision=precision)
    assert all(s['converged'] for s in stats)
    assert np.mean([s['newton_iterations'] for s in stats]) < 8
    assert np.abs(floor - reachable).max() < (1e-7 if precision == 'float64' else 2e-3)
