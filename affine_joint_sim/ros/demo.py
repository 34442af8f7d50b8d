"""``make run``: the node and the demo PD controller as two processes, closed loop over DDS.

The controller starts first; the node runs the scene for ``duration`` simulated seconds
(recording a bag), then the controller is stopped and both reports are printed together.
"""

import signal
import subprocess
import sys
import time
from pathlib import Path

__all__ = ['run_demo']


def _start(*args) -> subprocess.Popen:
    """``affine-joint-sim ARGS`` in a child process; its stdout (the report) is captured."""
    return subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', *map(str, args)],
                            stdout=subprocess.PIPE, text=True)


def run_demo(scene: str, targets: dict[str, float], duration: float, mode: str,
             record: Path | None, kp: float, kd: float,
             interface: str = 'joint_commands') -> int:
    """Run node + controller; print final angles vs targets, steps/s, real-time factor, bag.

    Returns the node's exit status.
    """
    target_args = [a for joint, angle in targets.items() for a in ('--target', f'{joint}={angle}')]
    controller = _start('controller', *target_args, '--kp', kp, '--kd', kd, '--interface',
                        interface)
    node_args = ['run', '--scene', scene, '--mode', mode, '--duration', duration]
    if record is not None:
        node_args += ['--record', record]
    print(f'demo: node ({scene}, {mode}, {duration:g} s) and PD controller '
          f'(targets {targets}) over DDS on loopback ...', flush=True)
    start = time.monotonic()
    node = _start(*node_args)
    node_report, _ = node.communicate()
    controller.send_signal(signal.SIGINT)
    controller_report, _ = controller.communicate(timeout=30)
    print(f'\n--- demo summary ({time.monotonic() - start:.1f} s wall) ---')
    print(node_report.rstrip())
    print(controller_report.rstrip())
    return node.returncode
