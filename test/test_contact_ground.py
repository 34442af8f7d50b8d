"""Contact with ground half-spaces (physics.contact.terms): the barrier's gradient and Hessian
against finite differences, the resting distance against the closed-form equilibrium of the
barrier (the numbers of libuipc's defaults), a drop that never penetrates and obeys energy,
and the scene checks."""

import math
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.rotations import rpy_matrix
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.barrier import (assert_matches_differences, assert_psd, contact_terms,
                             resting_distance)

G = 9.81
SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'


def _box_scene(height=0.2, d_hat=0.01, kappa=1.0e9, ground=None, dt=0.01, **extra):
    return Scene.from_dict({
        'dt': dt, 'solver': {'integrator': 'bdf1'},
        'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0,
                    'position': [0.0, 0.0, height], 'collision': 'shape', **extra}],
        'ground': ground or {'height': 0.0},
        'contact': {'d_hat': d_hat, 'kappa': kappa}})


def test_the_resting_distance_oracle_reproduces_the_published_numbers():
    # 1 kg on 4 corners, κ 1e9, d̂ 1 cm: 9.8986e-3 m; 10 such boxes stacked: 9.6769e-3 m
    assert resting_distance(G / 4, 0.01, 1e9) == pytest.approx(9.8986e-3, abs=1e-7)
    assert resting_distance(10 * G / 4, 0.01, 1e9) == pytest.approx(9.6769e-3, abs=1e-7)


@pytest.mark.parametrize('d_hat, kappa', [(0.01, 1e9), (0.001, 1e9), (0.01, 1e8)])
def test_a_box_comes_to_rest_at_the_barrier_equilibrium_and_never_touches(d_hat, kappa):
    sim = Stepper(_box_scene(0.1, d_hat, kappa))
    nearest = []
    for _ in range(300):
        sim.step()
        nearest.append(sim.stats['min_distance'])
        assert sim.stats['converged']
    expected = resting_distance(G / 4, d_hat, kappa)
    assert min(nearest) > 0.0
    assert sim.stats['contacts'] == 4
    assert sim.stats['min_distance'] == pytest.approx(expected, abs=1e-6)
    assert abs(sim.body_qdot[0][2]) < 1e-6


def test_a_sphere_rests_on_its_single_point_at_the_equilibrium_of_its_whole_weight():
    scene = Scene.from_dict({
        'dt': 0.01, 'bodies': [{'name': 'ball', 'shape': {'sphere': {'radius': 0.05}},
                                'mass': 2.0, 'position': [0.0, 0.0, 0.08],
                                'collision': 'shape'}],
        'ground': {'height': -0.01}, 'contact': {'d_hat': 0.005}})
    sim = Stepper(scene)
    for _ in range(300):
        sim.step()
    expected = resting_distance(2.0 * G, 0.005, 1e9)
    assert sim.stats['contacts'] == 1
    assert sim.body_q[0][2] == pytest.approx(-0.01 + 0.05 + expected, abs=1e-6)


def test_a_drop_never_penetrates_and_never_outruns_free_fall():
    drop = 0.5
    sim = Stepper(_box_scene(0.05 + drop, dt=0.005))
    fastest = 0.0
    for _ in range(400):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        fastest = max(fastest, -sim.body_qdot[0][2])
    assert sim.stats['contacts'] == 4
    assert fastest <= math.sqrt(2.0 * G * drop)


def test_a_tilted_half_space_holds_a_box_creeping_down_it():
    tilt = math.radians(20.0)
    normal = [math.sin(tilt), 0.0, math.cos(tilt)]
    scene = _box_scene(0.2, ground={'point': [0.0, 0.0, 0.0], 'normal': normal},
                       orientation={'rpy': [0.0, tilt, 0.0]})
    sim = Stepper(scene)
    for _ in range(200):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
    assert sim.stats['contacts'] == 4
    # μ 0.5 > tan 20°: it creeps down the slope (its normal's x side), never into it
    velocity = sim.body_qdot[0][:3]
    along = velocity @ np.array([math.cos(tilt), 0.0, -math.sin(tilt)])
    assert along > 0.0 and abs(velocity @ np.array(normal)) < 1e-3


def _near_ground_state(scene, rng):
    """A state of the box with every corner between 0.2 d̂ and 0.9 d̂ above the ground."""
    q = np.zeros((1, 12))
    tilt = 0.02 * rng.normal(size=3)
    a = rpy_matrix(*tilt) @ (np.eye(3) + 1e-4 * rng.normal(size=(3, 3)))
    q[0, 3:] = a.reshape(9)
    corners = np.array([[sx, sy, sz] for sx in (-0.05, 0.05) for sy in (-0.05, 0.05)
                        for sz in (-0.05, 0.05)])
    lowest = (corners @ a.T)[:, 2].min()
    q[0, :3] = [0.01, -0.02, -lowest + 0.005]
    return q


def test_the_barrier_gradient_and_hessian_match_finite_differences():
    rng = np.random.default_rng(3)
    scene = _box_scene()
    with_contact, without = Stages(scene), Stages(scene.model_copy(
        update={'ground': None, 'contact': None}))
    q = _near_ground_state(scene, rng)
    q_tilde = q + 1e-3 * rng.normal(size=q.shape)
    gradient, hessian, fd_gradient, fd_hessian = contact_terms(with_contact, without, q,
                                                                q_tilde, step=1e-8)
    assert np.abs(fd_gradient).max() > 0.0
    assert_matches_differences(gradient, fd_gradient)
    assert_matches_differences(hessian, fd_hessian)
    assert_psd(hessian)


def test_a_penetrating_state_has_infinite_energy():
    stages = Stages(_box_scene())
    q = _near_ground_state(_box_scene(), np.random.default_rng(4))
    q[0, 2] -= 0.02
    assert stages.energy(q, q) == math.inf


def test_a_scene_that_starts_touching_is_refused_naming_the_body_and_the_distance():
    with pytest.raises(SceneError, match=r"body 'box' starts 0\.01 m inside ground"):
        Stepper(_box_scene(0.04))


def test_a_scene_without_contact_reports_no_contact_statistics():
    scene = Scene.from_dict({'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]},
                                         'mass': 1.0, 'collision': 'shape'}]})
    sim = Stepper(scene)
    sim.step()
    assert 'min_distance' not in sim.stats and 'contact' not in sim.stats['active_terms']


def test_collision_geometry_becomes_contact_points_in_the_body_frame():
    from affine_joint_sim.physics.host.model import build_model
    scene = Scene.from_dict({
        'bodies': [{'name': 'base', 'fixed': True, 'mass': 1.0},
                   {'name': 'tool', 'shape': {'box': [0.2, 0.1, 0.1]}, 'mass': 1.0,
                    'position': [0.0, 0.0, 0.5],
                    'collision': [{'box': [0.2, 0.1, 0.1]},
                                  {'sphere': {'radius': 0.03},
                                   'origin': {'xyz': [0.1, 0.0, 0.0]}},
                                  {'capsule': {'radius': 0.01, 'length': 0.2},
                                   'origin': {'xyz': [0.0, 0.0, -0.05],
                                              'rpy': [0.0, math.pi / 2, 0.0]}}]}],
        'ground': [{'height': 0.0}, {'point': [1.0, 0.0, 0.0], 'normal': [-2.0, 0.0, 0.0]}]})
    host = build_model(scene)
    assert list(host.point_body) == [1] * 11
    np.testing.assert_allclose(np.abs(host.point_rest[:8]), [[0.1, 0.05, 0.05]] * 8)
    np.testing.assert_allclose(host.point_rest[8], [0.1, 0.0, 0.0])
    # the capsule's axis (its z) turned onto x: centres at ±0.1 m along x
    np.testing.assert_allclose(host.point_rest[9:], [[-0.1, 0.0, -0.05], [0.1, 0.0, -0.05]],
                               atol=1e-12)
    np.testing.assert_allclose(host.point_radius, [0.0] * 8 + [0.03, 0.01, 0.01])
    np.testing.assert_allclose(host.plane_normal, [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    np.testing.assert_allclose(host.plane_offset, [0.0, -1.0])


def _incline_run(mu, tilt_deg=20.0, steps=300):
    """(Along-slope speeds [m/s] of a 1 kg box on a tilted half-space (BDF1, dt 0.01,
    d̂ 1 cm, ε_v 1 cm/s) every step, the Stepper at the end)."""
    tilt = math.radians(tilt_deg)
    scene = _box_scene(0.2, ground={'point': [0.0, 0.0, 0.0],
                                    'normal': [math.sin(tilt), 0.0, math.cos(tilt)]},
                       orientation={'rpy': [0.0, tilt, 0.0]})
    scene = scene.model_copy(update={'contact': scene.contact.model_copy(
        update={'friction': mu, 'eps_velocity': 0.01})})
    sim = Stepper(scene)
    down = np.array([math.cos(tilt), 0.0, -math.sin(tilt)])
    speeds = []
    for _ in range(steps):
        sim.step()
        assert sim.stats['converged'] and sim.stats['min_distance'] > 0.0
        speeds.append(sim.body_qdot[0][:3] @ down)
    return np.array(speeds), sim


def test_a_box_that_sticks_on_an_incline_creeps_at_the_smoothed_friction_speed():
    # tan 20° < μ = 0.5: smoothed friction creeps at ε_v (1 − √(1 − tan α / μ)) = 4.78 mm/s
    speeds, _ = _incline_run(0.5)
    expected = 0.01 * (1.0 - math.sqrt(1.0 - math.tan(math.radians(20.0)) / 0.5))
    np.testing.assert_allclose(speeds[-100:], expected, rtol=1e-3)   # within Newton's tolerance


def test_contacts_report_the_normal_and_friction_forces_that_hold_a_creeping_box():
    speeds, sim = _incline_run(0.5)         # creeping at a steady speed: forces balance
    tilt = math.radians(20.0)
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    contacts = sim.contacts
    assert len(contacts) == 4 == sim.stats['contacts']
    assert {(c['body'], c['other']) for c in contacts} == {('box', 'ground')}
    total = sum(c['normal_force'] * c['normal'] + c['friction_force'] for c in contacts)
    np.testing.assert_allclose(total, [0.0, 0.0, G], atol=1e-4 * G)     # holds its weight
    friction = sum(c['friction_force'] for c in contacts)
    assert friction @ normal == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(friction) == pytest.approx(G * math.sin(tilt), rel=1e-4)
    for c in contacts:
        np.testing.assert_allclose(c['normal'], normal)
        assert c['point'] @ normal == pytest.approx(0.0, abs=1e-12)      # on the ground
        assert 0.0 < c['distance'] < 0.01


def test_a_box_that_slips_on_an_incline_accelerates_at_g_sin_minus_mu_g_cos():
    speeds, _ = _incline_run(0.2)
    tilt = math.radians(20.0)
    acceleration = np.diff(speeds[-100:]) / 0.01
    np.testing.assert_allclose(acceleration, G * (math.sin(tilt) - 0.2 * math.cos(tilt)),
                               rtol=1e-4)


def test_contact_damping_ends_a_bounce_that_the_bare_barrier_keeps():
    """BDF2 barely damps a stiff barrier: a box dropped 2 mm at dt 1 ms still bounced after
    a second (its gap ranging over 1.2 mm) before contact damping (ζ = 1, the default)."""
    spreads = {}
    for damping in (1.0, 0.0):
        scene = Scene.from_dict({
            'dt': 1e-3, 'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]},
                                    'mass': 1.0, 'position': [0.0, 0.0, 0.052],
                                    'collision': 'shape'}],
            'ground': {'height': 0.0}, 'contact': {'damping': damping}})
        sim = Stepper(scene)
        gaps = []
        for _ in range(1000):
            sim.step()
            gaps.append(sim.stats['min_distance'])
        spreads[damping] = max(gaps[500:]) - min(gaps[500:])
        assert min(gaps) > 0.0
    assert spreads[1.0] < 1e-6 and spreads[0.0] > 1e-4


def test_a_solid_ball_rolls_down_an_incline_at_five_sevenths_g_sin_alpha():
    """Friction acts where the ball touches, r below its centre: it turns the ball (before,
    at the centre, the ball crept down without turning). BDF2 (the default): BDF1 damps a
    fast spin (its rotation is slowed by about (ω dt)² a step), which friction then drags."""
    tilt, radius, dt = math.radians(20.0), 0.05, 0.002
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    scene = Scene.from_dict({
        'dt': dt, 'bodies': [{'name': 'ball', 'shape': {'sphere': {'radius': radius}},
                              'mass': 1.0, 'position': list((radius + 5e-4) * normal),
                              'collision': 'shape'}],
        'ground': {'point': [0.0, 0.0, 0.0], 'normal': list(normal)},
        'contact': {'friction': 0.5}})
    sim = Stepper(scene)
    down = np.array([math.cos(tilt), 0.0, -math.sin(tilt)])
    speeds, spins = [], []
    for _ in range(250):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        speeds.append(sim.body_qdot[0][:3] @ down)
        a, a_dot = sim.body_q[0][3:].reshape(3, 3), sim.body_qdot[0][3:].reshape(3, 3)
        spins.append((a_dot @ a.T)[0, 2])       # ω_y of [ω]× = Ȧ Aᵀ: rolling down x
    acceleration = (speeds[-1] - speeds[124]) / (125 * dt)
    assert acceleration == pytest.approx(5.0 / 7.0 * G * math.sin(tilt), rel=0.04)
    assert spins[-1] * radius == pytest.approx(speeds[-1], rel=0.04)       # rolls: ω r = v


def test_a_sliding_box_stops_within_the_coulomb_stopping_distance():
    # BDF1 at dt h from v0 under μ g: d = Σ_k h (v0 − k μ g h), 0.4997 m for v0 2, μ 0.4, h 0.01
    rest = resting_distance(G / 4, 0.01, 1e9)
    scene = _box_scene(0.05 + rest, linear_velocity=[2.0, 0.0, 0.0])
    scene = scene.model_copy(update={'contact': scene.contact.model_copy(
        update={'friction': 0.4})})
    sim = Stepper(scene)
    for _ in range(100):
        sim.step()
    h, v0, mu = 0.01, 2.0, 0.4
    steps = int(v0 / (mu * G * h))
    expected = sum(h * (v0 - k * mu * G * h) for k in range(1, steps + 1))
    assert sim.body_q[0][0] == pytest.approx(expected, rel=5e-3)
    assert abs(sim.body_qdot[0][0]) < 1e-3


def test_a_damped_box_stops_at_v0_squared_over_2_mu_g_under_bdf2():
    """Friction's lagged normal force includes the damper's share of the load: without it the
    box slid 1.2 % too far (friction pitches it forward at the start, and the damper carried
    part of the front corners' load unseen by friction)."""
    rest = resting_distance(G / 4, 1e-3, 1e9)
    scene = Scene.from_dict({
        'dt': 1e-3, 'ground': {'height': 0.0}, 'contact': {'friction': 0.4},
        'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0,
                    'position': [0.0, 0.0, 0.05 + rest], 'linear_velocity': [2.0, 0.0, 0.0],
                    'collision': 'shape'}]})
    sim = Stepper(scene)
    for _ in range(1000):
        sim.step()
    assert abs(sim.body_qdot[0][0]) < 1e-3
    assert sim.body_q[0][0] == pytest.approx(2.0 ** 2 / (2 * 0.4 * G), rel=1e-3)


def test_two_surfaces_combine_their_friction_by_the_harmonic_mean():
    from affine_joint_sim.physics.contact.model import combined_friction
    assert combined_friction(0.5, 0.5) == 0.5
    assert combined_friction(1.0, 0.05) == pytest.approx(2 * 0.05 / 1.05)
    assert combined_friction(0.0, 0.8) == 0.0 and combined_friction(0.0, 0.0) == 0.0


def _ball_scene():
    return Scene.from_dict({
        'dt': 0.01, 'solver': {'integrator': 'bdf1'},
        'bodies': [{'name': 'ball', 'shape': {'sphere': {'radius': 0.05}}, 'mass': 1.0,
                    'position': [0.0, 0.0, 0.2], 'collision': 'shape'}],
        'ground': {'height': 0.0}, 'contact': {'d_hat': 0.01}})


@pytest.mark.parametrize('slip', [2e-5, 3e-3])      # below and beyond ε_v dt = 1e-4 m
@pytest.mark.parametrize('body', ['box', 'ball'])   # 8 corners; 1 centre, friction r below
@pytest.mark.parametrize('release', [1.0, 1e-6])    # m: the damper's quadratic part; its pull
def test_friction_and_damping_gradients_and_hessians_match_finite_differences(slip, body,
                                                                              release):
    rng = np.random.default_rng(5)
    scene = _box_scene() if body == 'box' else _ball_scene()
    with_contact, without = Stages(scene), Stages(scene.model_copy(
        update={'ground': None, 'contact': None}))
    if body == 'box':
        q = _near_ground_state(scene, rng)
    else:
        q = np.zeros((1, 12))
        q[0, :3] = [0.01, -0.02, 0.055]
        q[0, 3:] = rpy_matrix(0.3, -0.2, 0.1).reshape(9)
    start = q.copy()
    start[0, :2] -= slip * np.array([0.6, 0.8])           # where the step started: 0.2 mm
    start[0, 2] += 2e-4                                    # higher, so the damper acts
    start[0, 3:] = (rpy_matrix(0.0, 0.0, 0.01) @ q[0, 3:].reshape(3, 3)).reshape(9)   # turned
    with_contact.scratch.q_n.assign(start[None])
    # a lagged normal force and damping on every point against the plane, as at the step
    # start (the damping's c·dt: its term ½ c dt (d − d_n)² is checked with friction's, and
    # with a release nearer than every pair its pull that cancels the barrier's push)
    with_contact.scratch.friction_normal.fill_(2.5e-4)
    with_contact.scratch.normal_damping.fill_(3.0e-2)
    with_contact.scratch.damping_release.fill_(release)
    q_tilde = q.copy()
    # where the pull cancels the barrier only friction is left, small against the energies'
    # rounding (~1e-17 J): a longer difference step and a rounding share ten times larger
    pulled = release < 0.1
    gradient, hessian, fd_gradient, fd_hessian = contact_terms(
        with_contact, without, q, q_tilde, step=1e-7 if pulled else 1e-8)
    assert_matches_differences(gradient, fd_gradient, atol_share=1e-5 if pulled else 1e-6)
    # IPC's closed forms are the exact Hessian of the smoothed friction, and PSD
    assert_matches_differences(hessian, fd_hessian, rtol=1e-4, atol_share=1e-5)
    assert_psd(hessian)


def test_the_contact_record_keeps_the_smallest_distance_and_the_most_contacts():
    sim = Stepper(_box_scene(0.1))
    assert sim.contact_record == {'min_distance': math.inf, 'most_contacts': 0}
    nearest = math.inf
    for _ in range(100):
        sim.step()
        nearest = min(nearest, sim.stats['min_distance'])
    assert sim.contact_record == {'min_distance': nearest, 'most_contacts': 4}
    sim.reset()                     # the record spans resets, like the problem totals
    assert sim.contact_record['min_distance'] == nearest
    assert Stepper(Scene.load(SCENES / 'pendulum.yaml')).contact_record is None


def test_the_command_line_run_reports_contact_and_refuses_a_touching_scene(tmp_path):
    from helpers.cli import cli
    (tmp_path / 'drop.yaml').write_text(_box_scene(0.1).to_yaml())
    done = cli('run', '--scene', tmp_path / 'drop.yaml', '--mode', 'fast', '--duration', 1.0)
    assert done.returncode == 0, done.stderr
    line = next(s for s in done.stdout.splitlines() if s.startswith('contact:'))
    distance = float(line.split('world ')[1].split(' m')[0])
    assert 0.0 < distance < 0.01 and line.endswith('at most 4 contacts at once')
    (tmp_path / 'touching.yaml').write_text(_box_scene(0.04).to_yaml())
    done = cli('run', '--scene', tmp_path / 'touching.yaml', '--mode', 'fast')
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1
    assert "body 'box' starts 0.01 m inside ground" in done.stderr
