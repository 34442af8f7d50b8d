"""Sensors in Python (affine_joint_sim.sensors, Stepper.sensors): IMU and contact readings
against closed forms, URDF link frames, batches, and the scene checks of the ``sensors`` list."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, SceneError, Stepper
from affine_joint_sim.poses import rigid_transforms
from affine_joint_sim.rotations import quaternion_matrix, rpy_matrix
from affine_joint_sim.sim_warnings import SimulationWarning
from test_scene import BASE as SCENE_BASE

G = 9.81
ROOT = Path(__file__).resolve().parents[1]
ARM3 = ROOT / 'test' / 'data' / 'urdf' / 'arm3.urdf'
TILT = (0.3, -0.2, 0.1)         # rpy of the tilted frame on the box


def _resting_box(**extra) -> dict:
    """A 1 kg box turned 0.4 rad about z, started just above where it rests on the ground,
    and a second one dropped from 1 m."""
    return {
        'name': 'boxes', 'dt': 0.01, 'ground': {'height': 0.0}, 'contact': {},
        'bodies': [{'name': 'box', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0,
                    'position': [0.0, 0.0, 0.0507], 'orientation': {'rpy': [0.0, 0.0, 0.4]},
                    'collision': 'shape'},
                   {'name': 'dropped', 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0,
                    'position': [1.0, 0.0, 1.0], 'collision': 'shape'}],
        'frames': [{'name': 'box', 'body': 'box'},
                   {'name': 'tilted', 'body': 'box', 'position': [0.02, 0.0, 0.05],
                    'orientation': {'rpy': list(TILT)}},
                   {'name': 'edge', 'body': 'box', 'position': [0.05, 0.0, 0.0]}],
        'sensors': [{'name': 'imu', 'type': 'imu', 'body': 'box'},
                    {'name': 'tilted_imu', 'type': 'imu', 'body': 'tilted'},
                    {'name': 'touch', 'type': 'contact', 'body': 'box'},
                    {'name': 'edge_touch', 'type': 'contact', 'body': 'edge'},
                    {'name': 'falling_imu', 'type': 'imu', 'body': 'dropped'},
                    {'name': 'falling_touch', 'type': 'contact', 'body': 'dropped'}],
        **extra}


def _rotation(q_xyzw) -> np.ndarray:
    return quaternion_matrix(*q_xyzw)


def test_an_imu_on_a_resting_box_reads_its_orientation_no_turn_and_gravity_up():
    sim = Stepper(Scene.from_dict(_resting_box()))
    up = np.array([0.0, 0.0, G])
    tilt = rpy_matrix(*TILT)
    # before the first step: the reading at rest, −g in the sensor frame
    start = sim.sensors
    np.testing.assert_allclose(start['imu']['linear_acceleration'], rpy_matrix(0, 0, 0.4).T @ up,
                               atol=1e-12)
    np.testing.assert_array_equal(start['imu']['angular_velocity'], 0.0)
    for _ in range(20):
        sim.step()
    # the dropped box falls freely: its accelerometer reads 0 (a = g)
    np.testing.assert_allclose(sim.sensors['falling_imu']['linear_acceleration'], 0.0, atol=1e-9)
    for _ in range(180):
        sim.step()
    assert sim.stats['contacts'] >= 4
    body = rigid_transforms(sim.body_q[0])[:3, :3]
    link = dict(zip(sim.link_names, sim.link_transforms))
    readings = sim.sensors
    imu, tilted = readings['imu'], readings['tilted_imu']
    # orientation: the box's, turned 0.4 rad about z (it rests flat)
    np.testing.assert_allclose(_rotation(imu['orientation']), body, atol=1e-12)
    np.testing.assert_allclose(body, rpy_matrix(0, 0, 0.4), atol=1e-5)
    np.testing.assert_allclose(_rotation(tilted['orientation']), link['tilted'][:3, :3],
                               atol=1e-12)
    assert imu['orientation'][3] > 0.0 and np.linalg.norm(imu['orientation']) == \
        pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(imu['angular_velocity'], 0.0, atol=1e-6)
    np.testing.assert_allclose(tilted['angular_velocity'], 0.0, atol=1e-6)
    # the accelerometer: +9.81 along the world up axis, in its frame
    np.testing.assert_allclose(imu['linear_acceleration'], up, atol=1e-3)
    np.testing.assert_allclose(tilted['linear_acceleration'], (body @ tilt).T @ up, atol=1e-3)
    # a reset reads the rest value again, before any step
    sim.reset()
    np.testing.assert_array_equal(sim.sensors['tilted_imu']['linear_acceleration'],
                                  start['tilted_imu']['linear_acceleration'])


def test_a_contact_sensor_on_a_resting_box_carries_its_weight_and_its_moment():
    sim = Stepper(Scene.from_dict(_resting_box()))
    for _ in range(20):
        sim.step()
    # the dropped box touches nothing yet: exactly zero
    falling = sim.sensors['falling_touch']
    np.testing.assert_array_equal(falling['force'], 0.0)
    np.testing.assert_array_equal(falling['torque'], 0.0)
    for _ in range(180):
        sim.step()
    readings = sim.sensors
    weight = np.array([0.0, 0.0, 1.0 * G])
    # in the box's frame (z up, turned about z): the ground carries its weight, centred
    np.testing.assert_allclose(readings['touch']['force'], weight, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(readings['touch']['torque'], 0.0, atol=1e-6)
    # about a point 5 cm to the box's +x: the weight's moment 0.05 m · m g about its y axis
    np.testing.assert_allclose(readings['edge_touch']['force'], weight, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(readings['edge_touch']['torque'], [0.0, 0.05 * G, 0.0],
                               rtol=1e-4, atol=1e-6)
    # the sum of the contacts of sim.contacts, rotated into the box's frame
    body = rigid_transforms(sim.body_q[0])[:3, :3]
    total = sum(c['normal_force'] * c['normal'] + c['friction_force'] for c in sim.contacts
                if c['body'] == 'box')
    np.testing.assert_allclose(body @ readings['touch']['force'], total, rtol=1e-12, atol=1e-12)


def test_an_imu_on_a_spinning_body_reads_its_rate_and_the_centripetal_acceleration():
    # a body tilted in space spins at w about its own z axis (a principal axis), gravity off;
    # a frame 0.5 m out on its x axis moves on a circle: a = −w² r towards the axis
    w, r, dt = 2.0, 0.5, 0.001
    axes = rpy_matrix(0.3, -0.2, 0.5)
    sim = Stepper(Scene.from_dict({
        'name': 'spin', 'dt': dt, 'gravity': [0.0, 0.0, 0.0],
        'bodies': [{'name': 'plate', 'shape': {'box': [0.4, 0.3, 0.1]}, 'mass': 2.0,
                    'position': [1.0, 2.0, 3.0], 'linear_velocity': [0.3, 0.0, 0.0],
                    'orientation': {'rpy': [0.3, -0.2, 0.5]},
                    'angular_velocity': (axes @ [0.0, 0.0, w]).tolist()}],
        'frames': [{'name': 'rim', 'body': 'plate', 'position': [r, 0.0, 0.0]}],
        'sensors': [{'name': 'centre', 'type': 'imu', 'body': 'plate'},
                    {'name': 'rim_imu', 'type': 'imu', 'body': 'rim'}]}))
    np.testing.assert_allclose(sim.sensors['centre']['angular_velocity'], [0, 0, w], atol=1e-12)
    for _ in range(200):
        sim.step()
    centre, rim = sim.sensors['centre'], sim.sensors['rim_imu']
    # ω in its own frame stays (0, 0, w) (BDF2 loses ~(ω dt)² of the rate per step)
    np.testing.assert_allclose(centre['angular_velocity'], [0.0, 0.0, w], rtol=1e-4, atol=1e-8)
    np.testing.assert_allclose(rim['angular_velocity'], centre['angular_velocity'], atol=1e-12)
    # the centre moves at a constant velocity: no acceleration
    np.testing.assert_allclose(centre['linear_acceleration'], 0.0, atol=1e-8)
    # the rim: −ω² r along its x axis; the difference of the last step lags half a step, a
    # tangential ω³ r dt / 2 (1e-3 of the centripetal reading here)
    rate = centre['angular_velocity'][2]
    ax, ay, az = rim['linear_acceleration']
    assert ax == pytest.approx(-rate * rate * r, rel=1e-5)
    assert ay == pytest.approx(rate ** 3 * r * dt / 2, rel=1e-2)
    assert abs(az) < 1e-8
    np.testing.assert_allclose(_rotation(rim['orientation']), sim.link_transforms[0][:3, :3],
                               atol=1e-12)


def test_reading_sensors_changes_nothing_and_a_batch_equals_single_runs():
    def pendulum(**extra):
        return Scene.from_dict({
            'name': 'p', 'dt': 0.01,
            'bodies': [{'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'mass': 1.0,
                        'fixed': True},
                       {'name': 'link', 'shape': {'box': [0.1, 0.1, 1.0]}, 'mass': 1.0,
                        'position': [0.0, 0.0, -0.5]}],
            'joints': [{'name': 'hinge', 'parent': 'base', 'child': 'link',
                        'x0': [-0.05, 0, 0], 'x1': [0.05, 0, 0]}], **extra})

    sensors = {'sensors': [{'name': 'imu', 'type': 'imu', 'body': 'link'},
                           {'name': 'base_imu', 'type': 'imu', 'body': 'base'}]}
    plain, watched = Stepper(pendulum()), Stepper(pendulum(**sensors))
    batch = Stepper(pendulum(**sensors), num_envs=2)
    assert plain.sensors == {} and watched.sensor_names == ['imu', 'base_imu']
    batch.set_torque('hinge', np.array([0.0, 1.5]))
    watched.set_torque('hinge', 1.5)
    plain.set_torque('hinge', 1.5)
    for _ in range(30):
        for sim in (plain, watched, batch):
            sim.step()
        watched.sensors, batch.sensors            # read every step: nothing changes
    np.testing.assert_array_equal(plain.body_q, watched.body_q)
    single, batched = watched.sensors, batch.sensors
    for name, reading in single.items():
        for key, value in reading.items():
            assert batched[name][key].shape == (2, len(value))
            np.testing.assert_array_equal(batched[name][key][1], value)
    assert np.abs(single['imu']['angular_velocity']).max() > 0.1
    # the fixed base reads no turn and gravity up
    np.testing.assert_array_equal(single['base_imu']['angular_velocity'], 0.0)
    np.testing.assert_allclose(single['base_imu']['linear_acceleration'], [0, 0, G], atol=1e-12)


def test_a_sensor_on_a_welded_urdf_link_sits_at_the_link_frame():
    scene = Scene.from_urdf(ARM3, sensors=[
        {'name': 'tool_imu', 'type': 'imu', 'body': 'tool'},
        {'name': 'forearm_imu', 'type': 'imu', 'body': 'forearm'}])
    names = [b.name for b in scene.bodies]
    assert 'tool' not in names            # welded into the forearm's body
    sim = Stepper(scene)
    sim.set_torque('elbow', 0.5)
    sim.set_torque('pan', 0.3)
    for _ in range(40):
        sim.step()
    link = dict(zip(sim.link_names, sim.link_transforms))
    tool, forearm = sim.sensors['tool_imu'], sim.sensors['forearm_imu']
    np.testing.assert_allclose(_rotation(tool['orientation']), link['tool'][:3, :3], atol=1e-12)
    np.testing.assert_allclose(_rotation(forearm['orientation']), link['forearm'][:3, :3],
                               atol=1e-12)
    # one body, one rotation rate, each in its own frame
    omega = link['tool'][:3, :3] @ tool['angular_velocity']
    np.testing.assert_allclose(link['forearm'][:3, :3] @ forearm['angular_velocity'], omega,
                               atol=1e-12)
    assert np.linalg.norm(omega) > 0.05


def test_the_urdf_entry_takes_sensors_and_names_a_wrong_link(tmp_path):
    scene = tmp_path / 'arm.yaml'
    scene.write_text(f'urdf: {ARM3}\nsensors:\n  - {{name: tool_imu, type: imu, body: tool}}\n')
    assert [s.body for s in Scene.load(scene).sensors] == ['tool']
    scene.write_text(f'urdf: {ARM3}\nsensors:\n  - {{name: tool_imu, type: imu, body: tol}}\n')
    with pytest.raises(SceneError) as info:
        Scene.load(scene)
    lines = str(info.value).splitlines()
    assert len(lines) == 2 and lines[1].startswith('  sensors[0].body: unknown link or body '
                                                   "'tol'; valid: base, turret, "), lines
    assert 'tool' in lines[1]


def test_a_contact_sensor_that_cannot_touch_is_warned_about_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        Stepper(Scene.from_dict(_resting_box()))          # every one of them can touch
        no_contact = _resting_box()
        del no_contact['ground'], no_contact['contact']
        Stepper(Scene.from_dict(no_contact))
        bare = _resting_box()
        del bare['bodies'][1]['collision']
        Stepper(Scene.from_dict(bare))
    said = [str(w.message) for w in caught if issubclass(w.category, SimulationWarning)]
    assert said == [
        "contact sensor 'touch' on body 'box' always reads zero: the scene has no contact "
        '(give contact or ground)',
        "contact sensor 'edge_touch' on link 'edge' (body 'box') always reads zero: the scene "
        'has no contact (give contact or ground)',
        "contact sensor 'falling_touch' on body 'dropped' always reads zero: the scene has no "
        'contact (give contact or ground)',
        "contact sensor 'falling_touch' on body 'dropped' always reads zero: the body has no "
        'collision geometry']


BASE = SCENE_BASE + '''sensors:
  - {name: imu, type: imu, body: link}
'''


@pytest.mark.parametrize('edit, path, hint', [
    (('body: link}', 'body: lnk}'), 'sensors[0].body', "unknown body 'lnk'; valid: base, link"),
    (('type: imu', 'type: lidar'), 'sensors[0].type', "Input should be 'imu' or 'contact'"),
    (('name: imu,', 'name: my-imu,'), 'sensors[0].name',
     "'my-imu' is not a ROS topic token (letters, digits and single underscores, not starting "
     "with a digit or ending with an underscore; e.g. 'my_imu')"),
    (('name: imu,', 'name: 9imu,'), 'sensors[0].name', "e.g. '_9imu'"),
    (('name: imu,', 'name: "a b",'), 'sensors[0].name', 'without whitespace'),
    (('body: link}', 'body: link}\n  - {name: imu, type: contact, body: base}'),
     'sensors[1].name', "duplicate name 'imu' (also sensors[0])"),
    (('body: link}', 'body: link, rate: 100}'), 'sensors[0].rate',
     'unknown key; valid keys here: name, type, body'),
    (('type: imu, ', ''), 'sensors[0].type', 'Field required'),
])
def test_invalid_sensors_name_the_key_path_in_one_line(edit, path, hint):
    with pytest.raises(SceneError) as info:
        Scene.from_yaml_text(BASE.replace(*edit), source='scene.yaml')
    lines = str(info.value).splitlines()
    assert lines[0] == 'scene.yaml: invalid scene (1 problem)'
    assert len(lines) == 2 and lines[1].startswith(f'  {path}: ') and hint in lines[1], lines


def test_sensors_round_trip_through_yaml():
    scene = Scene.from_yaml_text(BASE)
    again = Scene.from_yaml_text(scene.to_yaml())
    assert again == scene and again.sensors[0].type == 'imu'


def _imu_reference(q, q_dot, q_dot_before, offset, dt, gravity):
    """An IMU's (orientation, ω, specific force) in its frame, at ``offset`` on a body with
    the frame's axes its own, by NumPy: the polar rotation by SVD (poses.rigid_transforms),
    ω from the skew part of Ȧ A⁻¹, the backward difference of the offset point's velocity."""
    rotation = rigid_transforms(q)[:3, :3]
    w = q_dot[3:].reshape(3, 3) @ np.linalg.inv(q[3:].reshape(3, 3))
    omega = 0.5 * np.array([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]])
    velocity = [v[:3] + v[3:].reshape(3, 3) @ offset for v in (q_dot, q_dot_before)]
    specific = (velocity[0] - velocity[1]) / dt - gravity
    return rotation, rotation.T @ omega, rotation.T @ specific


def test_the_kernels_readings_are_numpys_of_the_same_states():
    # tumbling boxes in every orientation (each branch of the quaternion), an IMU at the centre
    # of each and one off it; gravity on
    rng = np.random.default_rng(1)
    angles = rng.uniform(-3.0, 3.0, (12, 3))
    angles[:3] = [[np.pi, 0.0, 0.0], [0.0, np.pi, 0.0], [0.0, 0.0, np.pi]]   # half turns
    scene = Scene.from_dict({
        'name': 'tumbling', 'dt': 0.002,
        'bodies': [{'name': f'box{i}', 'shape': {'box': [0.3, 0.2, 0.1]}, 'mass': 1.0,
                    'position': [float(i), 0.0, 1.0], 'orientation': {'rpy': rpy.tolist()},
                    'angular_velocity': rng.uniform(-5.0, 5.0, 3).tolist()}
                   for i, rpy in enumerate(angles)],
        'frames': [{'name': f'off{i}', 'body': f'box{i}', 'position': [0.1, -0.05, 0.02]}
                   for i in range(len(angles))],
        'sensors': [{'name': f'imu_{where}{i}', 'type': 'imu', 'body': f'{where}{i}'}
                    for i in range(len(angles)) for where in ('box', 'off')]})
    sim = Stepper(scene)
    for _ in range(5):
        before = sim.body_qdot.copy()
        sim.step()
    readings, q, q_dot = sim.sensors, sim.body_q, sim.body_qdot
    for i in range(len(angles)):
        for where, offset in (('box', np.zeros(3)), ('off', np.array([0.1, -0.05, 0.02]))):
            rotation, omega, specific = _imu_reference(q[i], q_dot[i], before[i], offset,
                                                       scene.dt, np.asarray(scene.gravity))
            reading = readings[f'imu_{where}{i}']
            assert reading['orientation'][3] >= 0.0
            np.testing.assert_allclose(_rotation(reading['orientation']), rotation, atol=1e-13)
            np.testing.assert_allclose(reading['angular_velocity'], omega, atol=1e-10)
            np.testing.assert_allclose(reading['linear_acceleration'], specific, atol=1e-8)


class _MirroredStepper(Stepper):
    """The GPU's download path on the CPU (test_mirrors.py)."""

    _mirror_on_cpu = True


def test_the_gpu_path_reads_the_same_sensors_without_downloading_the_state():
    scene = Scene.from_dict(_resting_box())
    direct, mirrored = Stepper(scene), _MirroredStepper(scene)
    for step in range(60):
        direct.step()
        mirrored.step()
        if step % 20 == 19:         # v_prev, q and the contacts downloaded when read
            a, b = direct.sensors, mirrored.sensors
            for name in a:
                for key in a[name]:
                    np.testing.assert_array_equal(a[name][key], b[name][key])
    assert mirrored._downloads.copies == 0
