"""The stepper at the extremes of its inputs: it stays finite, passive energy never grows, joint
gaps stay within the penalty spring's sag, and what it cannot do it says (flag + warning).

Truth: energy conservation (BDF steps may only dissipate), the static sag of the penalty joint
(a load F on a joint of two anchors of stiffness K/dt² each opens it by F dt²/(2K)), closed
forms of a constant torque and of the first affine step of a spinning body, and the previous
state where a step is rejected. Each case is a few hundred steps; the soak is 1e5.
"""

import math
import warnings

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.chain import chain_scene
from affine_joint_sim.sim_warnings import SimulationWarning

G = 9.81
BASE_MASS = 1000.0 * 0.2 ** 3          # chain_scene's fixed base [kg]
DYNAMIC_LOAD = 4.0                     # joint load / static load: a swinging link pulls ≤ 3 g
ENERGY_TOL = 1e-9                      # growth allowed per J of energy scale (roundoff)


def edited(scene: Scene, *, body=None, joint=None, solver=None, **top) -> Scene:
    """``scene`` with every free body, every joint and the solver updated by the given keys."""
    data = scene.model_dump(exclude_none=True)
    for b in data['bodies']:
        if not b.get('fixed'):
            b.update(body or {})
    for j in data['joints']:
        j.update(joint or {})
    data['solver'] = dict(data.get('solver', {}), **(solver or {}))
    data.update(top)
    return Scene.from_dict(data)


def pendulum(angle=1.0, **changes) -> Scene:
    """A 1 kg, 1 m box link released at ``angle`` [rad] from hanging straight down."""
    return edited(chain_scene(1, link_length=1.0, angle=angle), **changes)


def mass(body) -> float:
    """A box body's mass [kg], given or from its density."""
    return body.mass if body.mass is not None else body.density * math.prod(body.shape.box)


def sag_bound(sim: Stepper) -> float:
    """Largest gap [m] the joints may open: DYNAMIC_LOAD × the weight below each joint, on its
    two anchors of stiffness K/dt², K = strength_ratio (m_parent + m_child)."""
    scene, masses = sim.scene, {b.name: mass(b) for b in sim.scene.bodies}
    below = {b.name: masses[b.name] for b in scene.bodies}
    for joint in reversed(scene.joints):          # chains list joints root first
        below[joint.parent] += below[joint.child]
    return max(DYNAMIC_LOAD * below[j.child] * G * scene.dt ** 2
               / (2 * j.strength_ratio * (masses[j.parent] + masses[j.child]))
               for j in scene.joints) + 1e-12


def energy_scale(sim: Stepper) -> float:
    """m g h of every free body over the scene's extent [J]: a scale for energy tolerances."""
    extent = max(np.linalg.norm(b.position) for b in sim.scene.bodies) + 1.0
    return sum(b.mass for b in sim.scene.bodies if not b.fixed) * G * extent


def run_passive(sim: Stepper, steps: int, every: int = 1) -> dict:
    """Step ``sim``; check finiteness, energy and gap on the way; return what was seen."""
    energy0, bound = sim.energy, sag_bound(sim)
    scale = energy_scale(sim) + abs(energy0)
    seen = {'energy_growth': 0.0, 'gap': 0.0, 'unconverged': 0, 'rejected': 0, 'angles': []}
    for n in range(steps):
        sim.step()
        if n % every and n != steps - 1:
            continue
        stats = sim.stats
        assert np.all(np.isfinite(sim.body_q)) and np.all(np.isfinite(sim.body_qdot))
        seen['energy_growth'] = max(seen['energy_growth'], (sim.energy - energy0) / scale)
        seen['gap'] = max(seen['gap'], stats['joint_gap'])
        seen['unconverged'] += not stats['converged']
        seen['rejected'] += stats['step_rejected']
        seen['angles'].append(sim.angles)
    assert seen['energy_growth'] <= ENERGY_TOL, seen
    assert seen['gap'] <= bound, (seen, bound)
    assert seen['rejected'] == 0, seen
    return seen


@pytest.mark.parametrize('torque_model', ['lever_arm', 'generalized'])
@pytest.mark.parametrize('torque', [1e-9, 1e-3, 1.0, 1e3, 1e6])
def test_torque_from_1e_minus_9_to_1e6(torque, torque_model):
    sim = Stepper(pendulum(angle=0.0, gravity=[0, 0, 0], joint={'torque_model': torque_model,
                                                               'angle_mode': 'continuous'}))
    sim.set_torque('joint0', torque)
    inertia = 1.0 * (0.05 ** 2 + 1.0) / 12 + 0.25          # box link about its end [kg·m²]
    k = 2 * 100.0 * (BASE_MASS + 1.0)                     # both anchors' K [kg]
    angles, unconverged = [], False
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always', SimulationWarning)
        for _ in range(30):
            sim.step()
            stats = sim.stats
            unconverged |= not stats['converged']
            assert np.all(np.isfinite(sim.body_q)) and not stats['step_rejected']
            # the joint carries at most the lever-arm force τ/r plus the centripetal force
            load = torque / 0.5 + 1.0 * 0.5 * sim.velocities[0] ** 2
            assert stats['joint_gap'] <= 1.5 * load * 0.01 ** 2 / k + 1e-12
            angles.append(sim.angles[0])
    assert unconverged == any('did not converge' in str(w.message) for w in caught)
    assert np.all(np.diff(angles) > 0) and angles[0] > 0
    if torque <= 1.0:   # rotation per step ≤ 0.01 rad: BDF1's θ_n = τ dt² n (n + 1) / (2 I)
        assert angles[-1] == pytest.approx(torque * 0.01 ** 2 * 30 * 31 / (2 * inertia),
                                           rel=2e-3)


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
@pytest.mark.parametrize('dt', [1e-5, 1e-4, 1e-3, 1e-2, 0.05])
def test_dt_from_1e_minus_5_to_0_05(dt, integrator):
    sim = Stepper(pendulum(dt=dt, solver={'integrator': integrator}))
    seen = run_passive(sim, 200)
    assert seen['unconverged'] == 0


def test_bdf2_keeps_a_body_at_rest_at_rest():
    # BDF2's 4/3 q_n − 1/3 q_{n−1} must be exactly q_n at rest: float32-rounded coefficients
    # once stretched a free body by 1e-8 per step at dt = 1e-5 and fed energy into it
    scene = Scene.from_dict({'dt': 1e-5, 'gravity': [0, 0, 0], 'solver': {'integrator': 'bdf2'},
                             'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 1.0]},
                                         'mass': 1.0}]})
    sim = Stepper(scene)
    start = sim.body_q.copy()
    for _ in range(100):
        sim.step()
    np.testing.assert_array_equal(sim.body_q, start)


@pytest.mark.parametrize('ratio', [1e-6, 1e-3, 1.0, 1e3, 1e6])
@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_parent_child_mass_ratio_from_1e_minus_6_to_1e6(ratio, integrator):
    data = chain_scene(2, link_length=1.0, angle=1.0, integrator=integrator).model_dump(
        exclude_none=True)
    data['bodies'][1]['mass'] = ratio          # upper link: parent of the lower 1 kg link
    seen = run_passive(Stepper(Scene.from_dict(data)), 150)
    assert seen['unconverged'] == 0


def test_64_link_chain_falls_for_one_second():
    sim = Stepper(chain_scene(64, link_length=0.1, angle=math.pi / 2))
    seen = run_passive(sim, 100)
    assert seen['unconverged'] == 0
    assert sim.body_q[-1, 2] < -1.0        # the free end fell by more than 1 m


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
@pytest.mark.parametrize('rotation_per_step', [0.1, 0.5, 1.0, 2.0, 3.0])
def test_rotation_per_step_up_to_the_aliasing_limit(rotation_per_step, integrator):
    # A wheel (COM on its axle) set spinning at ω = rotation/dt. The first (BDF1) affine step
    # moves A to A + dt[ω]×A; its nearest rotation turns by atan(ω dt) < π/2, so a body can
    # never turn as far as the aliasing limit in one step: it is slowed instead, never sped up.
    wheel = Scene.from_dict(dict(
        Scene.from_yaml('msg_configs/scenes/wheel.yaml').model_dump(exclude_none=True),
        solver={'integrator': integrator, 'newton_tol': 1e-6}))
    omega = rotation_per_step / wheel.dt
    sim = Stepper(edited(wheel, body={'angular_velocity': [0.0, omega, 0.0]},
                         joint={'torque': 0.0}))
    angles = np.array(run_passive(sim, 40)['angles'])[:, 0]
    assert angles[0] == pytest.approx(math.atan(rotation_per_step), rel=1e-3)
    assert np.all(np.diff(angles) > 0)


def counter_rotating_pair(rotation_per_step: float) -> Scene:
    """Two free cubes hinged about world z, spun in opposite senses about the hinge."""
    omega, cube = rotation_per_step / 0.01, {'shape': {'box': [0.2, 0.2, 0.2]}, 'mass': 1.0}
    return Scene.from_dict({
        'gravity': [0, 0, 0], 'dt': 0.01,
        'bodies': [dict(cube, name='left', position=[-0.3, 0, 0], angular_velocity=[0, 0, -omega],
                        linear_velocity=[0, 0.3 * omega, 0]),
                   dict(cube, name='right', position=[0.3, 0, 0], angular_velocity=[0, 0, omega],
                        linear_velocity=[0, 0.3 * omega, 0])],
        'joints': [{'name': 'hinge', 'parent': 'left', 'child': 'right', 'x0': [0, 0, -0.1],
                    'x1': [0, 0, 0.1], 'torque_model': 'generalized',
                    'angle_mode': 'continuous'}]})


def test_a_step_past_the_aliasing_limit_is_rejected_keeping_the_last_good_state():
    slow = Stepper(counter_rotating_pair(0.5))
    for _ in range(5):
        slow.step()
        assert not slow.stats['step_rejected'] and slow.angles[0] > 0
    fast = Stepper(counter_rotating_pair(100.0))     # each cube turns ~π/2: relative ~π
    start, energy = fast.body_q.copy(), fast.energy
    with pytest.warns(SimulationWarning, match='alias'):
        fast.step()
    stats = fast.stats
    assert stats['angle_aliased'] and stats['step_rejected'] and not stats['non_finite']
    np.testing.assert_array_equal(fast.body_q, start)
    assert fast.angles[0] == 0.0 and fast.energy == energy


def test_a_non_finite_step_is_rejected_keeping_the_last_good_state():
    sim = Stepper(pendulum(angle=0.3), num_envs=2)
    for _ in range(5):
        sim.step()
    q, angles = sim.body_q.copy(), sim.angles.copy()
    sim.set_torque('joint0', np.array([1e308, 0.0]))    # finite, but overflows the state
    with pytest.warns(SimulationWarning, match='NaN/Inf'):
        sim.step()
    stats = sim.stats
    assert list(stats['step_rejected']) == [True, False]
    assert list(stats['non_finite']) == [True, False]
    np.testing.assert_array_equal(sim.body_q[0], q[0])
    np.testing.assert_array_equal(sim.angles[0], angles[0])
    assert not np.array_equal(sim.body_q[1], q[1])      # the other env stepped on
    sim.set_torque('joint0', 0.0)
    sim.step()
    assert not sim.stats['step_rejected'].any() and np.all(np.isfinite(sim.body_q))


def test_non_convergence_is_flagged_and_warned_keeping_the_last_iterate():
    # two Newton iterations cannot meet 1e-10 m/s, but leave the pendulum within 1e-3 rad of
    # the converged run: keeping the iterate (flagged) beats freezing the simulation
    loose = Stepper(pendulum(solver={'newton_max_iter': 2, 'newton_tol': 1e-10}))
    tight = Stepper(pendulum(solver={'newton_tol': 1e-8}))
    with pytest.warns(SimulationWarning, match='did not converge'):
        loose.step()
    tight.step()
    for _ in range(50):
        loose.step()
        tight.step()
        assert not loose.stats['converged'] and not loose.stats['step_rejected']
    assert loose.angles[0] == pytest.approx(tight.angles[0], abs=1e-3)


@pytest.mark.parametrize('kappa', [1e4, 1e6, 1e8, 1e11])
@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_kappa_from_1e4_to_1e11(kappa, integrator):
    sim = Stepper(pendulum(body={'kappa': kappa}, solver={'integrator': integrator}))
    assert run_passive(sim, 150)['unconverged'] == 0


@pytest.mark.parametrize('strength_ratio', [1.0, 1e2, 1e4, 1e6])
@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_strength_ratio_from_1_to_1e6(strength_ratio, integrator):
    sim = Stepper(pendulum(joint={'strength_ratio': strength_ratio},
                           solver={'integrator': integrator}))
    assert run_passive(sim, 150)['unconverged'] == 0


@pytest.mark.parametrize('integrator', ['bdf1', 'bdf2'])
def test_passive_pendulum_soak_of_1e5_steps(integrator):
    sim = Stepper(pendulum(angle=1.0, solver={'integrator': integrator}))
    seen = run_passive(sim, 100_000, every=500)
    assert seen['unconverged'] == 0
    swing = np.array(seen['angles'])[:, 0]     # released at 1 rad: θ stays within [−2, 0]
    assert np.all((swing >= -2.0 - 1e-6) & (swing <= 1e-6))
