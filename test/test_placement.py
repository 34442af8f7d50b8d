"""Placing a free body between steps (Stepper.set_body_state, placement): a placed body goes
on exactly as a scene that starts it there (BDF1), and as the ballistic closed form (BDF2,
restarted by a BDF1 step);
a body's lagged contact forces go with the old pose; refusals leave the state untouched."""

from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim.rotations import rpy_matrix
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
G = np.array([0.0, 0.0, -9.81])
RPY = [0.3, -0.2, 0.5]
V, W = np.array([0.4, -0.3, 1.5]), np.array([1.0, -2.0, 0.5])


def _scene(integrator, position=(0.0, 0.0, 0.052), **start):
    """A box resting near the ground with friction beside a fixed post."""
    return Scene.from_dict({
        'dt': 0.005, 'solver': {'integrator': integrator}, 'ground': {'height': 0.0},
        'contact': {'friction': 0.5},
        'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0,
                    'position': list(position), 'collision': 'shape', **start},
                   {'name': 'post', 'fixed': True, 'mass': 1.0,
                    'shape': {'box': [0.1, 0.1, 1.0]}, 'position': [0.5, 0.0, 0.5],
                    'collision': 'shape'}]})


def _pose(position, rpy=RPY):
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rpy_matrix(*rpy), position
    return pose


def test_a_placed_body_goes_on_as_a_scene_that_starts_it_there():
    placed = Stepper(_scene('bdf1'))
    for _ in range(20):                         # settled on the ground, friction lagged
        placed.step()
    assert placed.contacts
    placed.set_body_state('box', _pose([0.0, -0.2, 1.0]), V, W)
    assert placed.contacts == []                # the old pose's lagged forces went with it
    np.testing.assert_allclose(placed.link_transforms[0], _pose([0.0, -0.2, 1.0]), atol=1e-15)
    started = Stepper(_scene('bdf1', (0.0, -0.2, 1.0), orientation={'rpy': RPY},
                             linear_velocity=V.tolist(), angular_velocity=W.tolist()))
    np.testing.assert_allclose(placed.body_q[0], started.body_q[0], atol=1e-15)
    np.testing.assert_allclose(placed.body_qdot[0], started.body_qdot[0], atol=1e-14)
    for _ in range(40):
        placed.step()
        started.step()
        np.testing.assert_allclose(placed.body_q[0], started.body_q[0], rtol=0, atol=1e-12)
    assert placed.time == pytest.approx(0.3)     # the clock went on


def test_a_placed_body_flies_the_ballistic_arc_under_bdf2():
    sim = Stepper(_scene('bdf2'))
    for _ in range(10):
        sim.step()
    start = np.array([0.0, 0.0, 2.0])
    sim.set_body_state('box', _pose(start), V, np.zeros(3))
    for n in range(1, 61):
        sim.step()
        t = n * sim.dt
        # a BDF1 step (½ g dt² off), then BDF2, exact for a parabola, keeps that error
        # bounded: ¾ g dt² at most
        np.testing.assert_allclose(sim.body_q[0][:3], start + V * t + 0.5 * G * t * t,
                                   rtol=0, atol=0.76 * 9.81 * sim.dt ** 2)
        np.testing.assert_allclose(sim.body_q[0][3:], _pose(start)[:3, :3].reshape(9),
                                   atol=1e-9)


def test_a_placed_urdf_object_is_where_its_frame_was_asked_to_be():
    sim = Stepper(SCENES / 'grasp.yaml')
    sim.step()
    cube = sim.link_names.index('cube')
    pose = _pose([0.3, 0.25, 0.5])
    sim.set_body_state('cube', pose, V, W)
    np.testing.assert_allclose(sim.link_transforms[cube], pose, atol=1e-12)
    sim.step()
    assert sim.stats['converged']


@pytest.mark.parametrize('name, pose, match, error', [
    ('post', _pose([1.0, 0.0, 0.5]), "body 'post' is fixed", ValueError),
    ('nothing', _pose([0.0, 0.0, 1.0]), "nothing", KeyError),
    ('box', _pose([0.0, 0.0, 0.03]), r"body 'box' would be 0\.0\d+ m inside ground", SceneError),
    ('box', _pose([0.48, 0.0, 0.5]), r"body 'box' would be .* inside post", SceneError),
    ('box', np.diag([1.0, 1.0, 2.0, 1.0]), 'not a rotation', ValueError),
])
def test_a_refused_placement_names_why_and_changes_nothing(name, pose, match, error):
    sim = Stepper(_scene('bdf2'))
    sim.step()
    before = sim.body_q, sim.body_qdot, sim.contacts
    with pytest.raises(error, match=match):
        sim.set_body_state(name, pose)
    np.testing.assert_array_equal(sim.body_q, before[0])
    np.testing.assert_array_equal(sim.body_qdot, before[1])
    assert sim.contacts == before[2]


def test_a_jointed_body_is_refused_with_its_joints():
    sim = Stepper(SCENES / 'pendulum.yaml')
    name = sim.body_names[-1]
    with pytest.raises(ValueError, match=rf"body '{name}' is in joints '.*': only a free body"):
        sim.set_body_state(name, _pose([0.0, 0.0, 1.0]))
