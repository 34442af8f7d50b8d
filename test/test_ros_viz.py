"""The run in viewers over real DDS and in bags: markers and body_poses at viz_rate of sim
time, a DELETEALL on reset, nothing at viz_rate 0, and bags whose MCAP files decode with the
readers Foxglove uses (mcap + mcap-ros2-support)."""

import glob
import subprocess
import sys

from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker

from helpers.ros_client import Inbox, call, stamp_ns


def test_markers_and_poses_stream_and_reset_clears_them(sim, ros_node, wait_for):
    sim('--scene', 'arm', '--mode', 'realtime', '--real-time-factor', '2.0')
    markers, poses = Inbox(ros_node, 'markers'), Inbox(ros_node, 'body_poses')
    assert wait_for(lambda: len(poses.messages) >= 5 and len(markers.messages) >= 5)
    arm = markers.messages[-1]
    assert len(arm.markers) == 7 and {m.header.frame_id for m in arm.markers} == {'world'}
    assert len(poses.messages[-1].poses) == 7
    stamps = [stamp_ns(m) for m in poses.messages[1:]]
    # every 1/30 s of sim time, on the first 10 ms step at or after it
    assert all(30e6 <= b - a <= 40e6 for a, b in zip(stamps, stamps[1:])), stamps
    count = len(markers.messages)
    assert call(ros_node, wait_for, Trigger, '/affine_joint_sim/reset', Trigger.Request()).success
    assert wait_for(lambda: any(m.markers and m.markers[0].action == Marker.DELETEALL
                                for m in markers.since(count)))


def test_contact_forces_are_arrows_in_markers(sim, ros_node, wait_for, tmp_path):
    """A 1 kg box at rest on its four corners: four arrows, each m g / 4 up at ARROW_SCALE."""
    from affine_joint_sim.ros.viz import ARROW_SCALE

    scene = tmp_path / 'resting.yaml'
    scene.write_text('ground: {height: 0.0}\ncontact: {}\nbodies:\n- name: box\n'
                     '  shape: {box: [0.1, 0.1, 0.1]}\n  mass: 1.0\n'
                     '  position: [0.0, 0.0, 0.0507]\n  collision: shape\n')
    child = sim('--scene', scene, '--mode', 'realtime', '--real-time-factor', '2.0')
    markers = Inbox(ros_node, 'markers')

    def arrows():
        shown = [m for message in markers.messages for m in message.markers
                 if m.ns == 'contact_forces']
        return [m for m in shown[-4:] if m.action == Marker.ADD and stamp_ns(m) >= 5e8]

    assert wait_for(lambda: len(arrows()) == 4)
    for arrow in arrows():
        assert arrow.type == Marker.ARROW and arrow.header.frame_id == 'world'
        start, tip = arrow.points
        assert abs(start.z) < 1e-9                             # on the ground
        assert abs(tip.z - ARROW_SCALE * 9.81 / 4) < 1e-3 and abs(tip.x - start.x) < 1e-6
    assert 'Traceback' not in child.stop()


def test_viz_rate_0_publishes_no_views(sim, ros_node, wait_for):
    child = sim('--viz-rate', '0')
    assert ros_node.count_publishers('/joint_states') > 0
    assert ros_node.count_publishers('/markers') == 0
    assert ros_node.count_publishers('/body_poses') == 0
    assert 'Traceback' not in child.stop()


def test_a_bag_shows_the_run_to_foxglove_readers(tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    bag = tmp_path / 'run'
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene', 'arm',
                           '--mode', 'fast', '--duration', '1', '--record', str(bag)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    decoded = {}
    for path in sorted(glob.glob(str(bag / '*.mcap'))):
        with open(path, 'rb') as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, message, msg in reader.iter_decoded_messages():
                decoded.setdefault(channel.topic, []).append((message.log_time, msg))
    assert [len(decoded[t]) for t in ('/markers', '/body_poses', '/robot_description')] == \
        [32, 31, 1]                                   # DELETEALL, then t = 0, 1/30, ..., 1 s
    assert decoded['/markers'][0][1].markers[0].action == Marker.DELETEALL
    assert decoded['/robot_description'][0][1].data.startswith('<?xml')
    times = [t for t, _ in decoded['/body_poses']]
    assert times[0] == 0 and times[-1] == 1_000_000_000
    last = decoded['/markers'][-1][1].markers
    assert len(last) == 7 and last[0].header.stamp.sec == 1


def test_views_are_computed_only_while_something_subscribes(ros_node):
    """Nothing subscribed and nothing recorded: a view tick computes nothing and asks DDS
    nothing (matched events count the subscriptions); a viewer that comes gets the views, and
    when it goes they stop."""
    import time

    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from affine_joint_sim.ros.node import SimNode

    node = SimNode(context=ros_node.context, parameter_overrides=[
        Parameter('scene', value='pendulum'), Parameter('viz_rate', value=30.0)])
    executor = SingleThreadedExecutor(context=ros_node.context)
    executor.add_node(node)
    executor.add_node(ros_node)
    computed, update, now = [], node.viz.messages.update, [0]
    node.viz.messages.update = lambda t: computed.append(t) or update(t)

    def tick_until(predicate):
        deadline = time.monotonic() + 10.0
        while not predicate() and time.monotonic() < deadline:
            now[0] += 40_000_000            # every tick due at 30 Hz
            node.viz.publish(now[0], now[0])
            executor.spin_once(timeout_sec=0.05)
        return predicate()

    try:
        for _ in range(10):
            now[0] += 40_000_000
            node.viz.publish(now[0], now[0])
        assert computed == [] and not node.viz.watched
        markers = Inbox(ros_node, 'markers')
        assert tick_until(lambda: markers.messages)
        assert node.viz.watched and computed
        ros_node.destroy_subscription(markers.sub)
        assert tick_until(lambda: not node.viz.watched)
        seen = len(computed)
        for _ in range(10):
            now[0] += 40_000_000
            node.viz.publish(now[0], now[0])
        assert len(computed) == seen
    finally:
        executor.shutdown()
        node.destroy_node()
