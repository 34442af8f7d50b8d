"""What viewers get, without DDS: marker and pose messages against the bodies' rigid poses
(computed here by SVD), marker types and sizes against the shapes, the sim-time schedule,
in-place patched bytes against rclpy's own serialization, the quaternion and nearest-rotation
helpers, and the URDF generated for YAML scenes."""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseArray
from rclpy.serialization import deserialize_message
from visualization_msgs.msg import Marker, MarkerArray

from affine_joint_sim.ros.patched import PatchedMessage
from affine_joint_sim.ros.viz import VizMessages, VizSchedule
from affine_joint_sim.rotations import rotation_matrix
from affine_joint_sim.scene import Orientation, Scene
from affine_joint_sim.stepper import Stepper
from affine_joint_sim.viz.description import robot_description

SCENES = Path(__file__).resolve().parent.parent / 'msg_configs' / 'scenes'


def polar(a):
    """The rotation of A's polar decomposition, U Vᵀ of its SVD."""
    u, _, vt = np.linalg.svd(a)
    return u @ vt


def matrix(pose) -> np.ndarray:
    out = np.eye(4)
    o = pose.orientation
    out[:3, :3] = rotation_matrix(Orientation(quat_xyzw=(o.x, o.y, o.z, o.w)))
    out[:3, 3] = pose.position.x, pose.position.y, pose.position.z
    return out


def strained_run(name, steps=30):
    sim = Stepper(Scene.load(SCENES / f'{name}.yaml'))
    for k, joint in enumerate(sim.command_joint_names):
        sim.set_torque(joint, 0.8 * (-1) ** k)
    for _ in range(steps):
        sim.step()
    return sim


def test_markers_sit_at_the_bodies_rigid_poses_with_their_shapes():
    sim = strained_run('arm')
    q = sim.body_q
    raw, _ = VizMessages(sim, 'world').update(1_230_000_000)
    markers = deserialize_message(raw, MarkerArray).markers
    assert len(markers) == len(sim.scene.bodies)
    for k, (marker, body) in enumerate(zip(markers, sim.scene.bodies)):
        expected = np.eye(4)
        expected[:3, :3] = polar(q[k, 3:].reshape(3, 3))
        expected[:3, 3] = q[k, :3]
        np.testing.assert_allclose(matrix(marker.pose), expected, atol=1e-9)
        assert (marker.ns, marker.id, marker.header.frame_id) == (body.name, k, 'world')
        assert (marker.header.stamp.sec, marker.header.stamp.nanosec) == (1, 230_000_000)
        assert marker.color.a == 1.0 and marker.action == Marker.ADD
        scale = (marker.scale.x, marker.scale.y, marker.scale.z)
        if body.shape.kind == 'box':
            assert marker.type == Marker.CUBE and scale == tuple(body.shape.box)
        elif body.shape.kind == 'cylinder':
            d = 2 * body.shape.cylinder.radius
            assert marker.type == Marker.CYLINDER            # RViz's cylinder axis is its z
            assert scale == (d, d, body.shape.cylinder.length)
        else:
            assert marker.type == Marker.SPHERE and scale == (2 * body.shape.sphere.radius,) * 3


def test_urdf_markers_are_its_visuals_and_body_poses_its_link_frames():
    sim = strained_run('arm6_gripper')
    markers, poses = VizMessages(sim, 'map').update(0)
    markers = deserialize_message(markers, MarkerArray).markers
    visuals = sim.scene.visuals
    assert len(markers) == len(visuals) == 10         # fingers, hand, links; world's base
    transforms = dict(zip(sim.body_names, sim.body_transforms))
    for marker, visual in zip(markers, visuals):
        body = transforms[visual.body].copy()
        body[:3, :3] = polar(body[:3, :3])
        local = np.eye(4)
        local[:3, :3] = rotation_matrix(visual.orientation)
        local[:3, 3] = visual.position
        np.testing.assert_allclose(matrix(marker.pose), body @ local, atol=1e-9)
        assert marker.header.frame_id == 'map'
        assert (marker.color.r, marker.color.g, marker.color.b, marker.color.a) == \
            pytest.approx(tuple(visual.color))          # the URDF's named materials
    frames = deserialize_message(poses, PoseArray)
    assert len(frames.poses) == len(sim.link_names)
    for pose, expected in zip(frames.poses, sim.link_transforms):
        np.testing.assert_allclose(matrix(pose), expected, atol=1e-9)


def test_patching_changes_only_poses_and_stamps():
    sim = strained_run('double_pendulum')
    views = VizMessages(sim, 'world')
    first = deserialize_message(views.update(0)[0], MarkerArray)
    for stamp in (999_999_999, 2_000_000_001):
        sim.step()
        later = deserialize_message(views.update(stamp)[0], MarkerArray)
        assert [(m.header.stamp.sec, m.header.stamp.nanosec) for m in later.markers] == \
            [divmod(stamp, 1_000_000_000)] * len(later.markers)
        assert [m.pose for m in later.markers] != [m.pose for m in first.markers]
        for m, f in zip(later.markers, first.markers):
            m.pose, m.header.stamp = f.pose, f.header.stamp
        assert later == first                        # every other field as built
    msg = PoseArray()
    msg.header.frame_id = 'odom'
    patched = PatchedMessage(msg, [], [msg.header])
    back = deserialize_message(patched.update(np.zeros(0), 7_000_000_005), PoseArray)
    assert (back.header.stamp.sec, back.header.stamp.nanosec, back.header.frame_id) == (
        7, 5, 'odom')


def test_stats_say_how_far_the_bodies_are_from_rigid():
    sim = strained_run('arm')
    a = sim.body_q[1:, 3:].reshape(-1, 3, 3)
    expected = max(np.linalg.norm(m @ m.T - np.eye(3)) for m in a)
    assert sim.stats['rotation_strain'] == pytest.approx(expected, rel=1e-9)
    assert 0 < expected < 1e-3


@pytest.mark.parametrize('rate, dt, count', [(30.0, 0.01, 31), (10.0, 0.01, 11),
                                             (100.0, 0.01, 101), (30.0, 0.05, 21),
                                             (0.0, 0.01, 0)])
def test_views_follow_viz_rate_in_sim_time(rate, dt, count):
    schedule = VizSchedule(rate)
    times = [k * round(dt * 1e9) for k in range(round(1.0 / dt) + 1)]
    due = [t for t in times if schedule.due(t)]
    assert len(due) == count
    if rate:
        # each view is the first step at or after a multiple of 1/rate
        assert all(math.floor(t * 1e-9 * rate + 1e-9) > math.floor((t - dt * 1e9) * 1e-9 * rate
                                                                   + 1e-9) for t in due[1:])
        schedule.reset()
        assert schedule.due(due[-1])                 # after a reset the next state is sent


@pytest.mark.parametrize('name', ['pendulum', 'double_pendulum', 'arm', 'wheel', 'gantry',
                                  'arm_gripper'])
def test_generated_urdf_loads_back_to_the_same_bodies(name, tmp_path):
    """The URDF made for a YAML scene, read by the URDF loader: the same masses, centres of
    mass, principal moments, joint types, limits and damping."""
    scene = Scene.load(SCENES / f'{name}.yaml')
    path = tmp_path / f'{name}.urdf'
    path.write_text(robot_description(scene))
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        back = Scene.from_urdf(path, merge_fixed=False)
    for body in scene.bodies:
        if body.fixed:
            continue
        other = back.bodies[back.body_index(body.name)]
        assert other.mass == pytest.approx(Stepper(scene)._host.body_mass[
            scene.body_index(body.name)], rel=1e-12)
        np.testing.assert_allclose(other.position, body.position, atol=1e-12)
    for joint in scene.joints:
        other = back.joints[back.joint_index(joint.name)]
        assert other.type == joint.type
        assert other.damping == joint.damping
        if joint.limit is not None:
            assert (other.limit.lower, other.limit.upper) == (joint.limit.lower,
                                                              joint.limit.upper)


def test_the_foxglove_layout_shows_the_topics_the_node_publishes():
    import json

    from affine_joint_sim.ros.topics import load_topics

    layout = json.loads((SCENES.parent / 'foxglove_layout.json').read_text())
    names = {'/' + t.name() for t in load_topics().values() if '{joint}' not in t.template}
    panel = layout['configById']['3D!affine_joint_sim']
    assert set(panel['topics']) <= names
    assert panel['layers']['robot_description']['topic'] in names
    assert panel['followTf'] == 'world'
    for key in ('Plot!joint_positions', 'Plot!joint_efforts'):
        paths = [p['value'] for p in layout['configById'][key]['paths']]
        assert paths and all(p.split('.')[0] in names for p in paths)
    panels = {layout['layout']['first'], *layout['layout']['second'].values()} - {'column'}
    assert panels == set(layout['configById'])
