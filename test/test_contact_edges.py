"""Edges and faces against static geometry (README.md#contact): a box's edge across a static
ridge, a box's face on a static spike's corner and a capsule lying across a bar, where no
contact point is near; the edge–edge and vertex–face barrier gradients against finite
differences; conservative advancement against the analytic time of impact; the mollifier of
near-parallel edges; the surfaces' edges and areas; the refusal of a scene whose capsule
starts through a bar."""

import math

import numpy as np
import pytest
import trimesh

from affine_joint_sim.contact_schema import Collision
from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.physics.contact.hull import mesh_hull
from affine_joint_sim.physics.contact.pairs import pair_distances, pair_weight, segment_params
from affine_joint_sim.physics.contact.primitives import (CYLINDER_SEGMENTS, box_surface,
                                                 cylinder_surface, moving_surface)
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.barrier import (assert_matches_differences, assert_psd, contact_terms,
                             resting_distance)

G = 9.81
D_HAT = 0.01
RIDGE_TOP = 0.2 + 0.05 * math.sqrt(2.0)     # the top edge of a 0.1 m square bar turned 45°
RIDGE = {'name': 'ridge', 'fixed': True, 'mass': 1.0, 'shape': {'box': [1.0, 0.1, 0.1]},
         'position': [0.0, 0.0, 0.2], 'orientation': {'rpy': [math.pi / 4, 0.0, 0.0]},
         'collision': 'shape'}
# a cube standing on a corner: its top corner at z = 0.1 + 0.05·√3
SPIKE_TOP = 0.1 + 0.05 * math.sqrt(3.0)
SPIKE = {'name': 'spike', 'fixed': True, 'mass': 1.0, 'shape': {'box': [0.1, 0.1, 0.1]},
         'position': [0.0, 0.0, 0.1],
         'orientation': {'rpy': [math.pi / 4, math.atan(1.0 / math.sqrt(2.0)), 0.0]},
         'collision': 'shape'}
BAR = {'name': 'bar', 'fixed': True, 'mass': 1.0, 'shape': {'box': [0.02, 1.0, 0.02]},
       'position': [0.0, 0.0, 0.2], 'collision': 'shape'}     # its top at z = 0.21


def _scene(fixed: dict, free: dict, gravity=(0.0, 0.0, -G), **solver) -> Scene:
    return Scene.from_dict({
        'dt': 0.01, 'gravity': list(gravity), 'solver': {'integrator': 'bdf1', **solver},
        'contact': {'d_hat': D_HAT},
        'bodies': [fixed, {'name': 'thing', 'mass': 1.0, 'collision': 'shape', **free}]})


def _inside(sim, points, half) -> float:
    """How deep [m] the deepest of the world ``points`` lies inside the moving box of half
    sides ``half`` (≤ 0: none inside)."""
    q = np.asarray(sim.body_q)[1]
    local = np.linalg.solve(q[3:].reshape(3, 3), (np.asarray(points) - q[:3]).T).T
    return float(np.min(np.asarray(half) - np.abs(local), axis=1).max())


def test_segment_params_find_the_nearest_points():
    rng = np.random.default_rng(3)
    grid = np.linspace(0.0, 1.0, 401)
    for _ in range(30):
        a, b, c, e = rng.normal(size=(4, 3))
        s, t = segment_params(a, b, c, e)
        best = min(np.linalg.norm(a + u * (b - a) - c - w * (e - c)) for u in grid[::8]
                   for w in grid[::8])
        assert np.linalg.norm(a + s * (b - a) - c - t * (e - c)) <= best + 1e-12
    point = np.array([0.3, 0.4, 0.0])       # a zero-length segment
    assert segment_params(point, point, np.zeros(3), np.array([1.0, 0.0, 0.0])) == (0.0, 0.3)


def _area(surface) -> float:
    corners = surface.vertices[surface.faces]
    return float(0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                               corners[:, 2] - corners[:, 0]), axis=1).sum())


def test_surfaces_have_the_solids_edges_and_area(tmp_path):
    box = box_surface([0.1, 0.2, 0.3])
    lengths = np.linalg.norm(box.vertices[box.edges[:, 0]] - box.vertices[box.edges[:, 1]],
                             axis=1)
    assert sorted(np.round(lengths, 12)) == [0.2] * 4 + [0.4] * 4 + [0.6] * 4
    assert _area(box) == pytest.approx(2 * (0.2 * 0.4 + 0.2 * 0.6 + 0.4 * 0.6))
    can = cylinder_surface(0.1, 0.2)
    k = CYLINDER_SEGMENTS
    polygon = 0.5 * k * 0.1 ** 2 * math.sin(2 * math.pi / k)
    side = k * 2 * 0.1 * math.sin(math.pi / k) * 0.4
    assert _area(can) == pytest.approx(2 * polygon + side)
    assert len(can.edges) == 3 * k
    mesh = trimesh.creation.box(extents=[0.1, 0.2, 0.3])
    mesh.export(tmp_path / 'box.stl')
    geometry = Collision(mesh={'uri': str(tmp_path / 'box.stl')})
    surface = moving_surface(geometry, mesh_hull(str(tmp_path / 'box.stl'), [1.0] * 3,
                                                 'a test', 1e-3))
    assert len(surface.vertices) == 8 and len(surface.faces) == 12
    assert len(surface.edges) == 18                 # 12 sides and a diagonal on each face
    assert _area(surface) == pytest.approx(_area(box_surface([0.05, 0.1, 0.15])))


def test_a_box_dropped_across_a_ridge_rests_on_its_edge():
    """No corner of the box comes near the ridge: only its bottom edges crossing the ridge's
    top edge hold it (before edge–edge contact it sank 5 cm, to where its corners met the
    ridge's sides)."""
    sim = Stepper(_scene(RIDGE, {'shape': {'box': [0.1, 0.1, 0.1]},
                                 'position': [0.0, 0.0, RIDGE_TOP + 0.05 + 0.02]}))
    ridge = np.array([[x, 0.0, RIDGE_TOP] for x in np.linspace(-0.5, 0.5, 201)])
    for _ in range(100):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        assert _inside(sim, ridge, [0.05] * 3) < 0.0
    assert sim.body_q[1][2] == pytest.approx(
        RIDGE_TOP + 0.05 + resting_distance(G / 2, D_HAT, 1e9), abs=2e-5)
    contacts = sim.contacts
    assert {c['other'] for c in contacts} == {'ridge'}
    assert sum(c['normal_force'] * c['normal'][2] for c in contacts) == pytest.approx(G,
                                                                                       rel=1e-3)


def test_a_box_dropped_on_a_spike_rests_on_its_tip():
    """A 0.3 m box centred over a cube standing on a corner: the spike's top corner holds the
    box's bottom face (vertex–face; the box's corners are far beyond the spike). The tip is
    under the diagonal the face's two triangles share: each carries half the weight."""
    sim = Stepper(_scene(SPIKE, {'shape': {'box': [0.3, 0.3, 0.1]},
                                 'position': [0.0, 0.0, SPIKE_TOP + 0.05 + 0.02]}))
    tip = [[0.0, 0.0, SPIKE_TOP]]
    for _ in range(100):
        sim.step()
        assert _inside(sim, tip, [0.15, 0.15, 0.05]) < 0.0
    assert sim.body_q[1][2] == pytest.approx(
        SPIKE_TOP + 0.05 + resting_distance(G / 2, D_HAT, 1e9), abs=2e-5)


def test_a_capsule_lies_across_a_bar():
    """A capsule 0.3 m long across a 2 cm bar: its ends are beyond the bar, so its axis
    against the bar's top edges holds it."""
    sim = Stepper(_scene(BAR, {'shape': {'box': [0.1, 0.1, 0.1]},
                               'collision': [{'capsule': {'radius': 0.02, 'length': 0.3},
                                              'origin': {'rpy': [0.0, math.pi / 2, 0.0]}}],
                               'position': [0.0, 0.0, 0.21 + 0.02 + 0.01]}))
    for _ in range(100):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
    assert sim.body_q[1][2] == pytest.approx(
        0.21 + 0.02 + resting_distance(G / 2, D_HAT, 1e9), abs=2e-5)


def _terms(fixed, free, q_shift):
    scene = _scene(fixed, free, gravity=(0.0, 0.0, 0.0))
    with_contact = Stages(scene)
    without = Stages(scene.model_copy(update={'contact': None}))
    q = with_contact.host.body_q0.copy()
    q[1, :3] += q_shift
    rng = np.random.default_rng(11)
    q[1, 3:] += 1e-3 * rng.normal(size=9)
    for stages in (with_contact, without):
        stages.scratch.q_n.assign(q[None])      # the mollifier's state
    return with_contact, without, q


@pytest.mark.parametrize('case', ['edge across a ridge', 'face over a spike',
                                  'capsule across a bar'])
def test_edge_and_face_barrier_gradients_match_finite_differences(case):
    box = {'shape': {'box': [0.1, 0.1, 0.1]}, 'orientation': {'rpy': [0.0, 0.0, 0.3]}}
    fixed, free, top = {
        'edge across a ridge': (RIDGE, box, RIDGE_TOP + 0.05 + 0.006),
        'face over a spike': (SPIKE, {'shape': {'box': [0.3, 0.3, 0.1]}},
                              SPIKE_TOP + 0.05 + 0.005),
        'capsule across a bar': (BAR, {'shape': {'box': [0.1, 0.1, 0.1]}, 'collision': [
            {'capsule': {'radius': 0.02, 'length': 0.3},
             'origin': {'rpy': [0.0, math.pi / 2, 0.0]}}]}, 0.21 + 0.02 + 0.004)}[case]
    with_contact, without, q = _terms(fixed, {**free, 'position': [0.0, 0.0, top]}, 0.0)
    gradient, hessian, fd_gradient, fd_hessian = contact_terms(with_contact, without, q,
                                                               q + 1e-4, step=1e-7, row=1)
    assert np.abs(fd_gradient).max() > 1e-3           # the barrier is active
    assert_matches_differences(gradient, fd_gradient)
    assert_psd(hessian)


def _gap_along(stages, q, dq, alpha) -> float:
    return float(pair_distances(q + alpha * dq, vars(stages.host)).min())


@pytest.mark.parametrize('sideways', [0.0, 3.0])
def test_the_step_bound_of_an_edge_stops_short_of_the_analytic_impact(sideways):
    """The box's bottom edges fall onto the ridge's top edge at 0.1 m per unit step, with a
    sideways slide of ``sideways`` times that along the ridge: the gap closes linearly,
    d(α) = d₀ − 0.1 α, so it reaches η d₀ at α = (1 − η) d₀ / 0.1; conservative advancement
    stops between there and where the gap is 2 η d₀."""
    scene = _scene(RIDGE, {'shape': {'box': [0.1, 0.1, 0.1]},
                           'position': [0.0, 0.0, RIDGE_TOP + 0.05 + 0.004]})
    stages = Stages(scene)
    q = stages.host.body_q0.copy()
    stages.scratch.q_n.assign(q[None])
    dq = np.zeros_like(q)
    dq[1, :3] = [0.1 * sideways, 0.0, -0.1]
    d0 = _gap_along(stages, q, dq, 0.0)
    assert d0 == pytest.approx(0.004)
    alpha = stages.step_bound(q, dq)
    assert (1.0 - 0.2) * d0 / 0.1 - 1e-12 <= alpha <= (1.0 - 0.1) * d0 / 0.1 + 1e-12
    path = np.linspace(0.0, alpha, 50)
    assert min(_gap_along(stages, q, dq, a) for a in path) >= 0.1 * d0 - 1e-12


def test_the_step_bound_of_a_turning_face_keeps_every_gap():
    """A box over the spike turns 0.5 rad and drops 5 cm in one step: every gap along the
    path up to the bound stays at least η of where it started."""
    scene = _scene(SPIKE, {'shape': {'box': [0.3, 0.3, 0.1]},
                           'position': [0.02, 0.0, SPIKE_TOP + 0.05 + 0.004]})
    stages = Stages(scene)
    q = stages.host.body_q0.copy()
    stages.scratch.q_n.assign(q[None])
    turn = np.array([[math.cos(0.5), -math.sin(0.5), 0.0], [math.sin(0.5), math.cos(0.5), 0.0],
                     [0.0, 0.0, 1.0]])
    dq = np.zeros_like(q)
    dq[1, :3] = [0.0, 0.0, -0.05]
    dq[1, 3:] = (turn @ q[1, 3:].reshape(3, 3) - q[1, 3:].reshape(3, 3)).reshape(-1)
    alpha = stages.step_bound(q, dq)
    assert 0.0 < alpha < 1.0
    start = pair_distances(q, vars(stages.host))
    for a in np.linspace(0.0, alpha, 60):
        gaps = pair_distances(q + a * dq, vars(stages.host))
        assert np.all(gaps >= 0.1 * np.minimum(start, D_HAT) - 1e-12)


def test_the_mollifier_turns_parallel_edges_off():
    scene = _scene(RIDGE, {'shape': {'box': [0.1, 0.1, 0.1]},
                           'position': [0.0, 0.0, RIDGE_TOP + 0.06]})
    model = vars(Stages(scene).host)
    q = np.asarray(Stages(scene).host.body_q0).copy()
    things = len(model['plane_offset']) + len(model['shape_kind'])
    first = len(model['point_body']) * things
    weights = [pair_weight(model, q, p)
               for p in range(first, first + len(model['edge_body']) * len(model['static_edge_a']))]
    assert min(weights) == 0.0 and max(weights) == 1.0      # parallel: off; crossing: on
    ends = model['static_edge_b'] - model['static_edge_a']
    along = np.abs(ends[:, 0]) > 0.5                         # the ridge's long edges
    q[1, 3:] = np.array([[math.cos(0.01), -math.sin(0.01), 0.0],
                         [math.sin(0.01), math.cos(0.01), 0.0], [0.0, 0.0, 1.0]]).reshape(-1)
    e = int(np.flatnonzero(np.abs(model['edge_b'] - model['edge_a'])[:, 0] > 0.05)[0])
    s = int(np.flatnonzero(along)[0])
    weight = pair_weight(model, q, first + e * len(along) + s)
    ratio = math.sin(0.01) ** 2 / 1e-3                       # |e₀ × e₁|² / ε
    assert weight == pytest.approx((2.0 - ratio) * ratio, rel=1e-9)


def test_a_capsule_through_a_bar_is_refused():
    scene = _scene(BAR, {'shape': {'box': [0.1, 0.1, 0.1]},
                         'collision': [{'capsule': {'radius': 0.02, 'length': 0.3},
                                        'origin': {'rpy': [0.0, math.pi / 2, 0.0]}}],
                         'position': [0.0, 0.0, 0.215]})
    with pytest.raises(SceneError, match=r"body 'thing' starts .* m inside bar"):
        Stepper(scene)
