"""Collision geometry beyond boxes and spheres (README.md#contact): cylinders, meshes, URDF
``<collision>`` elements, a floating URDF robot placed by ``base``, and the shipped quadruped
standing under PD. Resting heights are checked against the barrier's equilibrium for the load
each contact point carries."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.barrier import resting_distance

G = 9.81
ROOT = Path(__file__).resolve().parents[1]
D_HAT, KAPPA = 0.005, 1.0e9


def _drop(body: dict, steps: int = 300) -> Stepper:
    scene = Scene.from_dict({'dt': 0.01, 'bodies': [{'name': 'thing', 'mass': 1.0, **body}],
                             'ground': {'height': 0.0}, 'contact': {'d_hat': D_HAT}})
    sim = Stepper(scene)
    for _ in range(steps):
        sim.step()
        assert sim.stats['min_distance'] > 0.0
    return sim


def test_a_cylinder_stands_on_its_rim_points_and_lies_on_a_flat_of_them():
    cylinder = {'shape': {'cylinder': {'radius': 0.05, 'length': 0.2}}, 'collision': 'shape'}
    standing = _drop({**cylinder, 'position': [0.0, 0.0, 0.11]})
    assert standing.stats['contacts'] == 16
    assert standing.body_q[0][2] == pytest.approx(0.1 + resting_distance(G / 16, D_HAT, KAPPA),
                                                  abs=1e-6)
    # on its side, turned π/16 about its axis: it lies on a flat of the 16-gon, two points of
    # each rim, r cos(π/16) below its axis
    lying = _drop({**cylinder, 'position': [0.0, 0.0, 0.06],
                   'orientation': {'rpy': [np.pi / 2, np.pi / 16, 0.0]}})
    assert lying.stats['contacts'] == 4
    assert lying.body_q[0][2] == pytest.approx(
        0.05 * np.cos(np.pi / 16) + resting_distance(G / 4, D_HAT, KAPPA), abs=1e-6)


def _write_box_obj(path: Path, sides) -> None:
    half = 0.5 * np.asarray(sides)
    corners = [half * [sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
             (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    path.write_text(''.join(f'v {float(x)!r} {float(y)!r} {float(z)!r}\n' for x, y, z in corners)
                    + ''.join(f'f {a} {b} {c}\n' for a, b, c in faces))


def test_a_mesh_rests_on_its_vertices_like_the_same_box(tmp_path):
    _write_box_obj(tmp_path / 'brick.obj', [0.2, 0.1, 0.05])
    scene_file = tmp_path / 'brick.yaml'
    scene_file.write_text(
        'dt: 0.01\nground: {height: 0.0}\ncontact: {d_hat: 0.005}\n'
        'bodies:\n- name: brick\n  shape: {box: [0.2, 0.1, 0.05]}\n  mass: 1.0\n'
        '  position: [0.0, 0.0, 0.03]\n'
        '  collision: [{mesh: {uri: brick.obj, scale: [1.0, 1.0, 1.0]}}]\n')
    sim = Stepper(Scene.load(scene_file))        # the uri is relative to the scene file
    for _ in range(300):
        sim.step()
    assert sim.stats['contacts'] == 4
    assert sim.body_q[0][2] == pytest.approx(0.025 + resting_distance(G / 4, D_HAT, KAPPA),
                                             abs=1e-6)


def test_a_collision_mesh_that_cannot_be_read_is_one_line(tmp_path):
    (tmp_path / 'junk.stl').write_bytes(b'not a mesh')
    for uri in ('missing.obj', str(tmp_path / 'junk.stl')):
        scene = Scene.from_dict({'bodies': [{'name': 'lump', 'shape': {'box': [0.1, 0.1, 0.1]},
                                             'mass': 1.0,
                                             'collision': [{'mesh': {'uri': uri}}]}],
                                 'ground': {'height': -1.0}})
        with pytest.raises(SceneError, match=r"body 'lump' \(bodies\[0\]\.collision\[0\]\): "
                                             r'(cannot read|collision mesh .* has no)'):
            Stepper(scene)


URDF = '''<?xml version="1.0"?>
<robot name="puck">
  <link name="base">
    <inertial><mass value="2.0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0"
      izz="0.01"/></inertial>
    <collision><origin xyz="0 0 -0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry>
    </collision>
  </link>
  <joint name="mast_joint" type="fixed"><parent link="base"/><child link="mast"/>
    <origin xyz="0 0 0.1"/></joint>
  <link name="mast">
    <inertial><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0"
      izz="0.001"/></inertial>
    <collision><geometry>{mast}</geometry></collision>
  </link>
</robot>
'''


def _puck(tmp_path, mast='<sphere radius="0.03"/>') -> Path:
    path = tmp_path / 'puck.urdf'
    path.write_text(URDF.format(mast=mast))
    return path


def test_urdf_collisions_become_body_geometry_and_a_floating_robot_rests_on_its_base_box(
        tmp_path):
    scene = Scene.from_urdf(_puck(tmp_path), fixed_base=False, base={'xyz': [1.0, 2.0, 0.2]},
                            ground={'height': 0.0}, contact={'d_hat': D_HAT})
    (body,) = scene.bodies                       # the mast is welded to the base
    assert [g.kind for g in body.collision] == ['box', 'sphere']
    sim = Stepper(scene)
    # base placed at (1, 2, 0.2): its box spans z 0.1..0.2, the COM is 0.02 m above the origin
    assert sim.body_q[0][:3] == pytest.approx([1.0, 2.0, 0.22])
    for _ in range(300):
        sim.step()
    assert sim.stats['contacts'] == 4
    # the box's bottom face is 0.02 + 0.1 below the COM
    assert sim.body_q[0][2] == pytest.approx(0.12 + resting_distance(2.5 * G / 4, D_HAT, KAPPA),
                                             abs=1e-6)


def test_urdf_collision_problems_count_only_when_the_scene_has_contact(tmp_path):
    path = _puck(tmp_path, mast='<cone radius="0.1"/>')
    Scene.from_urdf(path)                         # no contact: the collisions are not used
    with pytest.raises(SceneError, match=r"puck\.urdf:14: <collision> of link 'mast': <cone> "
                                         r'geometry \(known: box'):
        Scene.from_urdf(path, ground={'height': -1.0})
    missing = _puck(tmp_path, mast='<mesh filename="package://nowhere/mast.stl"/>')
    with pytest.raises(SceneError, match=r"<collision> of link 'mast': mesh "
                                         r"'package://nowhere/mast\.stl' not found"):
        Scene.from_urdf(missing, contact={})
    bad = _puck(tmp_path, mast='<sphere radius="-1"/>')
    with pytest.raises(SceneError, match=r'<sphere radius="-1"> must be positive'):
        Scene.from_urdf(bad, contact={})


def test_a_floating_urdf_robot_without_ground_is_warned_about_once(tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        Scene.from_urdf(_puck(tmp_path), fixed_base=False)
        Scene.from_urdf(_puck(tmp_path), fixed_base=False, ground={'height': -1.0})
    floating = [str(w.message) for w in caught if 'falls without end' in str(w.message)]
    assert len(floating) == 1 and 'there is no ground' in floating[0]


def test_the_shipped_quadruped_stands_for_3_s_under_the_demo_controllers_pd():
    scene = Scene.load(ROOT / 'msg_configs' / 'scenes' / 'quadruped.yaml')
    assert scene.dt == 1e-3 and scene.ground is not None
    sim = Stepper(scene)
    names = sim.joint_names
    target = np.array([0.7 if 'thigh' in n else -1.4 if 'knee' in n else 0.0 for n in names])
    heights = []
    for _ in range(3000):
        sim.set_torques(100.0 * (target - sim.angles) - 10.0 * sim.velocities)   # its gains
        sim.step()
        assert sim.stats['converged'] and sim.stats['min_distance'] > 0.0
        heights.append(sim.body_q[0][2])
    # standing: the four feet carry it, the trunk level at rest near its standing height
    # (feet 0.245 m below the hips + 0.02 m radius, less the knees' sag under kp 100)
    assert sim.stats['contacts'] == 4
    assert 0.24 < heights[-1] < 0.27
    assert abs(heights[-1] - heights[-500]) < 1e-4
    assert np.abs(sim.body_qdot[0][:3]).max() < 1e-3
    trunk = sim.link_transforms[sim.link_names.index('trunk')]
    assert trunk[2, 2] > 0.999                     # its z axis still points up


def test_run_adds_a_ground_under_any_scene_and_a_urdf_robot_touches_it_with_its_collisions():
    from helpers.cli import cli
    urdf = ROOT / 'msg_configs' / 'robots' / 'quadruped.urdf'
    # welded to the world at its trunk, legs straight, its feet hang 0.34 m down: a ground
    # 0.1 m down cuts them, so the collision geometry is in use
    done = cli('run', '--scene', urdf, '--ground', -0.1, '--mode', 'fast', '--duration', 0.1)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.count('error') == 1 and 'Traceback' not in done.stderr
    assert "_shank' starts 0.24 m inside ground" in done.stderr.splitlines()[-1]
    assert "base: {xyz: [x, y, z]} or `affine-joint-sim run --base X Y Z`" in done.stderr
    # the standing scene with its ground lowered 5 cm: the robot drops onto it
    done = cli('run', '--scene', 'quadruped', '--ground', -0.05, '--mode', 'fast', '--duration',
               0.3)
    assert done.returncode == 0, done.stderr
    line = next(s for s in done.stdout.splitlines() if s.startswith('contact:'))
    assert float(line.split('world ')[1].split(' m')[0]) > 0.0
    assert 'at most 0 contacts' not in line


def test_base_places_a_fixed_base_robot_root_link_and_all(tmp_path):
    """Before, the fixed root body stayed at the origin while its links and joints moved."""
    from affine_joint_sim.rotations import rpy_matrix

    urdf = ROOT / 'msg_configs' / 'robots' / 'quadruped.urdf'
    base = {'xyz': [0.5, -0.2, 1.0], 'rpy': [0.0, 0.0, 0.3]}
    moved, home = (Scene.from_urdf(urdf, base=base, ground={'height': 0.0}),
                   Scene.from_urdf(urdf, ground={'height': -1.0}))
    shift = np.eye(4)
    shift[:3, :3], shift[:3, 3] = rpy_matrix(*base['rpy']), base['xyz']
    sims = Stepper(moved), Stepper(home)
    np.testing.assert_allclose(sims[0].link_transforms, shift @ sims[1].link_transforms,
                               atol=1e-12)
    trunk = moved.bodies[moved.body_index('trunk')]
    assert trunk.fixed and list(trunk.position) == base['xyz']
