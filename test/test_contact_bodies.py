"""Contact between two moving bodies (README.md#contact): a free collision in zero gravity
conserves linear momentum and never interpenetrates (the separating-axis test of the two boxes,
independent of the simulator's own distances); three stacked boxes stand; a gripper lifts a box
only when friction can carry it; thrown bricks never interpenetrate; a contact sensor feels the
box resting on its body; the point–face and edge–edge gradients and the friction of two bodies
against finite differences; the coupled solve against a dense solve of the assembled system;
the step bound against the analytic impact of two bodies."""

import math

import numpy as np
import pytest

from affine_joint_sim.bench.bodies import gripper_scene, lift_target, stack_scene
from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.physics.contact.pairs import near_pairs, pair_gap
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.barrier import assert_matches_differences, assert_psd
from helpers.separation import separation

D_HAT = 1e-3


def _box(name, position, size=0.1, mass=1.0, velocity=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)):
    return {'name': name, 'mass': mass, 'shape': {'box': [size] * 3},
            'position': list(position), 'orientation': {'rpy': list(rpy)},
            'collision': 'shape', 'linear_velocity': list(velocity)}


def _scene(bodies, gravity=(0.0, 0.0, 0.0), ground=False, **solver) -> Scene:
    spec = {'dt': 0.01, 'gravity': list(gravity), 'contact': {'d_hat': D_HAT},
            'solver': solver, 'bodies': bodies}
    if ground:
        spec['ground'] = {'height': 0.0}
    return Scene.from_dict(spec)


@pytest.mark.parametrize('spin', [0.0, 0.4])
def test_a_free_collision_conserves_momentum_and_never_interpenetrates(spin):
    """Two boxes (1 kg at 1 m/s, 2 kg at −0.5 m/s, offset 3 cm so they turn) collide in zero
    gravity: Σ m v stays at its initial value to Newton's tolerance, every step's boxes are
    apart by the separating-axis test, and the impact is close to inelastic as the default
    contact's are (docs/physics.md#impacts): along x they part at less than a fifth of the
    1.5 m/s they met at (0.41–0.83 of it before impacts were taken by BDF1)."""
    scene = _scene([_box('a', (-0.2, 0.0, 0.0), velocity=(1.0, 0.0, 0.0), rpy=(0.0, spin, 0.0)),
                    _box('b', (0.2, 0.0, 0.03), mass=2.0, velocity=(-0.5, 0.0, 0.0))],
                   newton_tol=1e-6)
    sim = Stepper(scene)
    mass = np.array([1.0, 2.0])
    start = (mass[:, None] * sim.body_qdot[:, :3]).sum(axis=0)
    touched, drift = False, 0.0
    for _ in range(50):
        sim.step()
        q = sim.body_q
        assert separation(q[0], q[1], [0.05] * 3, [0.05] * 3) > 0.0
        touched |= sim.stats['contacts'] > 0
        drift = max(drift, np.abs((mass[:, None] * sim.body_qdot[:, :3]).sum(axis=0)
                                  - start).max())
    assert touched
    assert drift < 1e-5                     # 1.5 kg·m/s of momentum exchanged
    assert abs(sim.body_qdot[1, 0] - sim.body_qdot[0, 0]) < 0.2 * 1.5


def test_three_stacked_boxes_stand():
    """Three 0.1 m boxes stacked on the ground (0.5 mm apart) settle and stand for 3 s:
    every gap stays positive and the top box drifts less than 1 mm."""
    bodies = [_box(f'box{k}', (0.0, 0.0, 0.05 + k * 0.1005 + 0.0005)) for k in range(3)]
    sim = Stepper(_scene(bodies, gravity=(0.0, 0.0, -9.81), ground=True))
    for _ in range(300):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        q = sim.body_q
        for k in range(2):
            assert separation(q[k], q[k + 1], [0.05] * 3, [0.05] * 3) > 0.0
    top = sim.body_q[2]
    assert np.hypot(top[0], top[1]) < 1e-3
    assert top[2] == pytest.approx(0.25, abs=3 * D_HAT)
    assert sim.stats['inner_iterations'] >= 0 and sim.stats['converged']


def _pair_scene(rpy_top):
    """A box 0.5 mm above another, turned ``rpy_top``: point–face pairs for a flat top, edge
    pairs for a crossed one."""
    return _scene([_box('low', (0.0, 0.0, 0.0)),
                   _box('top', (0.01, -0.005, 0.1 + 0.0005 + _lift(rpy_top)), rpy=rpy_top)])


def _lift(rpy) -> float:
    """How much higher a 0.1 m box turned by ``rpy`` reaches below its centre than 0.05 m."""
    rotation = Stages(Scene.from_dict({'bodies': [_box('x', (0, 0, 0), rpy=rpy)]})) \
        .host.body_q0[0, 3:].reshape(3, 3)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return float(-(signs * 0.05 @ rotation.T)[:, 2].min() - 0.05)


@pytest.mark.parametrize('case', ['face on face', 'edge across edge'])
def test_gradients_of_two_bodies_match_finite_differences(case):
    rpy = (0.0, 0.0, 0.3) if case == 'face on face' else (math.pi / 4, 0.0, 0.0)
    scene = _pair_scene(rpy)
    if case == 'edge across edge':      # the lower box on an edge too, crossing the top's
        scene = _scene([_box('low', (0.0, 0.0, 0.0), rpy=(0.0, math.pi / 4, 0.0)),
                        _box('top', (0.0, 0.0, 2 * 0.05 * math.sqrt(2.0) + 0.0005),
                             rpy=(math.pi / 4, 0.0, 0.0))])
    with_contact, without = Stages(scene), Stages(scene.model_copy(update={'contact': None}))
    q = with_contact.host.body_q0.copy()
    q_tilde = q + 1e-4
    for stages in (with_contact, without):
        stages.scratch.q_n.assign(q[None])
    families = {pair_gap(vars(with_contact.host), q, int(p)).static is None
                for p in near_pairs(vars(with_contact.host), q, D_HAT)}
    assert families == {True}
    step = 1e-7

    def gradient_at(x):
        return with_contact.newton_system(x, q_tilde)[0] - without.newton_system(x, q_tilde)[0]

    def energy_at(x):
        return with_contact.energy(x, q_tilde) - without.energy(x, q_tilde)

    gradient = gradient_at(q)
    hessian = with_contact.newton_system(q, q_tilde)[1] - without.newton_system(q, q_tilde)[1]
    fd = np.zeros(24)
    for i in range(24):
        e = np.zeros_like(q)
        e[i // 12, i % 12] = step
        fd[i] = (energy_at(q + e) - energy_at(q - e)) / (2 * step)
    assert np.abs(fd).max() > 1e-4                # the barrier is active
    assert_matches_differences(gradient, fd)
    np.testing.assert_allclose(gradient[:3], -gradient[12:15], rtol=1e-9,
                               atol=1e-12 * np.abs(gradient).max())   # action = reaction
    assert_psd(hessian)
    assert np.abs(hessian[:12, 12:]).max() > 0.0     # the two bodies' blocks are coupled


def test_the_coupled_solve_agrees_with_a_dense_solve():
    """Small scenes of touching boxes at random states near contact, the Newton direction
    against the dense solve of the assembled system: stacks of two and three (their contacts
    form a chain, which the forest factors exactly: no conjugate-gradient iteration) and a box
    lying across two that touch each other (a cycle: one contact is left to the iterations)."""
    rng = np.random.default_rng(7)
    for trial in range(4):
        if trial < 2:
            bodies = [_box(f'b{k}', (rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01),
                                     k * (0.1 + 0.0004)), rpy=(0.0, 0.0, rng.uniform(-0.3, 0.3)))
                      for k in range(2 + trial)]
        else:
            bodies = [_box('left', (-0.0502, 0.0, 0.0)), _box('right', (0.0502, 0.0, 0.0)),
                      _box('top', (rng.uniform(-0.01, 0.01), 0.0, 0.1004),
                           rpy=(0.0, 0.0, rng.uniform(-0.3, 0.3)))]
        stages = Stages(_scene(bodies, gravity=(0.0, 0.0, -9.81)))
        q = stages.host.body_q0.copy()
        stages.scratch.q_n.assign(q[None])
        gradient, hessian, dq = stages.newton_system(q, q + rng.normal(0.0, 1e-4, q.shape))
        assert (stages.inner_iterations > 0) == (trial >= 2)
        dense = np.linalg.solve(hessian, -gradient)
        np.testing.assert_allclose(dq, dense, rtol=0.0, atol=1e-5 * np.abs(dense).max())


@pytest.mark.parametrize('case', ['face', 'edge'])
def test_the_step_bound_of_two_bodies_stops_short_of_the_analytic_impact(case):
    """Two boxes approach head-on, each at 0.05 m per unit step (the gap closes at 0.1): it
    reaches η d₀ at α = (1 − η) d₀ / 0.1; conservative advancement stops between there and
    where the gap is 2 η d₀, and every gap along the way keeps η d₀."""
    if case == 'face':
        scene = _scene([_box('a', (0.0, 0.0, 0.0)), _box('b', (0.0, 0.0, 0.104))])
        gap = 0.004
    else:
        scene = _scene([_box('a', (0.0, 0.0, 0.0), rpy=(0.0, math.pi / 4, 0.0)),
                        _box('b', (0.0, 0.0, 0.1 * math.sqrt(2.0) + 0.004),
                             rpy=(math.pi / 4, 0.0, 0.0))])
        gap = 0.004
    stages = Stages(scene)
    model = vars(stages.host)
    q = stages.host.body_q0.copy()
    stages.scratch.q_n.assign(q[None])
    dq = np.zeros_like(q)
    dq[0, 2], dq[1, 2] = 0.05, -0.05

    def nearest(alpha):
        x = q + alpha * dq
        return min(pair_gap(model, x, int(p)).distance for p in near_pairs(model, x, 0.01))

    assert nearest(0.0) == pytest.approx(gap)
    alpha = stages.step_bound(q, dq)
    assert (1.0 - 0.2) * gap / 0.1 - 1e-12 <= alpha <= (1.0 - 0.1) * gap / 0.1 + 1e-12
    assert min(nearest(a) for a in np.linspace(0.0, alpha, 40)) >= 0.1 * gap - 1e-12


def test_two_bodies_starting_inside_each_other_are_refused():
    with pytest.raises(SceneError, match=r"body '[ab]' starts 0\.01 m inside body '[ab]'"):
        Stepper(_scene([_box('a', (0.0, 0.0, 0.0)), _box('b', (0.02, 0.01, 0.09))]))


@pytest.mark.parametrize('force, lifted', [(1.5, True), (0.8, False)])
def test_a_gripper_lifts_a_box_only_when_friction_can_carry_it(force, lifted):
    """Squeezed with F by each finger, the box is carried up 5 cm with the hand when
    2 μ F > m g (1.5 N against 0.98 N) and slips out, staying on the ground, when
    2 μ F < m g (0.8 N); the fingers and the box never interpenetrate (separating axes)
    either way."""
    sim = Stepper(Scene.from_dict(gripper_scene(force, dt=0.005)))
    start = sim.body_q[4, 2]
    for k in range(200):
        sim.set_target('lift', lift_target(k * sim.dt))
        sim.step()
        q = sim.body_q
        assert sim.stats['min_distance'] > 0.0
        for f in (2, 3):
            assert separation(q[f], q[4], [0.005, 0.015, 0.015], [0.02] * 3) > 0.0
    rise = sim.body_q[4, 2] - start
    if lifted:
        assert rise == pytest.approx(0.05, abs=3e-3)
    else:
        assert abs(rise) < 1e-3


def test_thrown_bricks_never_interpenetrate():
    """Four bricks (0.1 × 0.05 × 0.03 m) thrown at each other with random velocities and
    spins above the ground: at every step every two are apart by the separating-axis test
    and all are above the ground."""
    rng = np.random.default_rng(3)
    half = np.array([0.05, 0.025, 0.015])
    bodies = [{'name': f'brick{k}', 'mass': 0.4, 'shape': {'box': list(2.0 * half)},
               'position': [0.25 * math.cos(k * math.pi / 2), 0.25 * math.sin(k * math.pi / 2),
                            0.1 + 0.05 * k],
               'orientation': {'rpy': list(rng.uniform(-math.pi, math.pi, 3))},
               'collision': 'shape',
               'linear_velocity': list(-2.0 * np.array([math.cos(k * math.pi / 2),
                                                         math.sin(k * math.pi / 2), 0.0])
                                       + rng.uniform(-0.3, 0.3, 3)),
               'angular_velocity': list(rng.uniform(-5.0, 5.0, 3))} for k in range(4)]
    sim = Stepper(_scene(bodies, gravity=(0.0, 0.0, -9.81), ground=True))
    bumped = set()
    for _ in range(100):
        sim.step()
        q = sim.body_q
        for a in range(4):
            for b in range(a + 1, 4):
                assert separation(q[a], q[b], half, half) > 0.0
        assert sim.stats['min_distance'] > 0.0
        bumped |= {(c['body'], c['other']) for c in sim.contacts if c['other'] != 'ground'}
    assert len(bumped) >= 2                 # bricks hit each other


@pytest.mark.parametrize('slip', [4e-6, 4e-5])
def test_friction_between_two_bodies_matches_finite_differences(slip):
    """Lagged friction between a box resting on another, the top one slid by ``slip`` [m]
    since the step's start (below and beyond ε_v dt = 1e-5 m): its gradient over both bodies
    against central differences of the energy, equal and opposite on the two, and its
    Hessian symmetric PSD with the two bodies' blocks coupled."""
    scene = _scene([_box('low', (0.0, 0.0, 0.0)), _box('top', (0.0, 0.0, 0.1005))])
    with_contact, without = Stages(scene), Stages(scene.model_copy(update={'contact': None}))
    q_n = with_contact.host.body_q0.copy()
    q = q_n.copy()
    q[1, :2] += slip * np.array([0.6, 0.8])
    q_tilde = q + 1e-4
    for stages in (with_contact, without):
        stages.scratch.q_n.assign(q_n[None])
    with_contact.scratch.friction_normal.fill_(1e-3)      # dt² λ on every pair [N·s²]

    def friction_gradient(x):
        return with_contact.newton_system(x, q_tilde)[0] - without.newton_system(x, q_tilde)[0]

    def energy(x):
        return with_contact.energy(x, q_tilde) - without.energy(x, q_tilde)

    step = 1e-8
    fd = np.zeros(24)
    for i in range(24):
        e = np.zeros_like(q)
        e[i // 12, i % 12] = step
        fd[i] = (energy(q + e) - energy(q - e)) / (2 * step)
    gradient = friction_gradient(q)
    assert np.abs(gradient[:2]).max() > 1e-4            # friction acts along the slip
    assert_matches_differences(gradient, fd, rtol=1e-4, atol_share=1e-5)
    np.testing.assert_allclose(gradient[:3], -gradient[12:15], atol=1e-9 * np.abs(gradient).max())
    hessian = with_contact.newton_system(q, q_tilde)[1] - without.newton_system(q, q_tilde)[1]
    assert_psd(hessian)
    assert np.abs(hessian[:12, 12:]).max() > 0.0


def test_a_contact_sensor_feels_the_box_resting_on_its_body():
    """Contact sensors on two stacked 1 kg boxes at rest: the lower one feels the ground's
    push (both weights up) and the upper box pushing down (one weight), so it reads its own
    weight, m g up; the upper one reads m g too."""
    spec = stack_scene(2)
    spec['sensors'] = [{'name': 'low', 'type': 'contact', 'body': 'box0'},
                       {'name': 'top', 'type': 'contact', 'body': 'box1'}]
    sim = Stepper(Scene.from_dict(spec))
    for _ in range(200):
        sim.step()
    weight = np.array([0.0, 0.0, 9.81])
    for name in ('low', 'top'):
        np.testing.assert_allclose(sim.sensors[name]['force'], weight, rtol=1e-4, atol=1e-6)
