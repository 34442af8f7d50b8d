"""Newton (physics.solve.newton): the start from the last step's correction, extrapolated where it
changes smoothly, against runs converged tightly; the warm start against a NumPy polar
decomposition; updates that follow turns against the matrix exponential; where it stops when
rounding, not the tolerance, limits an update; near-massless links converge."""

import warnings

import numpy as np
import pytest

from affine_joint_sim.chain import chain_scene
from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.resources import scene_path
from affine_joint_sim.sim_warnings import SimulationWarning
from affine_joint_sim.stepper import Stepper
from helpers.physics import arm_with_fingers, random_rotation
from test_joints import every_joint_type


def _swinging_chain(tol: float, integrator: str, ramp: float = 0.0):
    """Three links released at 0.5 rad under 1 N·m at the first joint, growing by ``ramp``
    N·m a step, 0.5 s at dt 1e-3: (angles of every step, (Newton iterations, Hessians) of
    every step)."""
    scene = chain_scene(3, dt=1e-3, integrator=integrator, angle=0.5)
    data = scene.model_dump(exclude_none=True)
    data['solver'] = dict(data.get('solver', {}), newton_tol=tol)
    sim = Stepper(type(scene).from_dict(data))
    angles, calls = [], []
    for k in range(500):
        sim.set_torque(sim.command_joint_names[0], 1.0 + ramp * k)
        sim.step()
        angles.append(sim.angles.copy())
        calls.append((sim.stats['newton_iterations'], sim.stats['hessians']))
    return np.array(angles), calls


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_newton_starts_from_the_last_correction_and_its_first_update_ends_the_step(integrator):
    # the last step's forces besides inertia and gravity applied again: within the tolerance
    # of the solution where they change little (before: every step a full iteration and a
    # check on its factors, (2, 1)); the first step has no correction to start from
    angles, calls = _swinging_chain(1e-4, integrator)
    tight, _ = _swinging_chain(1e-10, integrator)
    assert calls[0] == (2, 1)
    assert sum(c == (1, 1) for c in calls) >= 490
    assert np.abs(angles - tight).max() < 1e-6
    assert np.abs(angles[-1] - angles[0]).max() > 0.05      # it swung


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_a_steadily_changing_correction_is_extrapolated(integrator):
    # the torque grows 0.01 N·m a step under a tolerance ten times tighter: the last
    # correction alone is off by its change (0 of 500 steps ended on the first update,
    # 2026-12-05), 2 c_n − c_{n−1} is not
    angles, calls = _swinging_chain(1e-5, integrator, ramp=0.01)
    tight, _ = _swinging_chain(1e-10, integrator, ramp=0.01)
    assert sum(c == (1, 1) for c in calls) >= 480
    assert np.abs(angles - tight).max() < 1e-6


def test_a_correction_that_jumps_is_not_extrapolated():
    # the six-joint arm falling from its bent pose at dt 0.01, its wrist spinning up: where a
    # correction changed by more than a fifth of itself the start takes it alone (extrapolated
    # there too, steps 66 and 71 ran into the 32-iteration cap without converging)
    assert max(_converged_iterations(Stepper(scene_path('arm6')), 100)) <= 8


def _converged_iterations(sim: Stepper, steps: int) -> list:
    """Newton iterations of each of ``steps`` steps of ``sim``, every one converged."""
    iterations = []
    for _ in range(steps):
        sim.step()
        assert sim.stats['converged']
        iterations.append(sim.stats['newton_iterations'])
    return iterations


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
    # tolerance (whose last update, from the previous iteration's factors, leaves 4.4e-7 rad
    # after 100 steps of this chaotic chain in float64)
    floor, stats = _chain_run(100, precision=precision, newton_tol=tol)
    reachable, _ = _chain_run(100, precision=precision)
    assert all(s['converged'] for s in stats)
    assert np.mean([s['newton_iterations'] for s in stats]) < 8
    assert np.abs(floor - reachable).max() < (1e-6 if precision == 'float64' else 2e-3)


def _expm(m, terms=40):
    """exp(m) by its Taylor series (3×3, |m| ≲ 1)."""
    out, term = np.eye(3), np.eye(3)
    for k in range(1, terms):
        term = term @ m / k
        out = out + term
    return out


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def test_an_update_that_turns_a_body_is_followed_on_its_rotation():
    stages = Stages(every_joint_type())
    rng = np.random.default_rng(11)
    q, dq = stages.host.body_q0.copy(), np.zeros_like(stages.host.body_q0)
    turns, strains = [], []
    for b in range(stages.host.body_count):
        a = random_rotation(rng) @ np.diag(1 + rng.uniform(-1e-3, 1e-3, 3))
        q[b, 3:] = a.reshape(9)
        w, e = rng.uniform(-0.2, 0.2, 3), rng.uniform(-1e-3, 1e-3, (3, 3))
        e = (e + e.T) / 2
        dq[b, :3] = rng.uniform(-0.01, 0.01, 3)
        dq[b, 3:] = ((_skew(w) + e) @ a).reshape(9)
        turns.append(w)
        strains.append(e)
    moved, _ = stages.moved(q, dq)
    for b in range(stages.host.body_count):
        a = q[b, 3:].reshape(3, 3)
        expected = _expm(_skew(turns[b])) @ (np.eye(3) + strains[b]) @ a
        np.testing.assert_allclose(moved[b, 3:].reshape(3, 3), expected, atol=1e-13)
        np.testing.assert_allclose(moved[b, :3], q[b, :3] + dq[b, :3], atol=1e-15)
    # to first order the straight step: the difference shrinks with the square of the step
    small = [np.abs(stages.moved(q, s * dq)[0] - (q + s * dq)).max() for s in (1e-2, 2e-2)]
    assert small[1] / small[0] == pytest.approx(4.0, rel=1e-3)


def test_the_full_step_turns_no_followed_body_by_more_than_half_a_radian():
    stages = Stages(every_joint_type())
    q, dq = stages.host.body_q0.copy(), np.zeros_like(stages.host.body_q0)
    body = stages.free[0]
    dq[body, 3:] = (_skew([0.0, 2.0, 0.0]) @ q[body, 3:].reshape(3, 3)).reshape(9)
    assert stages.moved(q, dq)[1] == pytest.approx(0.25, rel=1e-12)
    assert stages.moved(q, dq / 8)[1] == 1.0


def test_turns_that_float32_does_not_resolve_are_not_followed_and_said():
    # a 2 mg finger's rotational inertia (1e-12 kg·m²) is below float32's rounding of its
    # rigidity: its turns are noise there and not followed (nor do they cap the step)
    scene = arm_with_fingers('float32')
    arm = scene.model_copy(update={'bodies': scene.bodies[:2], 'joints': scene.joints[:1]})
    with warnings.catch_warnings():
        warnings.simplefilter('error')      # the 1 kg arm alone, and the fingers in float64
        Stages(arm)
        float64 = Stages(arm_with_fingers('float64'))
    with pytest.warns(SimulationWarning, match="float32 does not resolve the rotational "
                      "inertia of 3 moving bodies \\('finger0', 'finger1', 'finger2'\\)"):
        float32 = Stages(scene)
    assert list(float32.host.body_resolves_turns) == [1, 1, 0, 0, 0]
    for stages, capped in ((float64, 0.5 / 2.0), (float32, 1.0)):
        q, dq = stages.host.body_q0.copy(), np.zeros_like(stages.host.body_q0)
        finger = stages.free[-1]
        dq[finger, 3:] = (_skew([2.0, 0.0, 0.0]) @ q[finger, 3:].reshape(3, 3)).reshape(9)
        assert stages.moved(q, dq)[1] == pytest.approx(capped, rel=1e-6)


def test_near_massless_links_converge():
    # three 2 mg finger links at the tip of a 1 kg arm: their turns about their hinges are
    # nearly free and the orthogonality energy fought the stretch of straight Newton steps,
    # so every step ran to newton_max_iter (50 of 50) creeping a few milliradians an iteration
    sim = Stepper(arm_with_fingers('float64'), on_problem=lambda message: None)
    sim.set_torque('shoulder', 1.0)
    assert max(_converged_iterations(sim, 50)) <= 8
