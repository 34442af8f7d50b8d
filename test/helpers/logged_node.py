"""The node in a child process whose output goes to a file the test can watch while it runs."""

import signal
import subprocess
import sys
import time

from helpers import ros_client


class LoggedNode:
    """The node in a child process whose output goes to a file the test can watch."""

    def __init__(self, tmp_path, ros_node, wait_for, *flags, states='/joint_states'):
        self.log = tmp_path / f'node_{time.monotonic_ns()}.log'
        self.process = subprocess.Popen(
            [sys.executable, '-m', 'affine_joint_sim.cli', 'run', *map(str, flags)],
            stdout=self.log.open('w'), stderr=subprocess.STDOUT)
        assert ros_client.wait_until_up(ros_node, wait_for, self.process, states), \
            self.log.read_text()

    def said(self, text):
        return text in self.log.read_text()

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        return self.log.read_text()
