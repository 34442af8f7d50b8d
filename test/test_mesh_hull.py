"""A moving mesh touches as its convex hull, simplified only within contact.mesh_tolerance
(physics/contact/hull.py): the bound checked against the mesh's support function, the warning
said once with it, and an arm whose links are fine meshes folding onto itself checked against
the full meshes."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from affine_joint_sim.bench import zoo
from affine_joint_sim.physics.contact.hull import simplified_hull
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.sim_warnings import SimulationDetail, SimulationWarning
from affine_joint_sim.stepper import Stepper

ROBOTS = Path(__file__).resolve().parent.parent / 'msg_configs' / 'robots'


def _support_gap(points: np.ndarray, kept: np.ndarray, directions: np.ndarray) -> float:
    """The largest h_points(u) − h_kept(u) over unit directions u: the Hausdorff distance of
    two convex hulls, one inside the other, seen along u (support functions)."""
    return float(((points @ directions.T).max(axis=0) - (kept @ directions.T).max(axis=0)).max())


def test_a_hull_is_simplified_within_the_tolerance_and_no_further():
    import trimesh
    ball = np.unique(trimesh.creation.icosphere(subdivisions=4, radius=0.1).vertices, axis=0)
    directions = np.random.default_rng(7).normal(size=(20000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    for tolerance in (1e-3, 3e-3):
        hull = simplified_hull(ball, tolerance)
        assert hull.error <= tolerance
        assert 0.5 * tolerance < _support_gap(ball, hull.vertices, directions) <= tolerance
        assert len(hull.vertices) < len(ball)           # 2562 vertices: simplified
        assert {tuple(v) for v in hull.vertices} <= {tuple(v) for v in ball}
        assert len(hull.faces) == 2 * len(hull.vertices) - 4    # a closed convex polyhedron
    assert len(simplified_hull(ball, 1e-3).vertices) > len(simplified_hull(ball, 3e-3).vertices)


def test_a_box_mesh_keeps_exactly_its_corners():
    import trimesh
    brick = trimesh.creation.box([0.2, 0.1, 0.05]).subdivide().subdivide()
    hull = simplified_hull(np.unique(brick.vertices, axis=0), 1e-3)
    corners = 0.5 * np.array([0.2, 0.1, 0.05]) * np.array(
        [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    assert {tuple(c) for c in hull.vertices} == {tuple(c) for c in corners}
    assert hull.error == 0.0 and len(hull.faces) == 12


def _ball_scene(tmp_path, mesh, **contact) -> Scene:
    mesh.export(tmp_path / 'ball.stl')
    return Scene.from_dict({
        'bodies': [{'name': 'ball', 'shape': {'sphere': {'radius': 0.05}}, 'mass': 1.0,
                    'position': [0.0, 0.0, 0.1],
                    'collision': [{'mesh': {'uri': str(tmp_path / 'ball.stl')}}]}],
        'ground': {'height': 0.0}, 'contact': contact})


def test_a_simplified_hull_is_said_once_with_its_bound(tmp_path):
    import trimesh
    scene = _ball_scene(tmp_path, trimesh.creation.icosphere(subdivisions=3, radius=0.05))
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        sim = Stepper(scene)
    details = [str(w.message) for w in said if w.category is SimulationDetail]
    summaries = [str(w.message) for w in said if w.category is SimulationWarning]
    assert len(details) == 1, details
    assert re.search(r"^body 'ball' \(bodies\[0\]\.collision\[0\]\): collision mesh .*ball.stl "
                     r'touches as its convex hull, \d+ of its 642 corners \(642 vertices\): '
                     r'every vertex lies within 0\.\d+ mm of it \(contact.mesh_tolerance '
                     r'0\.001 m\)$', details[0]), details
    assert len(summaries) == 1 and re.search(
        r'collision meshes simplified for contact: 1 \(worst: ball.stl within 0\.\d+ mm\)',
        summaries[0]), summaries
    lowest = np.inf
    for _ in range(150):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        lowest = min(lowest, sim.body_q[0][2])
    assert 0.05 < lowest < 0.05 + 1e-3     # rests on its lowest vertex, a corner kept
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        Stepper(_ball_scene(tmp_path, trimesh.creation.icosphere(subdivisions=3, radius=0.05),
                            mesh_tolerance=0.01))
    assert 'mesh_tolerance 0.01 m' in ' '.join(str(w.message) for w in said)


def test_a_flat_moving_mesh_is_one_scene_error(tmp_path):
    import trimesh
    plate = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]],
                            [[0, 1, 2], [1, 3, 2]])
    with pytest.raises(SceneError, match=r"body 'ball' \(bodies\[0\]\.collision\[0\]\): "
                                         r'collision mesh .*ball.stl is flat \(a moving mesh '
                                         r'touches as its convex hull, which needs a volume\)'):
        Stepper(_ball_scene(tmp_path, plate))


def _fine_arm(folder: Path) -> Path:
    """arm6_gripper with each collision box as a box mesh subdivided twice and each cylinder
    as a capsule mesh of its radius and length (48 × 48 segments: about 2,300 vertices),
    every joint's effort 150, written with its meshes into ``folder``."""
    import trimesh

    def mesh(match):
        kind, attrs = match.group(1), dict(re.findall(r'(\w+)="([^"]*)"', match.group(2)))
        if kind == 'cylinder':
            radius, length = float(attrs['radius']), float(attrs['length'])
            solid = trimesh.creation.capsule(max(length - 2.0 * radius, 0.0), radius,
                                             count=[48, 48])
        else:
            solid = trimesh.creation.box([float(v) for v in attrs['size'].split()])
            solid = solid.subdivide().subdivide()
        name = f'part{len(list(folder.glob("*.stl")))}.stl'
        solid.export(folder / name)
        return f'<mesh filename="{name}"/>'
    text = re.sub(r'<(cylinder|box) ([^/]*)/>(?=</geometry>\s*</collision>)', mesh,
                  (ROBOTS / 'arm6_gripper.urdf').read_text())
    (folder / 'arm.urdf').write_text(re.sub(r'effort="\d+"', 'effort="150"', text))
    return folder / 'arm.urdf'


def _deepest_overlap(sim, meshes: dict) -> float:
    """The deepest [m] a vertex of one full collision mesh lies inside another's convex hull
    (which holds that mesh: the meshes overlap at most this), over the pairs of links on
    bodies that may touch each other."""
    import trimesh
    transforms, names = sim.link_transforms, sim.link_names
    body_of = dict(zip(names, sim._links.body))
    placed = {n: trimesh.Trimesh(m.vertices, m.faces).apply_transform(
        transforms[names.index(n)]) for n, m in meshes.items()}
    touch = set(zip(sim._host.touch_a, sim._host.touch_b))
    deepest = 0.0
    for a in placed:
        for b in placed:
            if (body_of[a], body_of[b]) in touch or (body_of[b], body_of[a]) in touch:
                planes = ConvexHull(placed[b].vertices).equations
                depth = -(placed[a].vertices @ planes[:, :3].T + planes[:, 3]).max(axis=1)
                deepest = max(deepest, float(depth.max()))
    return deepest


def test_an_arm_of_fine_meshes_folding_onto_itself_overlaps_them_at_most_3_mm(tmp_path):
    """wrist_1 driven at 10 N·m folds the gripper back onto the forearm (no gravity): the
    links touch as their hulls simplified within 1 mm, so the full meshes overlap at most
    2 mm (3 mm asked; the count-based reduction before overlapped them 2.2 mm here, a UR5's
    12.5 mm: the next test)."""
    import trimesh
    urdf = _fine_arm(tmp_path)
    (tmp_path / 'fold.yaml').write_text(
        f'urdf: {urdf.name}\ndt: 0.001\ngravity: [0, 0, 0]\ncontact: {{self_collision: true}}\n')
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', SimulationWarning)
        sim = Stepper(Scene.load(tmp_path / 'fold.yaml'))
    text = urdf.read_text()
    meshes = {}
    for link in re.finditer(r'<link name="(\w+)">(.*?)</link>', text, re.S):
        found = re.search(r'<collision>\s*<origin xyz="([^"]*)" rpy="0 0 0"/>\s*<geometry>'
                          r'<mesh filename="([^"]*)"', link.group(2))
        if found:
            mesh = trimesh.load(tmp_path / found.group(2), force='mesh')
            meshes[link.group(1)] = mesh.apply_translation(
                [float(v) for v in found.group(1).split()])
    assert len(meshes) == 10
    deepest, touched = _fold(sim, meshes, 'wrist_1', 10.0, 400)
    assert touched > 0                  # the gripper reached the forearm
    assert deepest <= 3e-3


def _fold(sim, meshes: dict, joint: str, torque: float, steps: int) -> tuple[float, int]:
    """(the deepest overlap [m] of the full meshes, the most contacts) over ``steps`` steps
    of ``joint`` driven at ``torque`` [N·m], checked every 20 steps."""
    torques = np.zeros(len(sim.command_joint_names))
    torques[sim.command_joint_names.index(joint)] = torque
    sim.set_torques(torques)
    deepest, touched = 0.0, 0
    for k in range(steps):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        if k % 20 == 19:
            deepest = max(deepest, _deepest_overlap(sim, meshes))
            touched = max(touched, sim.stats['contacts'])
    return deepest, touched


@pytest.mark.skipif(not zoo.installed(), reason='the zoo extra (example-robot-data) is not '
                    'installed')
def test_a_ur5_folding_its_elbow_under_150_nm_overlaps_its_meshes_at_most_3_mm(tmp_path):
    """The UR5 of example-robot-data, shoulder lifted back, its elbow driven at its effort
    limit with self-collision: wrist_1 comes to rest on the upper arm. The count-based
    reduction before this hull left it 12.5 mm inside the upper arm's mesh."""
    import trimesh
    urdf = zoo.urdf_path('ur5')
    (tmp_path / 'fold.yaml').write_text(
        f'urdf: {urdf}\ndt: 0.001\ncontact: {{self_collision: true}}\n'
        'initial_positions: {shoulder_lift_joint: -1.2, elbow_joint: 0.3}\n')
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', SimulationWarning)
        sim = Stepper(Scene.load(tmp_path / 'fold.yaml'))
    folder = urdf.parent.parent / 'meshes' / 'ur5' / 'collision'
    meshes = {link: trimesh.load(folder / f'{name}.stl', force='mesh') for link, name in (
        ('base_link', 'base'), ('shoulder_link', 'shoulder'), ('upper_arm_link', 'upperarm'),
        ('forearm_link', 'forearm'), ('wrist_1_link', 'wrist1'), ('wrist_2_link', 'wrist2'),
        ('wrist_3_link', 'wrist3'))}
    deepest, touched = _fold(sim, meshes, 'elbow_joint', 150.0, 300)
    assert touched > 0
    assert deepest <= 3e-3
