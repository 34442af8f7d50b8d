"""``make run``: the node and the demo PD controller as two processes, closed loop over DDS.

The controller starts first; the node runs the scene for ``duration`` simulated seconds
(recording a bag), then the controller is stopped and both reports are printed together.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

__all__ = ['run_demo']


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _start(*args) -> subprocess.Popen:
    """``affine-joint-sim ARGS`` in a child process; its stdout (the report) is captured.

    In a session of its own, so a Ctrl-C in the terminal reaches the demo only, which stops
    the children itself; and with SIGINT ignored until the child installs its own handler (the
    node's, rclpy's), so a child still starting up prints no traceback for it."""
    return subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', *map(str, args)],
                            stdout=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_ignore_sigint)


def _targets(scene: str, targets: dict[str, float]) -> dict[str, float]:
    """``targets``, checked: ValueError unless each names a moving joint of the scene. None
    given: shoulder = 1 rad on the pendulum (the ``make run`` demo), else every moving joint's
    initial position (the controller holds the start pose: a robot standing on the ground)."""
    from affine_joint_sim.resources import scene_path
    from affine_joint_sim.scene import Scene

    path = scene_path(scene)
    loaded = Scene.load(path)
    moving = {j.name: j.initial_position for j in loaded.joints if j.type != 'fixed'}
    if not targets:
        return {'shoulder': 1.0} if path.resolve() == scene_path('pendulum').resolve() \
            else moving
    wrong = [joint for joint in targets if joint not in moving]
    if wrong:
        raise ValueError(f'--target {", ".join(wrong)}: not a moving joint of scene '
                         f'{loaded.name!r} (joints: {", ".join(moving) or "none"})')
    return targets


def _stop(process: subprocess.Popen) -> str:
    """Stop a child and return its output: SIGINT (a running child prints its report and
    exits), SIGTERM if it is still starting up (it ignores SIGINT until then), SIGKILL if it
    hangs."""
    for sig, wait in ((signal.SIGINT, 5.0), (signal.SIGTERM, 25.0)):
        if process.poll() is None:
            process.send_signal(sig)
        try:
            return process.communicate(timeout=wait)[0] or ''
        except subprocess.TimeoutExpired:
            continue
    process.kill()
    return process.communicate()[0] or ''


def _script(scene: str, targets: dict[str, float], script: str | None) -> str | None:
    """The control script the controller runs: ``script``, else (no ``targets`` either) the
    packaged script named as the scene, if any; ValueError for ``script`` beside ``targets``
    or naming a joint the scene lacks."""
    from affine_joint_sim.control_script import ControlScript, packaged_scripts
    from affine_joint_sim.resources import scene_path
    if script is not None and targets:
        raise ValueError('--script replaces --target: give one of them')
    if script is None and not targets and Path(scene).stem in packaged_scripts() \
            and not Path(scene).is_file():
        script = Path(scene).stem
    if script is None:
        return None
    from affine_joint_sim.scene import Scene
    moving = [j.name for j in Scene.load(scene_path(scene)).joints if j.type != 'fixed']
    wrong = [joint for joint in ControlScript.load(script).joints if joint not in moving]
    if wrong:
        raise ValueError(f'--script {script}: {", ".join(wrong)} not a moving joint of scene '
                         f'{scene!r} (joints: {", ".join(moving) or "none"})')
    return script


def run_demo(scene: str, targets: dict[str, float], duration: float, mode: str,
             record: Path | None, kp: float, kd: float,
             interface: str = 'joint_commands', script: str | None = None) -> int:
    """Run node + controller; print final angles vs targets, steps/s, real-time factor, bag.

    ``script``: a control script (file or packaged name) the controller runs instead of
    ``targets``. SIGINT/SIGTERM (Ctrl-C) stop both children, whose reports are still printed;
    neither is left running. Returns the node's exit status (2: a target that is not a joint).
    """
    script = _script(scene, targets, script)
    if script is not None:
        target_args, what = ['--script', script], f'script {script}'
    else:
        targets = _targets(scene, targets)
        target_args = [a for joint, angle in targets.items()
                       for a in ('--target', f'{joint}={angle}')]
        what = f'targets {targets}'
    node_args = ['run', '--scene', scene, '--mode', mode, '--duration', duration]
    if record is not None:
        node_args += ['--record', record]
    where = ' on loopback' if os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE') == 'LOCALHOST' \
        else ''
    print(f'demo: node ({scene}, {mode}, {duration:g} s) and PD controller '
          f'({what}) over DDS{where} ...', flush=True)
    start = time.monotonic()
    stop = []

    def on_signal(signum, frame):
        stop.append(signum)

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    controller = node = None
    try:
        controller = _start('controller', *target_args, '--kp', kp, '--kd', kd, '--interface',
                            interface)
        node = _start(*node_args)
        while node.poll() is None and not stop:
            time.sleep(0.05)
    finally:
        node_report = _stop(node) if node is not None else ''
        controller_report = _stop(controller) if controller is not None else ''
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    print(f'\n--- demo summary ({time.monotonic() - start:.1f} s wall'
          f'{", interrupted" if stop else ""}) ---')
    print(node_report.rstrip())
    print(controller_report.rstrip())
    return node.returncode if not stop else 0
