"""The ROS simulation standard on a running node (README.md#the-simulation-standard), called
from this process with real rclpy clients: the features it says it has, pausing, stepping,
stopping and resetting (each step published like any other), the SimulateSteps action with its
feedback, the bodies as entities and a body's state against the scene's own numbers."""

import math

import pytest

from helpers.ros_client import Inbox, call, stamp_ns

pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')

NODE = '/affine_joint_sim/'
DT_NS = 10_000_000          # the pendulum's dt


def _call(ros_node, wait_for, name, **fields):
    from simulation_interfaces import srv

    kind = getattr(srv, ''.join(part.title() for part in name.split('_')))
    request = kind.Request()
    for key, value in fields.items():
        setattr(request, key, value)
    return call(ros_node, wait_for, kind, NODE + name, request)


def _settled(states, wait_for) -> int:
    """Wait (the node paused) until the states sent before the pause have all arrived; their
    count."""
    assert wait_for(lambda: states.last is not None)
    count = -1
    while count != len(states.messages):
        count = len(states.messages)
        wait_for(lambda: len(states.messages) > count, timeout=0.5)
    return count


def test_the_standard_pauses_steps_stops_and_resets(sim, ros_node, wait_for):
    from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures

    sim('--mode', 'fast')
    states = Inbox(ros_node, 'joint_states')
    features = _call(ros_node, wait_for, 'get_simulator_features').features.features
    assert {SimulatorFeatures.STEP_SIMULATION_MULTIPLE, SimulatorFeatures.SIMULATION_RESET,
            SimulatorFeatures.STEP_SIMULATION_ACTION,
            SimulatorFeatures.ENTITY_STATE_GETTING} <= set(features)
    assert SimulatorFeatures.SPAWNING in features
    state = _call(ros_node, wait_for, 'get_simulation_state')
    assert state.state.state == SimulationState.STATE_PLAYING
    refused = _call(ros_node, wait_for, 'step_simulation', steps=3)
    assert refused.result.result == Result.RESULT_OPERATION_FAILED      # not paused
    paused = _call(ros_node, wait_for, 'set_simulation_state',
                   state=SimulationState(state=SimulationState.STATE_PAUSED))
    assert paused.result.result == Result.RESULT_OK
    again = _call(ros_node, wait_for, 'set_simulation_state',
                  state=SimulationState(state=SimulationState.STATE_PAUSED))
    assert again.result.result == again.ALREADY_IN_TARGET_STATE
    count = _settled(states, wait_for)
    before = stamp_ns(states.last)
    stepped = _call(ros_node, wait_for, 'step_simulation', steps=5)
    assert stepped.result.result == Result.RESULT_OK
    assert wait_for(lambda: stamp_ns(states.last) == before + 5 * DT_NS)
    assert len(states.messages) == count + 5                # each step published
    stopped = _call(ros_node, wait_for, 'set_simulation_state',
                    state=SimulationState(state=SimulationState.STATE_STOPPED))
    assert stopped.result.result == Result.RESULT_OK
    assert wait_for(lambda: stamp_ns(states.last) == 0)
    assert _call(ros_node, wait_for, 'get_simulation_state').state.state == \
        SimulationState.STATE_STOPPED
    assert _call(ros_node, wait_for, 'set_simulation_state', state=SimulationState(
        state=SimulationState.STATE_PLAYING)).result.result == Result.RESULT_OK
    assert wait_for(lambda: stamp_ns(states.last) > 10 * DT_NS)
    reset = _call(ros_node, wait_for, 'reset_simulation', scope=1)       # time alone
    assert reset.result.result == Result.RESULT_FEATURE_UNSUPPORTED
    reset = _call(ros_node, wait_for, 'reset_simulation', scope=255)
    assert reset.result.result == Result.RESULT_OK


def test_bodies_are_the_entities_and_their_state_is_the_scene_s(sim, ros_node, wait_for):
    from simulation_interfaces.msg import EntityFilters, Result, SimulationState

    sim('--scene', 'double_pendulum', '--mode', 'fast')
    _call(ros_node, wait_for, 'set_simulation_state',
          state=SimulationState(state=SimulationState.STATE_STOPPED))     # at t = 0
    listed = _call(ros_node, wait_for, 'get_entities')
    assert listed.result.result == Result.RESULT_OK and len(listed.entities) >= 2
    only = _call(ros_node, wait_for, 'get_entities', filters=EntityFilters(filter='^upper'))
    assert only.entities == [name for name in listed.entities if name.startswith('upper')]
    bad = _call(ros_node, wait_for, 'get_entities', filters=EntityFilters(filter='('))
    assert bad.result.result == Result.RESULT_OPERATION_FAILED
    from affine_joint_sim import Scene
    from affine_joint_sim.resources import scene_path
    scene = Scene.load(scene_path('double_pendulum'))
    body = scene.bodies[-1]
    state = _call(ros_node, wait_for, 'get_entity_state', entity=body.name)
    assert state.result.result == Result.RESULT_OK
    assert state.state.header.frame_id == 'world' and stamp_ns(state.state) == 0
    p = state.state.pose.position
    assert math.dist((p.x, p.y, p.z), body.position) < 1e-9
    missing = _call(ros_node, wait_for, 'get_entity_state', entity='nobody')
    assert missing.result.result == Result.RESULT_NOT_FOUND


def test_the_simulate_steps_action_steps_with_feedback(sim, ros_node, wait_for):
    from rclpy.action import ActionClient
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import Result, SimulationState

    sim('--mode', 'fast')
    states = Inbox(ros_node, 'joint_states')
    client = ActionClient(ros_node, SimulateSteps, NODE + 'simulate_steps')
    assert client.wait_for_server(timeout_sec=30.0)

    def run(steps):
        feedback = []
        sent = client.send_goal_async(SimulateSteps.Goal(steps=steps),
                                      feedback_callback=lambda m: feedback.append(m.feedback))
        assert wait_for(sent.done)
        done = sent.result().get_result_async()
        assert wait_for(done.done, timeout=30.0)
        return done.result().result, feedback

    refused, _ = run(3)                                     # playing: refused
    assert refused.result.result == Result.RESULT_OPERATION_FAILED
    _call(ros_node, wait_for, 'set_simulation_state',
          state=SimulationState(state=SimulationState.STATE_PAUSED))
    _settled(states, wait_for)
    before = stamp_ns(states.last)
    result, feedback = run(4)
    assert result.result.result == Result.RESULT_OK
    assert wait_for(lambda: len(feedback) == 4, timeout=30.0)   # a topic: may trail the result
    assert [(f.completed_steps, f.remaining_steps) for f in feedback] == \
        [(1, 3), (2, 2), (3, 1), (4, 0)]
    assert wait_for(lambda: stamp_ns(states.last) == before + 4 * DT_NS)


def _transforms(bag, topic) -> list:
    """The TFMessages on ``topic`` of a bag (decoded: CDR's padding bytes may differ)."""
    from rclpy.serialization import deserialize_message
    from rosbags.rosbag2 import Reader
    from tf2_msgs.msg import TFMessage

    with Reader(bag) as reader:
        wanted = [c for c in reader.connections if c.topic == topic]
        return [deserialize_message(bytes(raw), TFMessage)
                for _, _, raw in reader.messages(wanted)]


def test_a_placed_body_is_recorded_and_replays_exactly(sim, ros_node, wait_for, tmp_path):
    from geometry_msgs.msg import Pose
    from simulation_interfaces.msg import EntityState, Result, SimulationState, \
        SimulatorFeatures

    from helpers.cli import cli

    bag = tmp_path / 'placed'
    child = sim('--scene', 'ramp', '--mode', 'fast', '--record', bag)
    assert SimulatorFeatures.ENTITY_STATE_SETTING in \
        _call(ros_node, wait_for, 'get_simulator_features').features.features
    _call(ros_node, wait_for, 'set_simulation_state',
          state=SimulationState(state=SimulationState.STATE_STOPPED))

    def placed(entity, z=1.0, w=math.cos(0.2), frame_id='world'):
        state = EntityState(pose=Pose())
        state.header.frame_id = frame_id
        state.pose.position.x, state.pose.position.z = 0.6, z
        state.pose.orientation.z, state.pose.orientation.w = math.sin(0.2), w
        state.twist.linear.x, state.twist.angular.z = -0.5, 2.0
        return _call(ros_node, wait_for, 'set_entity_state', entity=entity, state=state).result

    # placed at t = 0 and reset before any step: replay must undo it too
    assert placed('box', z=2.0).result == Result.RESULT_OK
    assert _call(ros_node, wait_for, 'reset_simulation', scope=255).result.result == \
        Result.RESULT_OK
    _call(ros_node, wait_for, 'set_simulation_state',
          state=SimulationState(state=SimulationState.STATE_PAUSED))
    _call(ros_node, wait_for, 'step_simulation', steps=3)
    assert placed('box').result == Result.RESULT_OK
    got = _call(ros_node, wait_for, 'get_entity_state', entity='box').state
    assert (got.pose.position.x, got.pose.position.z) == pytest.approx((0.6, 1.0), abs=1e-12)
    assert (got.pose.orientation.z, got.pose.orientation.w) == \
        pytest.approx((math.sin(0.2), math.cos(0.2)), abs=1e-12)
    assert (got.twist.linear.x, got.twist.angular.z) == pytest.approx((-0.5, 2.0), abs=1e-12)
    for entity, z, w, frame, code in (
            ('ramp', 1.0, math.cos(0.2), 'world', Result.RESULT_OPERATION_FAILED),   # fixed
            ('box', 0.01, math.cos(0.2), 'world', 101),                 # inside the ground
            ('box', 1.0, 1.0, 'world', 101),                            # |q| = 1.02
            ('box', 1.0, math.cos(0.2), 'map', Result.RESULT_FEATURE_UNSUPPORTED),
            ('nobody', 1.0, math.cos(0.2), 'world', Result.RESULT_NOT_FOUND)):
        refused = placed(entity, z, w, frame)
        assert refused.result == code and refused.error_message, (entity, z, w, frame)
    _call(ros_node, wait_for, 'step_simulation', steps=20)
    fell = _call(ros_node, wait_for, 'get_entity_state', entity='box').state
    assert fell.pose.position.x == pytest.approx(0.6 - 0.5 * 0.2, abs=1e-3)
    assert fell.pose.position.z == pytest.approx(1.0 - 0.5 * 9.81 * 0.2 ** 2, abs=2e-3)
    assert 'Traceback' not in child.stop()

    out = tmp_path / 'again'
    replayed = cli('replay', bag, '--out', out)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    recorded = _transforms(bag, '/tf')
    assert len(recorded) >= 3 and _transforms(out, '/tf') == recorded
    assert _transforms(out, '/tf_static') == _transforms(bag, '/tf_static')
