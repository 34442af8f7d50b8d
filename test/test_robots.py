"""Several URDF robots in one scene: loading, contact between robots, and the node giving each
robot its own topics, lockstep waiting for every robot's controller, bags that replay."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper
from helpers.cli import cli
from helpers.logged_node import LoggedNode
from helpers.ros_client import Inbox, stamp_ns

REPO = Path(__file__).resolve().parent.parent
URDF = Path(__file__).resolve().parent / 'data' / 'urdf'
CONTROLLER = Path(__file__).resolve().parent / 'helpers' / 'plain_controller.py'
PENDULUM_DT_NS = 10_000_000         # the double pendulum URDF's scene: dt 0.01 s


def _scene(tmp_path, data: dict) -> Scene:
    path = tmp_path / 'robots.yaml'
    path.write_text(yaml.safe_dump(data))
    return Scene.load(path)


def test_two_urdf_robots_are_one_scene_with_prefixed_names_and_move_alike():
    scene = Scene.load(REPO / 'msg_configs' / 'scenes' / 'two_arms.yaml')
    arm = Scene.load(REPO / 'msg_configs' / 'scenes' / 'arm6.yaml')
    assert [r.model_dump() for r in scene.robots] == [
        {'name': 'left', 'namespace': 'left'}, {'name': 'right', 'namespace': 'right'}]
    for side in ('left', 'right'):
        assert [j.name for j in scene.joints if j.name.startswith(side + '/')] == \
            [f'{side}/{j.name}' for j in arm.joints]
        frames = {f.name: f.parent for f in scene.frames}
        assert frames[f'{side}/shoulder_link'] == f'{side}/base_link'
        assert frames[f'{side}/world'] is None          # hangs from the node's frame_id
        assert scene.robot_descriptions[side] == arm.robot_description
    assert scene.robot_description is None
    again = Scene.from_yaml_text(scene.to_yaml())        # a bag's copy: the same scene
    assert again.model_dump() == scene.model_dump()
    # the two arms face each other from either side: mirror images that move alike
    sim = Stepper(scene)
    for _ in range(50):
        sim.step()
    left, right = np.split(sim.angles, 2)
    assert np.abs(left - right).max() < 1e-8 and np.abs(left[1] - 0.3) > 0.05
    # on /tf each robot's links hang under its prefix from its root at its base pose
    roots = sim.link_transforms[[sim.link_names.index(f'{side}/world')
                                 for side in ('left', 'right')]]
    np.testing.assert_allclose(roots[:, :3, 3], [[0.0, 0.6, 0.0], [0.0, -0.6, 0.0]], atol=1e-12)
    np.testing.assert_allclose(roots[0, :3, :3] @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize('change, message', [
    (lambda d: d['robots'][1].update(name='a'), "robots[1].name: duplicate name 'a'"),
    (lambda d: d['robots'][1].update(namespace='a'), "robots[1].namespace: 'a' is also"),
    (lambda d: d['robots'][0].update(colour='red'), 'robots[0].colour: unknown key'),
    (lambda d: d['robots'][0].pop('urdf'), 'robots[0]: each robot is a mapping with urdf'),
    (lambda d: d['robots'][0].update(name='1st'), 'robots[0].name'),
    (lambda d: d.update(bodies=[]), 'bodies: unknown key beside robots:'),
    (lambda d: d['robots'][0].update(joints={'knee': {}}), "'knee' is not a joint"),
    (lambda d: d.update(contact={'exclude': [['a/blade', 'b/paddle']]}),
     "contact.exclude[0]: unknown link or object 'b/paddle'"),
])
def test_a_bad_robots_entry_is_one_clear_error(tmp_path, change, message):
    data = {'robots': [{'name': 'a', 'urdf': str(URDF / 'paddle.urdf')},
                       {'name': 'b', 'urdf': str(URDF / 'paddle.urdf'),
                        'base': {'xyz': [0.0, 1.0, 0.0]}}]}
    change(data)
    with pytest.raises(SceneError) as error:
        _scene(tmp_path, data)
    assert message in str(error.value)


def _paddles(tmp_path, **contact) -> Stepper:
    """Two paddle robots: left's blade along +x from the origin, right's hinged at (0.5, 0.3)
    pointing back along −x, both free to turn about z; right's hinge pushed (2 N·m) swings its
    blade down in y onto left's (they meet after ~0.6 rad)."""
    scene = _scene(tmp_path, {
        'dt': 0.01, 'gravity': [0.0, 0.0, 0.0], 'contact': {'friction': 0.0, **contact},
        'robots': [{'name': 'left', 'urdf': str(URDF / 'paddle.urdf')},
                   {'name': 'right', 'urdf': str(URDF / 'paddle.urdf'),
                    'base': {'xyz': [0.5, 0.3, 0.0], 'rpy': [0.0, 0.0, np.pi]}}]})
    sim = Stepper(scene)
    sim.set_torque('right/hinge', 2.0)
    return sim


def test_two_robots_touch_as_any_two_bodies_and_an_exclude_names_their_links(tmp_path):
    sim = _paddles(tmp_path)
    blades = {'left/blade', 'right/blade'}
    gaps = []
    for _ in range(60):
        sim.step()
        gaps += [c['distance'] for c in sim.contacts if {c['body'], c['other']} == blades]
    left = sim.angles[0]
    # right's blade hit left's and turned it (left has no torque of its own), never through
    assert gaps and min(gaps) > 0.0
    assert left < -0.5
    passing = _paddles(tmp_path, exclude=[['left/blade', 'right/blade']])
    for _ in range(60):
        passing.step()
    assert passing.angles[0] == 0.0 and passing.angles[1] > 1.5     # swung through


# ---- the node -------------------------------------------------------------------------------


@pytest.fixture
def pendulums(tmp_path):
    """A scene of two double pendulums, robots 'left' and 'right' 3 m apart."""
    path = tmp_path / 'pendulums.yaml'
    urdf = str(URDF / 'double_pendulum.urdf')
    path.write_text(yaml.safe_dump({'name': 'pendulums', 'robots': [
        {'name': 'left', 'urdf': urdf, 'base': {'xyz': [0.0, 1.5, 0.0]}},
        {'name': 'right', 'urdf': urdf, 'base': {'xyz': [0.0, -1.5, 0.0]}}]}))
    return path


def _two_robot_run(tmp_path, ros_node, wait_for, scene, bag):
    """30 lockstep steps of ``scene`` with one controller per robot (left's shoulder to 0.6,
    right's to −0.4), recorded in ``bag``: each robot's 31 states and the node's output."""
    node = LoggedNode(tmp_path, ros_node, wait_for, '--scene', scene, '--mode', 'lockstep',
                      '--duration', '0.3', '--record', bag, states='/left/joint_states')
    inboxes = {side: Inbox(ros_node, 'joint_states', name=f'/{side}/joint_states', depth=100)
               for side in ('left', 'right')}
    assert wait_for(lambda: all(i.last is not None for i in inboxes.values()), timeout=30.0)
    started = [subprocess.Popen([sys.executable, str(CONTROLLER), 'shoulder', target,
                                 '--namespace', side, '--name', f'{side}_controller'],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
               for side, target in (('left', '0.6'), ('right', '-0.4'))]
    ended = wait_for(lambda: node.process.poll() is not None, timeout=60.0)
    output = node.stop()
    for process in started:
        process.kill()
        process.wait()
    assert ended and 'Traceback' not in output and '30 steps' in output, output[-4000:]
    runs = {}
    for side, inbox in inboxes.items():
        assert {tuple(m.name) for m in inbox.messages} == {('shoulder', 'elbow')}
        by_stamp = {}
        for m in inbox.messages:
            by_stamp.setdefault(stamp_ns(m), (tuple(m.position), tuple(m.effort)))
        runs[side] = [by_stamp[k * PENDULUM_DT_NS] for k in range(31)]
    return runs, output


def test_two_robots_with_a_controller_each_run_in_lockstep_alike_every_time_and_replay(
        tmp_path, ros_node, wait_for, pendulums):
    description = Inbox(ros_node, 'robot_description', name='/left/robot_description')
    first, output = _two_robot_run(tmp_path, ros_node, wait_for, pendulums, tmp_path / 'one')
    second, _ = _two_robot_run(tmp_path, ros_node, wait_for, pendulums, tmp_path / 'two')
    assert first == second
    # each controller drove its own robot only: efforts on each shoulder, of opposite sign
    assert first['left'][-1][1][0] > 0.0 > first['right'][-1][1][0]
    assert first['left'][-1][1][1] == first['right'][-1][1][1] == 0.0
    assert 'publishers on' not in output
    assert wait_for(lambda: description.last is not None)
    assert description.last.data == (URDF / 'double_pendulum.urdf').read_text()
    replayed = cli('replay', tmp_path / 'one')
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert '62 recorded states' in replayed.stdout
    assert 'largest difference 0.000e+00' in replayed.stdout
    assert 'left/shoulder' in replayed.stdout and 'right/elbow' in replayed.stdout
