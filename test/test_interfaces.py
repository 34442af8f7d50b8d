"""The interface packages make venv builds (tools/build_interfaces.py): tf2_msgs and
simulation_interfaces import, carry messages and service calls between two real processes, a
second build run does nothing, and a machine without the build tools gets one line saying what
to install."""

import subprocess
import sys
import time
from pathlib import Path

import pytest

BUILD = Path(__file__).resolve().parents[1] / 'tools' / 'build_interfaces.py'
pytest.importorskip('tf2_msgs', reason='tf2_msgs not built (make venv says why)')
pytest.importorskip('simulation_interfaces', reason='simulation_interfaces not built')

SERVER = """
import sys, rclpy
from simulation_interfaces.srv import GetEntities
rclpy.init()
node = rclpy.create_node('entities_server')
def answer(request, response):
    response.entities = [f'seen:{request.filters.filter}']
    response.result.result = response.result.RESULT_OK
    return response
node.create_service(GetEntities, 'get_entities', answer)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""

TALKER = """
import rclpy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage
rclpy.init()
node = rclpy.create_node('tf_talker')
publisher = node.create_publisher(TFMessage, 'tf', 10)
frame = TransformStamped(child_frame_id='hand')
frame.header.frame_id = 'world'
frame.transform.translation.z = 0.25
node.create_timer(0.05, lambda: publisher.publish(TFMessage(transforms=[frame])))
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


def test_a_second_build_does_nothing():
    began = time.monotonic()
    done = subprocess.run([sys.executable, str(BUILD)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0 and done.stdout == '' and done.stderr == '', done
    assert time.monotonic() - began < 30       # it builds nothing (a build takes a minute)


def test_without_build_tools_one_line_says_what_to_install(tmp_path):
    done = subprocess.run([sys.executable, str(BUILD), '--prefix', str(tmp_path)],
                          capture_output=True, text=True, timeout=60,
                          env={'PATH': str(tmp_path), 'HOME': str(tmp_path)})
    assert done.returncode == 0 and done.stdout == '', done
    line, = done.stderr.splitlines()
    assert line.startswith('interfaces: tf2_msgs, simulation_interfaces not built: cmake, a C '
                           'compiler, a C++ compiler') and 'apt install cmake g++' in line


def test_tf_messages_and_a_simulation_service_cross_processes(spawn, ros_node, wait_for):
    from simulation_interfaces.srv import GetEntities
    from tf2_msgs.msg import TFMessage

    received = []
    ros_node.create_subscription(TFMessage, 'tf', received.append, 10)
    spawn('-c', TALKER)
    assert wait_for(lambda: received, timeout=30.0)
    frame = received[-1].transforms[0]
    assert (frame.header.frame_id, frame.child_frame_id) == ('world', 'hand')
    assert frame.transform.translation.z == 0.25

    spawn('-c', SERVER)
    client = ros_node.create_client(GetEntities, 'get_entities')
    assert wait_for(client.service_is_ready, timeout=30.0)
    request = GetEntities.Request()
    request.filters.filter = 'cube'
    future = client.call_async(request)
    assert wait_for(future.done, timeout=30.0)
    assert future.result().entities == ['seen:cube']
    assert future.result().result.result == future.result().result.RESULT_OK
