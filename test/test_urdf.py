"""Robots from URDF files: mass properties, welding, kinematics, dynamics against the rigid
multibody reference, limits, package:// URIs, and every trap of a real URDF with its message.

The truths here are computed from the URDF's own numbers with formulas written in the test
(rpy rotations, the parallel-axis rule, ½ m v² + ½ ωᵀ I ω), not with the converter's code.
"""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim.bench.references import RigidTree
from affine_joint_sim.physics.host.model import build_model
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.sim_warnings import SimulationDetail, SimulationWarning
from affine_joint_sim.stepper import Stepper
from helpers.imports import modules_loaded_by

DATA = Path(__file__).resolve().parent / 'data' / 'urdf'
ROBOTS = Path(__file__).resolve().parent.parent / 'msg_configs' / 'robots'


def rpy(r, p, y):
    """URDF's fixed-axis roll-pitch-yaw rotation Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y),
                              math.sin(y))
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
            @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


def transform(xyz=(0, 0, 0), angles=(0, 0, 0)):
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rpy(*angles), xyz
    return out


def tensor(ixx, iyy, izz, ixy=0.0, ixz=0.0, iyz=0.0):
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def robot(body: str, name='r') -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def inertial(mass=1.0, xyz='0 0 0', angles='0 0 0', ixx=0.01, iyy=0.01, izz=0.01, ixy=0.0,
             ixz=0.0, iyz=0.0):
    return (f'<inertial><origin xyz="{xyz}" rpy="{angles}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="{ixz}" '
            f'iyz="{iyz}"/></inertial>')


def joint(name, kind, parent, child, xyz='0 0 0', axis='0 1 0', extra=''):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/>{extra}</joint>')


def write(tmp_path, text, name='robot.urdf') -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def load(tmp_path, text, **overrides) -> Scene:
    return Scene.from_urdf(write(tmp_path, text), **overrides)


def body_inertia(scene, name) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, COM, inertia tensor about the COM in world axes) of a scene body."""
    body = scene.bodies[scene.body_index(name)]
    model = build_model(scene)
    rot = model.body_q0[scene.body_index(name), 3:].reshape(3, 3)
    return body.mass, np.array(body.position), rot @ np.diag(body.inertia) @ rot.T


ARM_INERTIAL = inertial(2.0, '0.1 0.05 -0.4', '0.4 -0.3 0.7', 0.05, 0.04, 0.02, 0.003, -0.002,
                        0.001)
PENDULUM = robot('<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm', '0 0 1')
                 + '<link name="arm">' + ARM_INERTIAL + '</link>')


# ---- mass properties ----------------------------------------------------------------------

def test_kinetic_energy_of_a_link_equals_the_rigid_formula_of_the_urdf_numbers(tmp_path):
    """A link whose inertial frame is rotated and offset: its affine body, moved rigidly with
    linear velocity v of the COM and angular velocity ω, has ½ m v² + ½ ωᵀ I ω."""
    scene = load(tmp_path, PENDULUM)
    model = build_model(scene)
    k = scene.body_index('arm')
    rot = rpy(0.4, -0.3, 0.7)
    inertia = rot @ tensor(0.05, 0.04, 0.02, 0.003, -0.002, 0.001) @ rot.T   # world, at COM
    com = np.array([0.1, 0.05, 1.0 - 0.4])
    np.testing.assert_allclose(model.body_q0[k, :3], com, atol=1e-12)
    assert model.body_mass[k] == 2.0
    rng = np.random.default_rng(7)
    for _ in range(5):
        v, w = rng.normal(size=3), rng.normal(size=3)
        a = model.body_q0[k, 3:].reshape(3, 3)
        adot = np.cross(w, a.T).T                    # Ȧ = [ω]× A, column by column
        s = model.body_second_moment[k]
        affine = 0.5 * 2.0 * v @ v + 0.5 * np.sum(s * adot ** 2)
        assert affine == pytest.approx(0.5 * 2.0 * v @ v + 0.5 * w @ inertia @ w, rel=1e-12)


def test_rest_frame_is_the_principal_frame_and_equivalent_box_has_the_moments(tmp_path):
    scene = load(tmp_path, PENDULUM)
    model = build_model(scene)
    k = scene.body_index('arm')
    a = model.body_q0[k, 3:].reshape(3, 3)
    np.testing.assert_allclose(a @ a.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(a) == pytest.approx(1.0)
    # the uniform box of half sides h has S = m h² / 3 per axis; its volume is then scaled
    # evenly into the density range (this link's box would weigh 66 kg/m³)
    ratio = 2.0 * model.body_half_extent[k] ** 2 / 3.0 / model.body_second_moment[k]
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)
    volume = np.prod(2.0 * model.body_half_extent[k])
    assert 2.0 / volume == pytest.approx(100.0, rel=1e-12)
    assert model.body_ortho_coeff[k] >= 1e8 * volume      # κ v̄: at least the default κ


def test_welded_links_keep_total_mass_com_and_inertia(tmp_path):
    """Two massive links on a fixed joint become one body: mass, COM and inertia by the
    parallel-axis rule, computed here from the URDF numbers."""
    text = robot('<link name="base"/>' + joint('hinge', 'revolute', 'base', 'a', '0 0 1',
                                               extra='<limit lower="-1" upper="1" effort="1" '
                                                     'velocity="1"/>')
                 + '<link name="a">' + inertial(1.5, '0 0 -0.3', '0.2 0 0', 0.02, 0.03, 0.01,
                                                0.001) + '</link>'
                 + '<joint name="weld" type="fixed"><parent link="a"/><child link="b"/>'
                   '<origin xyz="0.1 0 -0.6" rpy="0 0.5 0"/></joint>'
                 + '<link name="b">' + inertial(0.5, '0 0.02 0.05', '0 0 0.3', 0.004, 0.005,
                                                0.003) + '</link>')
    scene = load(tmp_path, text)
    assert [b.name for b in scene.bodies] == ['base', 'a']
    parts = []
    for mass, pose, local_com, angles, inertia in (
            (1.5, transform((0, 0, 1)), (0, 0, -0.3), (0.2, 0, 0), tensor(0.02, 0.03, 0.01,
                                                                          0.001)),
            (0.5, transform((0, 0, 1)) @ transform((0.1, 0, -0.6), (0, 0.5, 0)),
             (0, 0.02, 0.05), (0, 0, 0.3), tensor(0.004, 0.005, 0.003))):
        rot = pose[:3, :3] @ rpy(*angles)
        parts.append((mass, (pose @ [*local_com, 1.0])[:3], rot @ inertia @ rot.T))
    total = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / total
    inertia = sum(i + m * ((c - com) @ (c - com) * np.eye(3) - np.outer(c - com, c - com))
                  for m, c, i in parts)
    mass, body_com, body_inertia_world = body_inertia(scene, 'a')
    assert mass == pytest.approx(total, rel=1e-12)
    np.testing.assert_allclose(body_com, com, atol=1e-12)
    np.testing.assert_allclose(body_inertia_world, inertia, atol=1e-12)
    sim = Stepper(scene)
    names = sim.link_names
    assert names == ['base', 'a', 'b']
    expected_b = transform((0, 0, 1)) @ transform((0.1, 0, -0.6), (0, 0.5, 0))
    np.testing.assert_allclose(sim.link_transforms[names.index('b')], expected_b, atol=1e-12)


def test_merge_fixed_false_keeps_massive_links_as_bodies_on_a_fixed_joint(tmp_path):
    text = robot('<link name="base"/>' + joint('hinge', 'continuous', 'base', 'a', '0 0 1')
                 + '<link name="a">' + inertial(1.0, '0 0 -0.3') + '</link>'
                 + joint('weld', 'fixed', 'a', 'b', '0 0 -0.6') + '<link name="b">'
                 + inertial(0.5) + '</link>' + joint('frame', 'fixed', 'b', 'tip', '0 0 -0.1')
                 + '<link name="tip"/>')
    scene = load(tmp_path, text, merge_fixed=False)
    assert [b.name for b in scene.bodies] == ['base', 'a', 'b']     # tip carries a frame only
    assert [(j.name, j.type) for j in scene.joints] == [('hinge', 'revolute'), ('weld', 'fixed')]
    assert [f.name for f in scene.frames] == ['base', 'a', 'b', 'tip']


# ---- kinematics ---------------------------------------------------------------------------

def test_initial_positions_place_links_by_forward_kinematics_and_are_reported(tmp_path):
    scene = Scene.from_urdf(DATA / 'arm3.urdf', initial_positions={'pan': 0.4, 'lift': -0.7,
                                                                   'elbow': 1.1})
    sim = Stepper(scene)
    np.testing.assert_array_equal(sim.angles, [0.4, -0.7, 1.1])

    def turn(axis, angle):
        axis = np.asarray(axis, float) / np.linalg.norm(axis)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        out = np.eye(4)
        out[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
        return out

    turret = transform((0, 0, 0.1)) @ turn((0, 0, 1), 0.4)
    upper = turret @ transform((0, 0, 0.1), (0, 0, 0.2)) @ turn((0, 1, 0), -0.7)
    forearm = upper @ transform((0, 0, 0.5)) @ turn((0.3, 1, 0.2), 1.1)
    tool = forearm @ transform((0, 0, 0.4), (0, 0.5, 0))
    links = dict(zip(sim.link_names, sim.link_transforms))
    for name, expected in (('base', np.eye(4)), ('turret', turret), ('upper_arm', upper),
                           ('forearm', forearm), ('tool', tool)):
        np.testing.assert_allclose(links[name], expected, atol=1e-12, err_msg=name)
    for _ in range(3):
        sim.step()
    assert np.all(np.abs(sim.angles - [0.4, -0.7, 1.1]) < 0.05)   # it moved on from there


def test_joint_names_and_coordinates_are_the_urdf_ones_at_zero(tmp_path):
    scene = Scene.from_urdf(ROBOTS / 'arm6_gripper.urdf')
    assert [j.name for j in scene.joints] == [
        'shoulder_pan', 'shoulder_lift', 'elbow', 'wrist_1', 'wrist_2', 'wrist_3',
        'left_finger_joint', 'right_finger_joint']
    sim = Stepper(scene)
    np.testing.assert_array_equal(sim.angles, np.zeros(8))
    assert scene.robot_description == (ROBOTS / 'arm6_gripper.urdf').read_text()


def test_a_prismatic_finger_opens_along_its_axis_under_a_positive_force(tmp_path):
    text = robot('<link name="base"/>'
                 + joint('slide', 'prismatic', 'base', 'finger', '0 0 0', '1 0 0',
                         '<limit lower="-0.5" upper="0.5" effort="5" velocity="1"/>')
                 + '<link name="finger">' + inertial(0.2) + '</link>')
    sim = Stepper(load(tmp_path, text, gravity=[0, 0, 0], initial_positions={'slide': 0.03}))
    assert sim.angles[0] == 0.03
    start = sim.link_transforms[1][:3, 3].copy()
    np.testing.assert_allclose(start, [0.03, 0, 0], atol=1e-12)
    sim.set_torque('slide', 1.0)
    for _ in range(20):
        sim.step()
    moved = sim.link_transforms[1][:3, 3] - start
    # a force of 1 N on 0.2 kg: x = a t² / 2 along +x, and the coordinate grows by as much
    assert moved[0] == pytest.approx(0.5 * 5.0 * 0.2 ** 2, rel=0.05)
    assert sim.angles[0] - 0.03 == pytest.approx(moved[0], rel=1e-6)


# ---- dynamics against the rigid multibody reference ----------------------------------------

def angle_error(scene, torques, duration=0.5):
    """Largest |θ − θ_ref| [rad] over samples every 0.1 s (reference: rigid tree, RK4)."""
    sim = Stepper(scene)
    for name, value in torques.items():
        sim.set_torque(name, value)
    times = 0.1 * np.arange(1, round(duration / 0.1) + 1)
    tree = RigidTree(scene)
    reference, _ = tree.simulate([torques.get(j.name, 0.0) for j in scene.joints], times,
                                 step=1e-3)
    every, samples = round(0.1 / scene.dt), []
    for i in range(round(duration / scene.dt)):
        sim.step()
        if (i + 1) % every == 0:
            samples.append(sim.angles)
    return np.abs(np.array(samples) - reference).max()


@pytest.mark.parametrize('urdf, start, torques', [
    ('double_pendulum.urdf', {'shoulder': 0.8, 'elbow': -0.4}, {}),
    ('arm3.urdf', {'pan': 0.2, 'lift': 0.5, 'elbow': 0.7}, {'pan': 0.5}),
])
@pytest.mark.parametrize('integrator, order, limit', [('bdf1', 1.8, 0.05), ('bdf2', 3.0, 0.012)])
def test_urdf_robots_follow_the_rigid_reference_with_the_integrators_order(
        urdf, start, torques, integrator, order, limit):
    errors = [angle_error(Scene.from_urdf(DATA / urdf, initial_positions=start, dt=dt,
                                          solver={'integrator': integrator}), torques)
              for dt in (0.01, 0.005)]
    assert errors[1] < limit, errors
    assert errors[0] / errors[1] > order, errors     # halving dt: error / 2 (bdf1), / 4 (bdf2)


def test_urdf_limits_stop_the_joint(tmp_path):
    """A pendulum released at 0.3 rad swings to −0.3 rad without a limit; a URDF limit at
    −0.1 rad stops it there (within the penalty's give)."""
    def swing(limit):
        text = robot('<link name="base"/>' + joint('hinge', 'revolute', 'base', 'arm', '0 0 1',
                                                   extra=f'<limit lower="{limit}" upper="1" '
                                                         'effort="10" velocity="1"/>')
                     + '<link name="arm">' + inertial(1.0, '0 0 -0.5', ixx=0.08, iyy=0.08,
                                                      izz=0.001) + '</link>')
        sim = Stepper(load(tmp_path, text, initial_positions={'hinge': 0.3}))
        lowest = math.inf
        for _ in range(150):
            sim.step()
            lowest = min(lowest, sim.angles[0])
        return lowest

    assert swing(-1.0) == pytest.approx(-0.3, abs=0.01)
    assert -0.13 < swing(-0.1) < -0.1



def _limited_pendulum(lower, upper):
    """The hinge's zero position lies outside [lower, upper] when both have one sign (as in
    stock exports such as the Kinova Gen2's joint_2, [0.82, 5.46])."""
    return robot('<link name="base"/>' + joint('hinge', 'revolute', 'base', 'arm', '0 0 1',
                                               extra=f'<limit lower="{lower}" upper="{upper}" '
                                                     'effort="10" velocity="1"/>')
                 + '<link name="arm">' + inertial(1.0, '0 0 -0.5', ixx=0.08, iyy=0.08,
                                                  izz=0.001) + '</link>')


def test_a_joint_whose_zero_is_outside_its_limits_starts_at_the_nearest_one_and_moves(
        tmp_path):
    """Before, the joint started at 0, 0.82 rad inside its limit: every step was rejected and
    the robot never moved, without a word beyond 'reduce dt'."""
    with pytest.warns(SimulationDetail, match="'hinge' starts at its lower limit 0.82 rad"):
        scene = load(tmp_path, _limited_pendulum(0.82, 5.46))
    sim = Stepper(scene)
    assert sim.angles[0] == pytest.approx(0.82, abs=1e-12)
    for _ in range(30):                          # gravity (3.6 N·m) presses it on its limit
        sim.step()
    assert sim.angles[0] == pytest.approx(0.82, abs=0.01)
    sim.set_torque('hinge', 8.0)                 # and 8 N·m lifts it off
    for _ in range(30):
        sim.step()
    assert sim.problem_totals['non_finite'] == sim.problem_totals['angle_aliased'] == 0
    assert sim.angles[0] > 0.9
    with pytest.warns(SimulationDetail, match='upper limit -0.5 rad'):
        assert load(tmp_path, _limited_pendulum(-2.0, -0.5)).joints[0].initial_position == -0.5


def test_initial_positions_outside_the_limits_are_refused_naming_the_joint(tmp_path):
    with pytest.raises(SceneError, match=r"initial_positions: 'hinge' = 100 rad is outside "
                                         r"the joint's limits \[-1, 1\] rad"):
        load(tmp_path, _limited_pendulum(-1.0, 1.0), initial_positions={'hinge': 100})
    scene = load(tmp_path, _limited_pendulum(-1.0, 1.0), initial_positions={'hinge': 100},
                 joints={'hinge': {'limit': None}})       # no limit: any start
    assert scene.joints[0].initial_position == 100


# ---- package:// URIs ----------------------------------------------------------------------

MESH_ROBOT = robot('<link name="base"><visual><geometry><mesh filename="package://my_robot/'
                   'meshes/base.stl"/></geometry></visual></link>'
                   + joint('hinge', 'continuous', 'base', 'arm')
                   + '<link name="arm">' + inertial() + '</link>')


def mesh_warnings(path, monkeypatch, env=None, **overrides):
    for key in ('ROS_PACKAGE_PATH', 'AMENT_PREFIX_PATH'):
        monkeypatch.delenv(key, raising=False)
    for key, value in (env or {}).items():
        monkeypatch.setenv(key, str(value))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        Scene.from_urdf(path, **overrides)
    return [str(w.message) for w in caught
            if w.category is SimulationDetail and 'mesh' in str(w.message)]


def test_package_uris_resolve_by_every_convention(tmp_path, monkeypatch):
    package = tmp_path / 'ws' / 'src' / 'my_robot'
    (package / 'meshes').mkdir(parents=True)
    (package / 'meshes' / 'base.stl').write_text('solid base\nendsolid base\n')
    elsewhere = write(tmp_path, MESH_ROBOT)
    assert mesh_warnings(elsewhere, monkeypatch, package_paths={'my_robot': str(package)}) == []
    assert mesh_warnings(elsewhere, monkeypatch, {'ROS_PACKAGE_PATH': package.parent}) == []
    assert mesh_warnings(elsewhere, monkeypatch, {'ROS_PACKAGE_PATH': package}) == []
    prefix = tmp_path / 'install'
    (prefix / 'share').mkdir(parents=True)
    (prefix / 'share' / 'my_robot').symlink_to(package)
    assert mesh_warnings(elsewhere, monkeypatch, {'AMENT_PREFIX_PATH': prefix}) == []
    (package / 'urdf').mkdir()
    inside = write(package / 'urdf', MESH_ROBOT)
    assert mesh_warnings(inside, monkeypatch) == []


def test_an_unresolved_mesh_is_a_warning_never_an_error(tmp_path, monkeypatch):
    messages = mesh_warnings(write(tmp_path, MESH_ROBOT), monkeypatch)
    assert len(messages) == 1
    assert "link 'base'" in messages[0] and 'package://my_robot/meshes/base.stl' in messages[0]
    assert 'drawn as a box' in messages[0]


# ---- scene YAML with urdf: and overrides ---------------------------------------------------

def test_scene_yaml_names_a_urdf_with_overrides(tmp_path):
    (tmp_path / 'robots').mkdir()
    (tmp_path / 'robots' / 'dp.urdf').write_text((DATA / 'double_pendulum.urdf').read_text())
    (tmp_path / 'dp.yaml').write_text(
        'urdf: robots/dp.urdf\nname: dp\ndt: 0.005\nsolver: {integrator: bdf1}\n'
        'initial_positions: {elbow: 0.25}\n'
        'joints: {shoulder: {damping: 0.5, torque_model: lever_arm}}\n')
    scene = Scene.from_yaml(tmp_path / 'dp.yaml')
    assert (scene.name, scene.dt, scene.solver.integrator) == ('dp', 0.005, 'bdf1')
    shoulder = scene.joints[scene.joint_index('shoulder')]
    assert (shoulder.damping, shoulder.torque_model) == (0.5, 'lever_arm')
    assert scene.joints[scene.joint_index('elbow')].initial_position == 0.25
    # the dumped scene stands alone (bags store it): same model without the URDF file
    again = Scene.from_yaml_text(scene.to_yaml())
    assert again.model_dump() == scene.model_dump() and again.robot_description is None


def test_loading_a_urdf_and_describing_and_drawing_scenes_import_no_warp():
    """Tools that only load and show scenes (URDF import, robot description, shapes, link
    frames, the renderer) do not pay for Warp."""
    loaded = modules_loaded_by(
        'from affine_joint_sim.poses import LinkFrames\n'
        'from affine_joint_sim.scene import Scene\n'
        'from affine_joint_sim.viz.description import robot_description\n'
        'from affine_joint_sim.viz.drawables import drawables\n'
        'import affine_joint_sim.viz.render\n'
        f'robot = Scene.from_urdf({str(ROBOTS / "arm6_gripper.urdf")!r})\n'
        f'arm = Scene.load({str(ROBOTS.parent / "scenes" / "arm.yaml")!r})\n'
        'for scene in (robot, arm):\n'
        '    robot_description(scene), drawables(scene), LinkFrames(scene)\n')
    assert 'affine_joint_sim.urdf.convert' in loaded and 'warp' not in loaded


def test_packaged_urdf_scenes_load_and_run():
    for name in ('arm6', 'arm6_gripper'):
        sim = Stepper(Scene.load(Path('msg_configs/scenes') / f'{name}.yaml'))
        for _ in range(5):
            sim.step()
        assert sim.stats['converged'] and not sim.stats['step_rejected']


# ---- traps: each a clear message naming the link or joint ---------------------------------

ARM = '<link name="arm">' + inertial() + '</link>'


def error_of(tmp_path, text, **overrides) -> str:
    with pytest.raises(SceneError) as info:
        load(tmp_path, text, **overrides)
    message = str(info.value)
    assert '\n' not in message and 'Traceback' not in message
    return message


def warnings_of(tmp_path, text, **overrides) -> list[str]:
    """The scene and what its load says item by item (the details behind its summary)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        scene = load(tmp_path, text, **overrides)
    assert all(issubclass(w.category, (SimulationWarning, SimulationDetail)) for w in caught)
    return scene, [str(w.message) for w in caught if w.category is SimulationDetail]


@pytest.mark.parametrize('link, words', [
    ('<link name="arm"/>', ["link 'arm' moves (joint 'hinge')", 'no mass']),
    ('<link name="arm">' + inertial(mass=0.0) + '</link>', ["link 'arm'", 'no mass']),
])
def test_a_moving_link_without_mass_is_an_error(tmp_path, link, words):
    message = error_of(tmp_path, robot('<link name="base"/>'
                                       + joint('hinge', 'continuous', 'base', 'arm') + link))
    assert all(w in message for w in words), message


def test_a_massless_link_on_a_fixed_joint_is_merged_as_a_frame(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm') + ARM
        + joint('tcp_joint', 'fixed', 'arm', 'tcp', '0 0 0.2') + '<link name="tcp"/>'),
        merge_fixed=False)
    assert said == [] and [b.name for b in scene.bodies] == ['base', 'arm']
    assert 'tcp' in [f.name for f in scene.frames]


def test_non_physical_inertia_is_fixed_with_a_warning(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm')
        + '<link name="arm">' + inertial(ixx=0.1, iyy=0.01, izz=0.01) + '</link>'))
    assert len(said) == 1 and "link 'arm'" in said[0] and 'triangle inequality' in said[0]
    moments = sorted(scene.bodies[1].inertia)
    assert moments[2] <= moments[0] + moments[1]         # physical now
    assert moments[2] == pytest.approx(0.1) and moments[0] > 0.01       # smallest change


def test_a_thin_rod_with_zero_axial_inertia_gets_a_floor(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm')
        + '<link name="arm">' + inertial(ixx=0.08, iyy=0.08, izz=0.0) + '</link>'))
    assert len(said) == 1 and 'degenerate' in said[0]
    assert min(scene.bodies[1].inertia) > 0.0


def test_negative_inertia_is_an_error(tmp_path):
    message = error_of(tmp_path, robot('<link name="base"/>' + joint('hinge', 'continuous',
                                                                     'base', 'arm')
                                       + '<link name="arm">' + inertial(ixx=-0.1) + '</link>'))
    assert "link 'arm'" in message and 'negative principal moment' in message


@pytest.mark.parametrize('limit, words', [
    ('', 'cannot move'),
    ('<limit effort="5" velocity="1"/>', 'cannot move'),
    ('<limit upper="0.5" effort="5" velocity="1"/>', 'one side of 0'),
])
def test_a_revolute_joint_without_bounds_says_what_the_spec_does(tmp_path, limit, words):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'revolute', 'base', 'arm', extra=limit) + ARM))
    assert any("joint 'hinge'" in m and 'no <limit lower upper>' in m and words in m
               for m in said), said
    limit = scene.joints[0].limit
    assert limit.lower == 0.0 and limit.upper in (0.0, 0.5)


@pytest.mark.parametrize('body, words', [
    ('<link name="base"/><link name="base"/>', "duplicate link name 'base'"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm') + ARM
     + joint('j', 'continuous', 'arm', 'arm2') + '<link name="arm2">' + inertial() + '</link>',
     "duplicate joint name 'j'"),
    ('<link name="base"/>' + joint('my joint', 'continuous', 'base', 'arm') + ARM,
     "joint name 'my joint' contains whitespace"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm') + ARM
     + joint('back', 'continuous', 'arm', 'base'), 'closed loop'),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm') + ARM
     + '<link name="c">' + inertial() + '</link>' + joint('k', 'continuous', 'arm', 'c')
     + joint('loop', 'continuous', 'base', 'c'), "link 'c' is the child of joints 'k' and "
                                                 "'loop': a closed kinematic loop"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'ghost'),
     "joint 'j': its child link 'ghost' is not defined"),
    ('<link name="base"/><link name="other"/>', '2 root links (base, other)'),
    ('<link name="base"/>' + joint('j', 'planar', 'base', 'arm') + ARM,
     "joint 'j': planar joints are not supported"),
    ('<link name="base"/>' + joint('j', 'hinge', 'base', 'arm') + ARM,
     "type 'hinge' is not a URDF joint type"),
    ('<link/>', '<link> has no name attribute'),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm', axis='0 0 0') + ARM,
     "joint 'j': <axis xyz> must be a non-zero vector"),
    ('<link name="base"/><joint name="j" type="fixed"><parent link="base"/></joint>',
     "<joint> 'j' needs <child"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm', 'nan 0 0') + ARM,
     "<origin> of joint 'j': xyz=\"nan 0 0\" must be 3 finite numbers"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm')
     + '<link name="arm">' + inertial(mass='inf') + '</link>',
     "<mass> of link 'arm': value=\"inf\" must be 1 finite number"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm')
     + '<link name="arm">' + inertial(mass=-1) + '</link>', "link 'arm': negative mass"),
    ('<link name="base"/>' + joint('j', 'revolute', 'base', 'arm',
                                   extra='<limit lower="-inf" upper="1"/>') + ARM,
     "joint 'j': <limit lower=\"-inf\" upper=\"1.0\"> must be finite"),
    ('<link name="base"/>' + joint('j', 'continuous', 'base', 'arm', '$(arg x) 0 0') + ARM,
     'is an unexpanded xacro or launch substitution'),
    ('', 'the robot has no <link>'),
])
def test_structural_traps_are_errors_naming_the_culprit(tmp_path, body, words):
    message = error_of(tmp_path, robot(body))
    assert words in message and 'robot.urdf' in message, message


@pytest.mark.parametrize('text, words', [
    ('<robot name="r"><link name="a"></robot>', 'not valid XML'),
    ('<scene/>', 'root element is <scene>, expected <robot>'),
    ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:macro name="m"/>'
     '<link name="a"/></robot>', 'xacro'),
    ('<robot name="r"><link name="a">' + inertial(mass='heavy') + '</link></robot>',
     'robot.urdf:1: <mass> of link \'a\': value="heavy" must be 1 finite number'),
])
def test_unparsable_files_are_errors_naming_the_file(tmp_path, text, words):
    message = error_of(tmp_path, text)
    assert words in message and 'robot.urdf' in message, message


def test_an_unreadable_file_is_an_error(tmp_path):
    with pytest.raises(SceneError, match=r'missing\.urdf: cannot read URDF file'):
        Scene.from_urdf(tmp_path / 'missing.urdf')


def test_dynamics_damping_and_friction_become_the_joint_terms(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm',
                                      extra='<dynamics damping="0.1" friction="0.5"/>') + ARM))
    assert (scene.joints[0].damping, scene.joints[0].friction) == (0.1, 0.5)
    assert not [m for m in said if 'friction' in m], said


def test_geometry_the_simulator_does_not_use_cannot_stop_a_robot(tmp_path):
    """pybullet's and Drake's <capsule>, an empty <geometry> or a mesh without a file: the
    visual is dropped with a note; collisions are never read."""
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"><visual><geometry><capsule radius="0.1" length="0.3"/></geometry>'
        '</visual><collision><geometry><capsule radius="1" length="2"/></geometry></collision>'
        '</link>' + joint('hinge', 'continuous', 'base', 'arm')
        + '<link name="arm">' + inertial() + '<visual><geometry/></visual><visual><geometry>'
        '<mesh/></geometry></visual></link>'))
    assert [b.name for b in scene.bodies] == ['base', 'arm']
    assert len(said) == 3, said
    assert "link 'base': a visual (line 3) with <capsule> geometry is not drawn" in said[0]
    assert 'with 0 shapes in its <geometry>' in said[1] and '<mesh> without a filename' in said[2]


def test_an_undefined_world_parent_is_the_world_and_infinite_bounds_no_limit(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        joint('weld', 'fixed', 'world', 'base') + '<link name="base">' + inertial(5.0)
        + '</link>' + joint('hinge', 'revolute', 'base', 'arm',
                            extra='<limit lower="-inf" upper="inf" effort="3"/>') + ARM))
    assert len(said) == 1 and "link 'world' is not defined but a joint's parent: taken as the " \
        'world' in said[0], said
    assert scene.bodies[0].fixed and scene.joints[0].limit is None
    assert scene.joints[0].effort_limit == 3.0


def test_a_floating_joint_leaves_its_child_free(tmp_path):
    scene, said = warnings_of(tmp_path, robot(
        '<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm') + ARM
        + joint('loose', 'floating', 'arm', 'ball') + '<link name="ball">' + inertial()
        + '</link>'))
    assert any("joint 'loose' is floating" in m for m in said), said
    assert [j.name for j in scene.joints] == ['hinge']
    assert not scene.bodies[scene.body_index('ball')].fixed


def test_free_base_needs_a_massive_root_and_fixed_base_does_not(tmp_path):
    text = robot('<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm') + ARM)
    assert load(tmp_path, text).bodies[0].fixed
    message = error_of(tmp_path, text, fixed_base=False)
    assert "link 'base' is the root of a free-base robot (fixed_base: false) but has no " \
        'mass' in message
    with pytest.warns(SimulationWarning, match='the robot floats'):
        free = load(tmp_path, robot('<link name="base">' + inertial(3.0) + '</link>'
                                    + joint('hinge', 'continuous', 'base', 'arm') + ARM),
                    fixed_base=False)
    assert not free.bodies[0].fixed


@pytest.mark.parametrize('overrides, words', [
    ({'initial_positions': {'nope': 1.0}}, "initial_positions: 'nope' is not a revolute"),
    ({'joints': {'nope': {'damping': 1.0}}}, "joints: 'nope' is not a joint of the robot"),
    ({'joints': {'hinge': {'damping': -1.0}}}, 'joints[0].damping'),
    ({'fixed_base': 'maybe'}, 'fixed_base'),
    ({'name': ''}, 'name: String should have at least 1 character'),     # as in a scene
    ({'colour': 'red'}, 'colour: unknown key; valid keys here: name, dt, gravity, solver, '
                        'fixed_base, merge_fixed, initial_positions, min_mass, package_paths, '
                        'joints'),
])
def test_bad_overrides_are_errors_naming_the_key(tmp_path, overrides, words):
    text = robot('<link name="base"/>' + joint('hinge', 'continuous', 'base', 'arm') + ARM)
    with pytest.raises(SceneError) as info:
        load(tmp_path, text, **overrides)
    assert words in str(info.value), str(info.value)


def test_names_outside_the_topic_alphabet_are_kept_and_clashes_refused(tmp_path):
    text = robot('<link name="base"/>' + joint('arm-joint.1', 'continuous', 'base', 'arm') + ARM)
    scene = load(tmp_path, text)
    assert scene.joints[0].name == 'arm-joint.1'
    clash = robot('<link name="base"/>' + joint('a-b', 'continuous', 'base', 'arm') + ARM
                  + joint('a_b', 'continuous', 'arm', 'arm2') + '<link name="arm2">'
                  + inertial() + '</link>')
    with pytest.raises(SceneError, match="share the topic token 'a_b'"):
        load(tmp_path, clash)


# ---- the rigid reference of a converted URDF against Pinocchio's reading of the URDF ------

GRIPPER_START = {'shoulder_lift': 0.3, 'elbow': 0.6, 'wrist_1': -0.4, 'left_finger_joint': 0.01,
                 'right_finger_joint': 0.01}


@pytest.mark.parametrize('urdf, start', [
    (ROBOTS / 'arm6.urdf', {'shoulder_lift': 0.3, 'elbow': 0.6, 'wrist_1': -0.4}),
    (DATA / 'arm3.urdf', {'pan': 0.2, 'lift': 0.5, 'elbow': 0.7}),
    (ROBOTS / 'arm6_gripper.urdf', dict(GRIPPER_START)),
])
def test_rigid_reference_of_our_scene_equals_pinocchio_on_the_urdf(urdf, start):
    """Pinocchio (optional extra ``reference``) reads the URDF itself: our conversion (inertia
    rotation, welding, forward kinematics) and the reference built on it must agree with it."""
    pytest.importorskip('pinocchio')
    from affine_joint_sim.bench.pinocchio_ref import PinocchioArm

    scene = Scene.from_urdf(urdf, initial_positions=start)
    torques = np.linspace(0.5, -0.2, len(scene.joints))
    times = 0.1 * np.arange(1, 5)
    ours, _ = RigidTree(scene).simulate(torques, times, step=1e-3)
    np.testing.assert_allclose(ours, PinocchioArm(urdf, scene).simulate(torques, times),
                               atol=1e-8)


def test_light_fingers_pushed_apart_on_a_heavy_arm_follow_the_rigid_reference():
    """Two 0.05 kg prismatic fingers on a 10 kg arm, forced apart while the arm falls: every
    joint within 2e-4 of the rigid multibody reference over 0.1 s at dt 1e-3 (measured 3.7e-5;
    6.3e-3 on a wrist when the fingers' force pairs acted at the centres of mass)."""
    scene = Scene.from_urdf(ROBOTS / 'arm6_gripper.urdf', initial_positions=GRIPPER_START,
                            dt=1e-3)
    torques = {'shoulder_lift': -3.0, 'left_finger_joint': 0.02, 'right_finger_joint': -0.02}
    sim = Stepper(scene)
    for name, value in torques.items():
        sim.set_torque(name, value)
    samples = []
    for i in range(100):
        sim.step()
        if (i + 1) % 10 == 0:
            samples.append(sim.angles)
    reference, _ = RigidTree(scene).simulate([torques.get(j.name, 0.0) for j in scene.joints],
                                             0.01 * np.arange(1, 11), step=1e-4)
    assert np.abs(np.array(samples) - reference).max() < 2e-4


def test_a_zero_width_limit_says_it_locks_the_joint(tmp_path):
    """SolidWorks exports (and example-robot-data's double pendulums) give lower = upper = 0:
    the joint was locked without a word."""
    with pytest.warns(SimulationDetail, match="'hinge' .revolute. has lower = upper = 0: its "
                                               'limit locks it there'):
        load(tmp_path, _limited_pendulum(0, 0))


def test_min_mass_gives_a_massless_moving_link_a_mass(tmp_path):
    """A massless link between two joints is an error naming the remedy; min_mass gives it
    that mass (as MuJoCo's boundmass does) and the robot runs."""
    text = robot('<link name="base"/>' + joint('pan', 'revolute', 'base', 'ghost', '0 0 1',
                                               axis='0 0 1', extra='<limit lower="-3" upper="3" '
                                                                   'effort="10" velocity="1"/>')
                 + '<link name="ghost"/>'
                 + joint('hinge', 'continuous', 'ghost', 'arm')
                 + '<link name="arm">' + inertial(1.0, '0 0 -0.5', ixx=0.08, iyy=0.08,
                                                  izz=0.001) + '</link>')
    with pytest.raises(SceneError, match="'ghost' moves .* or set min_mass"):
        load(tmp_path, text)
    with pytest.warns(SimulationDetail) as said:       # its mass, then its inertia floor
        scene = load(tmp_path, text, min_mass=0.01)
    assert "'ghost' weighs 0 kg: given min_mass 0.01 kg" in str(said[0].message)
    assert "'ghost': inertia [0, 0, 0] is (nearly) degenerate" in str(said[1].message)
    assert scene.bodies[scene.body_index('ghost')].mass == 0.01
    sim = Stepper(scene)
    for _ in range(20):
        sim.step()
    assert sim.stats['converged']


def test_a_floating_robot_is_told_it_falls(tmp_path):
    """Before, fixed_base: false fell forever without a word."""
    with pytest.warns(SimulationWarning, match='the robot floats .fixed_base: false. and there '
                                               'is no ground'):
        scene = load(tmp_path, _limited_pendulum(-1, 1).replace(
            '<link name="base"/>', '<link name="base">' + inertial(2.0) + '</link>'),
            fixed_base=False)
    assert not any(body.fixed for body in scene.bodies)


@pytest.mark.parametrize('body, words', [
    (joint('j', 'continuous', 'base', 'arm', axis='0 1'),
     ':3: <axis> of joint \'j\': xyz="0 1" must be 3 finite numbers'),
    (joint('j', 'continuous', 'base', 'arm', axis='0 0 1 0'),
     '<axis> of joint \'j\': xyz="0 0 1 0" must be 3 finite numbers'),
    (joint('j', 'continuous', 'base', 'arm').replace('<origin xyz="0 0 0"/>',
                                                     '<origin rpy="0 0 0 1"/>'),
     '<origin> of joint \'j\': rpy="0 0 0 1" must be 3 finite numbers'),
    (joint('j', 'revolute', 'base', 'arm', extra='<limit lower="low" upper="1"/>'),
     '<limit> of joint \'j\': lower="low" must be 1 finite number (or ±inf)'),
])
def test_malformed_numbers_are_one_line_naming_file_line_element_and_joint(tmp_path, body,
                                                                           words):
    """Before: a traceback (a 2-number axis), a NumPy matmul message naming nothing (4
    numbers), accepted silently (4 rpy numbers), or no element named (non-numeric)."""
    message = error_of(tmp_path, robot('<link name="base"/>' + body + ARM))
    assert words in message and 'robot.urdf' in message, message


def test_an_inertia_without_a_moment_is_refused_not_read_as_one(tmp_path):
    """Before, a missing ixx was silently read as 1 kg·m²."""
    arm = '<link name="arm">' + inertial().replace('ixx="0.01" ', '') + '</link>'
    message = error_of(tmp_path, robot('<link name="base"/>'
                                       + joint('j', 'continuous', 'base', 'arm') + arm))
    assert "<inertia> of link 'arm' needs ixx=\"...\" (1 number)" in message, message


@pytest.mark.parametrize('name', ['robot.xml', 'robot', 'robot.URDF'])
def test_a_urdf_is_told_by_its_content_whatever_its_name(tmp_path, name):
    """Before, anything not named .urdf was read as YAML ('a scene must be a mapping')."""
    scene = Scene.load(write(tmp_path, PENDULUM, name))
    assert [j.name for j in scene.joints] == ['hinge']


def test_an_unexpanded_xacro_gets_the_xacro_hint_first(tmp_path):
    """Before: 'the robot has no <link>' from the API (its links are inside macros), and the
    YAML reader's complaint from the command line (.xacro was read as YAML)."""
    text = ('<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
            '<xacro:macro name="leg"><link name="l"/></xacro:macro></robot>\n')
    for name in ('robot.urdf.xacro', 'robot.xacro'):
        with pytest.raises(SceneError, match='contains xacro macros: expand it first'):
            Scene.load(write(tmp_path, text, name))


def test_objects_stand_beside_the_robot_with_a_frame_a_visual_and_contact():
    """``objects`` add bodies of their own beside a URDF robot: where they are placed, drawn as
    their shapes, a frame of their name (body_poses), touching the links' <collision> unless
    excluded by name; an object named as a link is refused naming both."""
    box = {'name': 'crate', 'mass': 0.5, 'shape': {'box': [0.1, 0.1, 0.1]},
           'position': [0.6, 0.0, 0.05], 'collision': 'shape'}
    scene = Scene.from_urdf(ROBOTS / 'arm6_gripper.urdf', objects=[box], ground={'height': 0.0},
                            contact={'exclude': [['crate', 'forearm']]})
    crate = scene.bodies[scene.body_index('crate')]
    assert crate.position == (0.6, 0.0, 0.05) and not crate.fixed
    assert any(v.body == 'crate' and v.geometry.box == (0.1, 0.1, 0.1) for v in scene.visuals)
    assert [f.body for f in scene.frames if f.name == 'crate'] == ['crate']
    assert ('crate', 'forearm') in scene.contact.exclude
    assert scene.bodies[scene.body_index('left_finger')].collision      # links touch it
    with pytest.raises(SceneError, match=r"objects\[0\]\.name: 'forearm' is a link of the robot"):
        Scene.from_urdf(ROBOTS / 'arm6_gripper.urdf', objects=[{**box, 'name': 'forearm'}],
                        ground={'height': 0.0})
