"""Spawning and deleting entities while a scene runs: every other body goes on bit for bit, the
spawned ones move as they would have from the start, bad spawns change nothing."""

from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'
PADDLE = Path(__file__).resolve().parent / 'data' / 'urdf' / 'paddle.urdf'
CRATE = {'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 500.0, 'collision': 'shape'}


def _at(*xyz):
    pose = np.eye(4)
    pose[:3, 3] = xyz
    return pose


def _arm_run(edits: dict, steps: int = 120):
    """arm6 under a varying torque for ``steps`` steps, ``edits[step](sim)`` applied before
    that step: the joint angles after each step, and the Stepper."""
    sim = Stepper(Scene.load(SCENES / 'arm6.yaml'))
    angles = []
    for step in range(steps):
        if step in edits:
            edits[step](sim)
        sim.set_torque('shoulder_lift', 2.0 * np.sin(0.05 * step))
        sim.step()
        angles.append(sim.angles[:6].copy())
    return np.array(angles), sim


def test_a_far_body_or_robot_spawned_and_deleted_changes_no_bit_of_the_rest():
    alone, _ = _arm_run({})
    kernels = []
    edits = {20: lambda sim: (kernels.append(sim._k),
                              sim.spawn('crate', _at(40.0, 0.0, 3.0), body=CRATE)),
             40: lambda sim: sim.spawn('paddle', _at(-40.0, 0.0, 1.0), urdf=str(PADDLE)),
             60: lambda sim: (sim.set_torque('paddle/hinge', 1.0), kernels.append(sim._k)),
             80: lambda sim: sim.delete('crate'),
             100: lambda sim: sim.delete('paddle')}
    edited, sim = _arm_run(edits)
    np.testing.assert_array_equal(edited, alone)
    assert kernels[0] is kernels[1] is sim._k        # the same variant: nothing compiled
    assert sim.step_count == 120 and sim.body_names == Stepper(
        Scene.load(SCENES / 'arm6.yaml')).body_names


def test_a_spawned_body_and_robot_move_as_they_would_from_the_start():
    _, sim = _arm_run({0: lambda s: s.spawn('crate', _at(40.0, 0.0, 3.0), body=CRATE)},
                      steps=50)
    fresh = Stepper(Scene.from_dict({'dt': sim.dt, 'bodies': [
        {'name': 'crate', **CRATE, 'position': [40.0, 0.0, 3.0]}]}))
    for _ in range(50):
        fresh.step()
    np.testing.assert_allclose(sim.body_q[-1], fresh.body_q[0], rtol=0, atol=1e-12)
    # a robot spawned mid-run, its hinge pushed: θ = τ t² / (2 I) about its hinge
    sim.spawn('paddle', _at(-40.0, 0.0, 1.0), urdf=str(PADDLE))
    sim.set_torque('paddle/hinge', 0.5)
    start = sim.time
    for _ in range(30):
        sim.step()
    inertia = 0.0135 + 1.0 * 0.25 ** 2                 # the blade's about its hinge [kg·m²]
    expected = 0.5 * (sim.time - start) ** 2 / (2 * inertia)
    assert sim.angles[-1] == pytest.approx(expected, rel=0.05)
    sim.spawn('ball', _at(-40.0, 5.0, 1.0), body={'shape': {'sphere': {'radius': 0.1}},
                                                  'density': 500.0})
    assert sim.scene.robot_descriptions['paddle'] == PADDLE.read_text()
    assert [r.name for r in sim.scene.robots] == ['paddle']


def test_a_spawn_where_a_reset_would_put_it_inside_something_is_refused():
    scene = Scene.from_dict({'dt': 0.01, 'ground': {'height': 0.0}, 'bodies': [
        {'name': 'box', **CRATE, 'position': [0.0, 0.0, 1.0]}]})
    sim = Stepper(scene)
    for _ in range(30):         # it has fallen 0.44 m: its start is free now
        sim.step()
    with pytest.raises(SceneError, match="inside body 'box'"):
        sim.spawn('crate', _at(0.0, 0.0, 1.0), body=CRATE)
    sim.spawn('crate', _at(1.0, 0.0, 1.0), body=CRATE)
    sim.reset()
    assert sim.body_q[1][:3].tolist() == [1.0, 0.0, 1.0]


@pytest.mark.parametrize('edit, message', [
    (lambda sim: sim.spawn('crate', _at(0.0, 0.0, 0.05), body=CRATE), "inside"),
    (lambda sim: sim.spawn('ground_box', _at(2.0, 0.0, 1.0), body=CRATE), "'ground_box' is taken"),
    (lambda sim: sim.spawn('crate', _at(2.0, 0.0, 1.0), body={'density': 1.0}), 'give a shape'),
    (lambda sim: sim.spawn('crate', _at(2.0, 0.0, 1.0)), 'exactly one of body'),
    (lambda sim: sim.spawn('crate', np.zeros((4, 4)), body=CRATE), 'not a rotation'),
    (lambda sim: sim.spawn('p', _at(2.0, 0.0, 1.0), urdf='/no/such.urdf'), 'cannot read'),
    (lambda sim: sim.delete('nothing'), "no entity 'nothing'"),
])
def test_a_refused_spawn_or_delete_says_why_and_changes_nothing(edit, message):
    scene = Scene.from_dict({'dt': 0.01, 'ground': {'height': 0.0}, 'bodies': [
        {'name': 'ground_box', **CRATE, 'position': [0.0, 0.0, 0.5]}]})
    sim, twin = Stepper(scene), Stepper(scene)
    for _ in range(5):
        sim.step()
        twin.step()
    with pytest.raises((SceneError, ValueError)) as error:
        edit(sim)
    assert message in str(error.value)
    for _ in range(5):
        sim.step()
        twin.step()
    np.testing.assert_array_equal(sim.body_q, twin.body_q)
    assert sim.body_names == ['ground_box']


# ---- over ROS: the standard's SpawnEntity and DeleteEntity ---------------------------------


def test_entities_spawned_and_deleted_over_ros_get_topics_and_the_bag_replays_exactly(
        sim, ros_node, wait_for, tmp_path):
    pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from simulation_interfaces import srv
    from simulation_interfaces.msg import Result, SimulationState

    from helpers.cli import cli
    from helpers.ros_client import Inbox, call
    from test_ros_bags import bag_messages

    def service(which, **fields):
        kind = getattr(srv, ''.join(part.title() for part in which.split('_')))
        request = kind.Request()
        for key, value in fields.items():
            setattr(request, key, value)
        return call(ros_node, wait_for, kind, '/affine_joint_sim/' + which, request)

    def at(x, y, z, w=1.0):
        pose = PoseStamped()
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
        pose.pose.orientation.w = w
        return pose

    bag = tmp_path / 'spawned'
    child = sim('--scene', 'double_pendulum', '--mode', 'fast', '--record', bag)
    service('set_simulation_state', state=SimulationState(state=SimulationState.STATE_PAUSED))
    service('step_simulation', steps=3)
    crate = service('spawn_entity', name='crate', initial_pose=at(5.0, 0.0, 3.0),
                    resource_string='{shape: {box: [0.2, 0.2, 0.2]}, density: 500}')
    assert (crate.result.result, crate.entity_name) == (Result.RESULT_OK, 'crate')
    states = Inbox(ros_node, 'joint_states', name='/arm2/joint_states')
    description = Inbox(ros_node, 'robot_description', name='/arm2/robot_description')
    paddle = service('spawn_entity', name='paddle', uri=str(PADDLE), entity_namespace='arm2',
                     initial_pose=at(-5.0, 0.0, 1.0))
    assert paddle.result.result == Result.RESULT_OK, paddle.result.error_message
    assert wait_for(lambda: states.last is not None and description.last is not None)
    assert list(states.last.name) == ['hinge']
    assert description.last.data == PADDLE.read_text()
    for fields, code in (
            ({'name': 'crate', 'resource_string': '{mass: 1, shape: {sphere: {radius: 1}}}'},
             srv.SpawnEntity.Response.NAME_NOT_UNIQUE),
            ({'name': '9lives', 'uri': str(PADDLE)}, srv.SpawnEntity.Response.NAME_INVALID),
            ({'name': 'thing'}, srv.SpawnEntity.Response.NO_RESOURCE),
            ({'name': 'thing', 'uri': str(PADDLE), 'entity_namespace': 'a//b'},
             srv.SpawnEntity.Response.NAMESPACE_INVALID),
            ({'name': 'thing', 'resource_string': '[1, 2]'},
             srv.SpawnEntity.Response.UNSUPPORTED_FORMAT),
            ({'name': 'thing', 'resource_string': '<robot name="x"><link name="a"/>'},
             srv.SpawnEntity.Response.RESOURCE_PARSE_ERROR),
            ({'name': 'thing', 'resource_string': '{density: 1}'},
             srv.SpawnEntity.Response.RESOURCE_PARSE_ERROR)):
        refused = service('spawn_entity', initial_pose=at(9.0, 9.0, 9.0), **fields)
        assert refused.result.result == code and refused.result.error_message, fields
    renamed = service('spawn_entity', name='crate', allow_renaming=True,
                      initial_pose=at(7.0, 0.0, 3.0),
                      resource_string='{shape: {sphere: {radius: 0.1}}, density: 500}')
    assert (renamed.result.result, renamed.entity_name) == (Result.RESULT_OK, 'crate_1')
    commands = ros_node.create_publisher(JointState, '/arm2/joint_commands', 10)
    assert wait_for(lambda: commands.get_subscription_count() > 0)
    commands.publish(JointState(name=['hinge'], effort=[0.5]))
    assert wait_for(lambda: states.last.effort[0] == 0.5 if service(
        'step_simulation', steps=1) else False)
    service('step_simulation', steps=10)
    fell = service('get_entity_state', entity='crate').state.pose.position.z
    assert fell < 3.0 - 0.5 * 9.81 * 0.1 ** 2
    assert service('delete_entity', entity='paddle').result.result == Result.RESULT_OK
    assert service('delete_entity', entity='paddle').result.result == Result.RESULT_NOT_FOUND
    assert service('delete_entity', entity='shoulder').result.result == \
        Result.RESULT_NOT_FOUND                                  # a joint, not an entity
    assert wait_for(lambda: ros_node.count_publishers('/arm2/joint_states') == 0)
    service('step_simulation', steps=5)
    output = child.stop()
    assert 'Traceback' not in output, output
    recorded = bag_messages(bag)
    assert [m.effort[0] for m in recorded['/arm2/joint_states']][-1] == 0.5
    assert [list(m.effort) for m in recorded['/arm2/joint_commands']] == [[0.5]]
    replayed = cli('replay', bag)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert 'largest difference 0.000e+00' in replayed.stdout
    assert 'paddle/hinge' in replayed.stdout and 'refused' not in replayed.stdout


def test_replay_finds_each_recorded_topic_s_robot_by_its_namespace():
    from affine_joint_sim.ros.replay import _Message, _robot_of
    from affine_joint_sim.ros.robots import RobotFace

    faces = [RobotFace(None, '', None), RobotFace(None, 'left/', None),
             RobotFace(None, 'gripper/', None), RobotFace(None, 'cell/left/', None)]

    def robot(topic, kind, joint=None):
        return _robot_of(faces, _Message(kind, topic, 0, b'', '', joint))

    assert robot('/left/joints/gripper/external_torque', 'joint_torque', 'gripper') == 1
    assert robot('/gripper/joint_commands', 'joint_commands') == 2
    assert robot('/sim/cell/left/joint_states', 'joint_states') == 3
    assert robot('/joint_commands', 'joint_commands') == 0
    assert _robot_of(faces[1:], _Message('joint_commands', '/right/joint_commands', 0, b'',
                                         '')) is None


def test_contacts_read_right_after_an_edit_are_those_of_the_state_it_goes_on_from():
    scene = Scene.from_dict({'dt': 0.01, 'ground': {'height': 0.0}, 'bodies': [
        {'name': 'box', **CRATE, 'position': [0.0, 0.0, 0.5]}]})
    sim = Stepper(scene)
    for _ in range(60):         # it lands and rests
        sim.step()

    def touching():
        return sorted((c['body'], c['other'], round(c['distance'], 12)) for c in sim.contacts)

    resting = touching()
    assert resting and all(body == 'box' for body, _, _ in resting)
    sim.spawn('crate', _at(5.0, 0.0, 1.0), body=CRATE)
    assert touching() == resting
