"""Contact with fixed bodies' geometry (static shapes; README.md#contact): the exact distance
to boxes, spheres, capsules and cylinders against the closed forms, the barrier's gradient
against finite differences in every region of each shape, resting on a table at the barrier's
equilibrium, a fast box that cannot pass a thin slab, articulations that do not touch their
own fixed geometry, and the refusal of a scene that starts inside one."""

import math

import numpy as np
import pytest

from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.physics.contact.kinds import BOX, CAPSULE, CYLINDER, SPHERE
from affine_joint_sim.physics.contact.shapes import shape_distance
from affine_joint_sim.rotations import rpy_matrix
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.barrier import (assert_matches_differences, assert_psd, contact_terms,
                             resting_distance)

G = 9.81
D_HAT = 0.01
TABLE = {'name': 'table', 'fixed': True, 'mass': 10.0, 'shape': {'box': [1.0, 1.0, 0.1]},
         'collision': 'shape'}      # its top at z = 0.05


def _scene(fixed: dict, free: dict, **extra) -> Scene:
    return Scene.from_dict({
        'dt': 0.01, 'solver': {'integrator': 'bdf1'}, 'contact': {'d_hat': D_HAT, **extra},
        'bodies': [fixed, {'name': 'thing', 'mass': 1.0, 'collision': 'shape', **free}]})


def test_shape_distances_match_their_closed_forms():
    turn = rpy_matrix(0.3, -0.2, 0.5)
    centre = np.array([0.1, -0.2, 0.3])

    def at(local):
        return centre + turn @ np.asarray(local, float)

    box = (BOX.code, turn, centre, [0.2, 0.1, 0.05])
    assert shape_distance(*box, at([0.3, 0.0, 0.0])) == pytest.approx(0.1)          # face
    assert shape_distance(*box, at([0.3, 0.2, 0.0])) == pytest.approx(math.hypot(0.1, 0.1))
    assert shape_distance(*box, at([0.3, 0.2, 0.1])) == pytest.approx(
        math.sqrt(0.01 + 0.01 + 0.0025))                                          # corner
    assert shape_distance(*box, at([0.0, 0.0, 0.04])) == pytest.approx(-0.01)     # inside
    capsule = (CAPSULE.code, turn, centre, [0.05, 0.2, 0.0])
    assert shape_distance(*capsule, at([0.1, 0.0, 0.1])) == pytest.approx(0.05)
    assert shape_distance(*capsule, at([0.0, 0.0, 0.35])) == pytest.approx(0.1)
    cylinder = (CYLINDER.code, turn, centre, [0.05, 0.2, 0.0])
    assert shape_distance(*cylinder, at([0.0, 0.0, 0.3])) == pytest.approx(0.1)    # end face
    assert shape_distance(*cylinder, at([0.0, 0.08, 0.0])) == pytest.approx(0.03)  # side
    assert shape_distance(*cylinder, at([0.08, 0.0, 0.24])) == pytest.approx(0.05)  # rim
    sphere = (SPHERE.code, turn, centre, [0.05, 0.0, 0.0])
    assert shape_distance(*sphere, at([0.0, 0.06, 0.08])) == pytest.approx(0.05)


# (fixed body, free ball's centre) in each region of each shape: a face, an edge and a corner
# of a box, a sphere, a capsule's side and cap, a cylinder's side, end and rim; every ball
# 0.4–0.9 d̂ from the surface
REGIONS = {
    'box face': ({'box': [0.4, 0.4, 0.1]}, [0.05, 0.1, 0.05 + 0.02 + 0.006]),
    'box edge': ({'box': [0.4, 0.4, 0.1]}, [0.2 + 0.015, 0.0, 0.05 + 0.015]),
    'box corner': ({'box': [0.4, 0.4, 0.1]}, [0.2 + 0.013, 0.2 + 0.013, 0.05 + 0.014]),
    'sphere': ({'sphere': {'radius': 0.1}}, [0.06, 0.05, 0.1]),
    'capsule side': ({'capsule': {'radius': 0.05, 'length': 0.2}}, [0.077, 0.0, 0.05]),
    'capsule cap': ({'capsule': {'radius': 0.05, 'length': 0.2}}, [0.0, 0.03, 0.17]),
    'cylinder side': ({'cylinder': {'radius': 0.05, 'length': 0.2}}, [0.0, 0.077, 0.0]),
    'cylinder end': ({'cylinder': {'radius': 0.05, 'length': 0.2}}, [0.01, 0.0, 0.127]),
    'cylinder rim': ({'cylinder': {'radius': 0.05, 'length': 0.2}}, [0.065, 0.0, 0.115]),
}


@pytest.mark.parametrize('region', REGIONS)
def test_the_barrier_gradient_against_a_shape_matches_finite_differences(region):
    geometry, centre = REGIONS[region]
    fixed = {'name': 'obstacle', 'fixed': True, 'mass': 1.0, 'position': [0.0, 0.0, 0.0],
             'orientation': {'rpy': [0.2, -0.1, 0.3]}, 'collision': [geometry]}
    turn = rpy_matrix(0.2, -0.1, 0.3)
    ball = {'shape': {'sphere': {'radius': 0.02}}, 'position': list(turn @ centre)}
    scene = _scene(fixed, ball)
    scene = scene.model_copy(update={'gravity': (0.0, 0.0, 0.0)})
    with_contact = Stages(scene)
    without = Stages(scene.model_copy(update={'contact': None}))
    q = with_contact.host.body_q0.copy()
    rng = np.random.default_rng(7)
    q[1, 3:] += 1e-3 * rng.normal(size=9)
    gradient, hessian, fd_gradient, fd_hessian = contact_terms(with_contact, without, q,
                                                               q + 1e-4, step=1e-7, row=1)
    assert np.abs(fd_gradient).max() > 1e-3           # the barrier is active
    assert_matches_differences(gradient, fd_gradient)
    assert_psd(hessian)
    if region == 'box face':            # a flat face: the distance is linear, the Hessian exact
        assert_matches_differences(hessian, fd_hessian)


def _rest_box_on(fixed: dict, top: float):
    """A 0.1 m box dropped 2 cm onto ``fixed`` (its top at z = ``top``): it must rest on its
    four corners at the barrier's equilibrium, the contacts holding its weight on that top."""
    sim = Stepper(_scene(fixed, {'shape': {'box': [0.1, 0.1, 0.1]},
                                 'position': [0.1, -0.05, top + 0.07]}))
    for _ in range(300):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
    assert sim.stats['contacts'] == 4
    assert sim.body_q[1][2] == pytest.approx(top + 0.05 + resting_distance(G / 4, D_HAT, 1e9),
                                             abs=1e-6)
    contacts = sim.contacts
    assert {(c['body'], c['other']) for c in contacts} == {('thing', fixed['name'])}
    assert sum(c['normal_force'] for c in contacts) == pytest.approx(G, rel=1e-4)
    assert all(c['point'][2] == pytest.approx(top) for c in contacts)
    return sim


def test_a_box_rests_on_a_table_at_the_barrier_equilibrium():
    _rest_box_on(TABLE, 0.05)


def test_a_ball_rests_on_the_end_of_a_standing_cylinder():
    post = {'name': 'post', 'fixed': True, 'mass': 1.0, 'position': [0.0, 0.0, 0.5],
            'shape': {'cylinder': {'radius': 0.1, 'length': 1.0}}, 'collision': 'shape'}
    sim = Stepper(_scene(post, {'shape': {'sphere': {'radius': 0.05}},
                                'position': [0.02, 0.03, 1.07]}))
    for _ in range(300):
        sim.step()
    assert sim.stats['contacts'] == 1
    assert sim.body_q[1][2] == pytest.approx(1.05 + resting_distance(G, D_HAT, 1e9), abs=1e-6)


def test_a_fast_box_cannot_pass_a_thin_slab():
    """At 20 m/s a step moves the box 0.2 m: its prediction lies beyond the 1 cm slab,
    collision-free there; Newton must not start from it."""
    slab = {'name': 'slab', 'fixed': True, 'mass': 1.0, 'shape': {'box': [1.0, 1.0, 0.01]},
            'collision': 'shape'}
    sim = Stepper(_scene(slab, {'shape': {'box': [0.1, 0.1, 0.1]}, 'position': [0.0, 0.0, 0.3],
                                'linear_velocity': [0.0, 0.0, -20.0]}))
    for _ in range(100):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        assert sim.body_q[1][2] > 0.005 + 0.05
    assert sim.stats['contacts'] == 4 and abs(sim.body_qdot[1][2]) < 1e-3


def _hinged(**contact) -> Scene:
    """A fixed base box and a link hinged to it whose box overlaps the base at the hinge."""
    return Scene.from_dict({
        'gravity': [0.0, 0.0, 0.0], 'contact': contact,
        'bodies': [{'name': 'base', 'fixed': True, 'mass': 1.0, 'shape': {'box': [0.2] * 3},
                    'collision': 'shape'},
                   {'name': 'link', 'mass': 1.0, 'shape': {'box': [0.3, 0.05, 0.05]},
                    'position': [0.2, 0.0, 0.0], 'collision': 'shape'}],
        'joints': [{'name': 'hinge', 'type': 'revolute', 'parent': 'base', 'child': 'link',
                    'x0': [0.1, 0.0, -0.1], 'x1': [0.1, 0.0, 0.1]}]})


def test_an_articulation_does_not_touch_its_own_fixed_geometry_and_others_do():
    Stepper(_hinged()).step()                            # the link starts inside its base
    Stepper(_hinged(self_collision=True)).step()         # jointed to it: never
    intruder = _scene(TABLE, {'shape': {'box': [0.1, 0.1, 0.1]}, 'position': [0.0, 0.0, 0.08]})
    with pytest.raises(SceneError, match=r"body 'thing' starts 0\.02 m inside table"):
        Stepper(intruder)


def test_after_a_reset_the_contacts_are_those_of_a_fresh_start():
    """Before, reset kept the last step's lagged friction and damping: the ramp's box, 0.5 mm
    from the ramp at t = 0, was reported with a full friction force in some direction."""
    from pathlib import Path
    ramp = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes' / 'ramp.yaml'
    fresh, used = Stepper(Scene.load(ramp)), Stepper(Scene.load(ramp))
    for _ in range(50):
        used.step()
    used.reset()
    before, after = fresh.contacts, used.contacts
    assert len(before) == 4 and len(after) == 4
    for a, b in zip(before, after):
        assert np.array_equal(a['friction_force'], np.zeros(3))
        assert a['normal_force'] == b['normal_force']
        np.testing.assert_array_equal(a['friction_force'], b['friction_force'])


def test_contacts_are_computed_once_per_state():
    """Markers and contact sensors both read sim.contacts each frame: one evaluation serves
    both until the state changes (a reset's fresh contacts: the test above)."""
    sim = Stepper(_scene(TABLE, {'shape': {'box': [0.1, 0.1, 0.1]},
                                'position': [0.0, 0.0, 0.105]}))
    for _ in range(30):
        sim.step()
    first = sim.contacts
    assert len(first) == 4 and sim.contacts is first
    sim.step()
    assert sim.contacts is not first and len(sim.contacts) == 4
    second = sim.contacts
    sim.reset()
    assert sim.contacts is not second


def _write_obj(path, vertices, faces):
    path.write_text(''.join(f'v {float(x)!r} {float(y)!r} {float(z)!r}\n' for x, y, z in vertices)
                    + ''.join(f'f {a + 1} {b + 1} {c + 1}\n' for a, b, c in faces))


def test_a_box_rests_on_a_fixed_mesh_floor_at_the_barrier_equilibrium(tmp_path):
    """Two triangles make a 1 m square floor at z = 0.1 on a fixed body: a static mesh."""
    _write_obj(tmp_path / 'floor.obj', [[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0],
                                        [-0.5, 0.5, 0]], [[0, 1, 2], [0, 2, 3]])
    floor = {'name': 'floor', 'fixed': True, 'mass': 1.0, 'position': [0.0, 0.0, 0.1],
             'collision': [{'mesh': {'uri': str(tmp_path / 'floor.obj')}}]}
    assert _rest_box_on(floor, 0.1)._host.shape_kind.tolist() == [5, 5]


@pytest.mark.parametrize('where', [[0.1, 0.1, 0.026], [0.52, 0.5, 0.015],
                                   [-0.015, -0.017, 0.013]])          # face, edge, vertex
def test_the_barrier_gradient_against_a_triangle_matches_finite_differences(tmp_path, where):
    _write_obj(tmp_path / 'tri.obj', [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    fixed = {'name': 'tri', 'fixed': True, 'mass': 1.0,
             'collision': [{'mesh': {'uri': str(tmp_path / 'tri.obj')}}]}
    scene = _scene(fixed, {'shape': {'sphere': {'radius': 0.02}}, 'position': where})
    scene = scene.model_copy(update={'gravity': (0.0, 0.0, 0.0)})
    with_contact, without = Stages(scene), Stages(scene.model_copy(update={'contact': None}))
    q = with_contact.host.body_q0.copy()
    gradient, hessian, fd_gradient, fd_hessian = contact_terms(with_contact, without, q,
                                                               q + 1e-4, step=1e-7, row=1)
    assert np.abs(fd_gradient).max() > 1e-3
    assert_matches_differences(gradient, fd_gradient)
    assert_psd(hessian)


def test_a_large_static_mesh_is_reduced_with_a_warning_naming_the_body(tmp_path):
    import trimesh

    from affine_joint_sim.physics.contact.mesh import MAX_STATIC_TRIANGLES
    from affine_joint_sim.sim_warnings import SimulationDetail
    rock = trimesh.creation.icosphere(subdivisions=3, radius=0.2)          # 1280 faces
    rock.export(tmp_path / 'rock.stl')
    fixed = {'name': 'rock', 'fixed': True, 'mass': 1.0,
             'collision': [{'mesh': {'uri': str(tmp_path / 'rock.stl')}}]}
    scene = _scene(fixed, {'shape': {'sphere': {'radius': 0.02}}, 'position': [0, 0, 0.3]})
    with pytest.warns(SimulationDetail, match=r"body 'rock' \(collision\[0\]\): collision mesh "
                                               r'.* has 1280 triangles; contact uses'):
        sim = Stepper(scene)
    assert 20 <= len(sim._host.shape_kind) <= MAX_STATIC_TRIANGLES
    touched = 0
    for _ in range(100):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        touched = max(touched, sim.stats['contacts'])
    assert touched >= 1                                 # the ball lands on the rock

