"""Session setup for the suite: loopback-only DDS on a private domain, and rclpy fixtures.

The environment is set at import time, before any test module imports rclpy, and child
processes started by tests inherit it.
"""

import signal
import subprocess
import sys
import time

import pytest

from affine_joint_sim.ros.dds import use_loopback_dds

use_loopback_dds()


@pytest.fixture
def ros_node(request):
    """Yield an rclpy node on a private, per-test context (rclpy's own test pattern)."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context)
    name = 'test_' + ''.join(c if c.isalnum() else '_' for c in request.node.name)
    node = rclpy.create_node(name[:60], context=context)
    yield node
    node.destroy_node()
    context.try_shutdown()


@pytest.fixture
def wait_for(ros_node):
    """Return `wait_for(predicate, timeout=10.0) -> bool`, which spins `ros_node` until true.

    Callbacks of the node run while it waits. The result says whether the predicate became
    true within `timeout` [s], so a test asserts on it instead of sleeping for a fixed time.
    """
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=ros_node.context)
    executor.add_node(ros_node)

    def wait(predicate, timeout=10.0):
        deadline = time.monotonic() + timeout
        while not predicate():
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                return False
            executor.spin_once(timeout_sec=min(0.05, remaining))
        return True

    yield wait
    executor.shutdown()


class Child(subprocess.Popen):
    """A child Python process whose combined output is captured until it is stopped."""

    def stop(self, timeout=10.0):
        """Stop the child and return its output.

        SIGINT lets rclpy shut down cleanly; SIGKILL follows if that takes over `timeout` s.
        """
        if self.poll() is None:
            self.send_signal(signal.SIGINT)
        try:
            output, _ = self.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            output, _ = self.communicate()
        return output


@pytest.fixture
def spawn():
    """Return `spawn(*args) -> Child` running `python *args` with this environment.

    Children must stay quiet while they run (their output waits in a pipe until `stop()`).
    Any child still running at teardown is stopped.
    """
    children = []

    def start(*args):
        child = Child([sys.executable, *map(str, args)],
                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        children.append(child)
        return child

    yield start
    for child in children:
        child.stop()


@pytest.fixture
def sim(spawn, ros_node, wait_for):
    """Return `start(*flags) -> Child`: the node (``affine-joint-sim run FLAGS``), once its
    joint_states publisher and services are visible from the test's node."""
    from helpers import ros_client

    def start(*flags):
        child = spawn('-m', 'affine_joint_sim.cli', 'run', *flags)
        assert ros_client.wait_until_up(ros_node, wait_for, child), child.stop()
        return child

    return start
