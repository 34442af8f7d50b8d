"""The node over DDS: joint_states rate in ``fast`` mode, command-to-state latency in ``lockstep``,
and in process what the views (markers, body_poses, /tf) add to a step when nothing subscribes.

The node runs in a child process (``affine-joint-sim run``); this process subscribes (and, for
lockstep, answers every state with a ``joint_commands`` message, as a controller would).
Discovery stays on loopback.
"""

import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.ros.dds import use_loopback_dds

__all__ = ['add_parser', 'client', 'node_process', 'run', 'spin_until']


class Settings(NamedTuple):
    fast_seconds: float         # wall seconds of each fast-mode run (about)
    lockstep_steps: int         # lockstep round trips measured
    repeats: int                # fast-mode runs of each row, interleaved (the median shown)
    view_steps: int             # in-process node steps (and view ticks) timed per round


FULL = Settings(fast_seconds=3.0, lockstep_steps=2000, repeats=5, view_steps=20000)
QUICK = Settings(fast_seconds=1.0, lockstep_steps=300, repeats=1, view_steps=1000)
SCENES = ('pendulum', 'arm')
# fast-mode runs: (scene, viz_rate [Hz of sim time], a viewer subscribes markers,
# body_poses and /tf); the 0 Hz rows price the views
FAST_RUNS = (('pendulum', 30.0, True), ('pendulum', 30.0, False), ('pendulum', 0.0, False),
             ('arm', 30.0, True), ('arm', 30.0, False), ('arm', 0.0, False))


def node_process(*flags, stderr=subprocess.DEVNULL) -> subprocess.Popen:
    """``affine-joint-sim run FLAGS`` in a child process; its summary comes on stdout."""
    return subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', 'run', *flags],
                            stdout=subprocess.PIPE, stderr=stderr, text=True)


def client():
    """An rclpy node on a context of its own, its executor, and the topics."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from affine_joint_sim.ros.topics import load_topics

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_ros_loop', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    return node, executor, load_topics()


def spin_until(executor, predicate, timeout):
    deadline = time.monotonic() + timeout
    while not predicate() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    return predicate()


def fast_rate(scene: str, settings: Settings, viz_rate: float = 30.0,
              viewer: bool = False) -> dict:
    """Steps/s the node publishes in fast mode, and how many one rclpy subscriber of
    joint_states takes; with ``viewer`` the same process subscribes markers, body_poses and
    /tf (where tf2_msgs is built) too (the node then makes them; a Python viewer on the same
    2 cores also takes CPU)."""
    from affine_joint_sim.ros.topics import interfaces_built

    node, executor, topics = client()
    received = []
    states = topics['joint_states']
    node.create_subscription(states.msg_class, states.name(),
                             lambda m: received.append(time.monotonic()), states.qos)
    viewed = ('markers', 'body_poses') + (('tf',) if interfaces_built('tf2_msgs') else ())
    for key in viewed if viewer else ():
        node.create_subscription(topics[key].msg_class, topics[key].name(), lambda m: None,
                                 topics[key].qos)
    # Long enough in sim time for ~fast_seconds of wall time at the measured rates.
    sim_seconds = {'pendulum': 100.0, 'arm': 50.0}.get(scene, 50.0) * settings.fast_seconds
    child = node_process('--scene', scene, '--mode', 'fast', '--duration', str(sim_seconds),
                         '--viz-rate', str(viz_rate))
    try:
        spin_until(executor, lambda: child.poll() is not None, 600.0)
        spin_until(executor, lambda: False, 0.3)       # the tail still in flight
        summary = child.communicate()[0]
    finally:
        node.destroy_node()
        node.context.try_shutdown()
    published = float(summary.split(' steps/s')[0].rsplit(' ', 1)[1])
    span = received[-1] - received[0] if len(received) > 1 else float('nan')
    return {'scene': scene, 'viz_rate': viz_rate, 'viewer': 'yes' if viewer else 'no',
            'published_per_s': published,
            'received_per_s': (len(received) - 1) / span, 'received': len(received)}


def lockstep_latency(scene: str, settings: Settings) -> dict:
    """Round trip in lockstep: command published → next joint_states received [ms]."""
    node, executor, topics = client()
    commands, states = topics['joint_commands'], topics['joint_states']
    publisher = node.create_publisher(commands.msg_class, commands.name(), commands.qos)
    child = node_process('--scene', scene, '--mode', 'lockstep')
    sent, latencies, answered = [None], [], []

    def answer(msg):
        now = time.monotonic()
        answered.append(now)
        if sent[0] is not None:
            latencies.append(now - sent[0])
        if len(latencies) < settings.lockstep_steps:
            sent[0] = time.monotonic()
            publisher.publish(commands.msg_class(name=list(msg.name),
                                                 effort=[0.0] * len(msg.name)))

    node.create_subscription(states.msg_class, states.name(), answer, states.qos)
    try:
        spin_until(executor, lambda: len(latencies) >= settings.lockstep_steps, 120.0)
    finally:
        child.terminate()
        child.communicate()
        node.destroy_node()
        node.context.try_shutdown()
    ms = sorted(x * 1e3 for x in latencies)
    return {'scene': scene, 'round_trips': len(ms), 'median_ms': statistics.median(ms),
            'p90_ms': ms[int(0.9 * len(ms))], 'p99_ms': ms[int(0.99 * len(ms))],
            'loop_steps_per_s': (len(answered) - 1) / (answered[-1] - answered[0])}


def view_cost(scene: str, settings: Settings, rounds: int = 5) -> dict:
    """In process, nothing subscribed and nothing recorded: a node step in ``fast`` mode
    (state published, views at 30 Hz of sim time included) and the views' share of it, timed
    on their own over the same sim times (median of ``rounds``) [µs]."""
    import rclpy
    from rclpy.parameter import Parameter

    from affine_joint_sim.ros.node import SimNode

    context = rclpy.Context()
    rclpy.init(context=context)
    node = SimNode(context=context, parameter_overrides=[
        Parameter('scene', value=scene), Parameter('mode', value='fast'),
        Parameter('viz_rate', value=30.0)])
    steps, dt_ns = settings.view_steps, round(node.sim.dt * 1e9)
    step_us, view_us = [], []
    try:
        node.reset()
        for _ in range(rounds):
            start = time.perf_counter()
            for _ in range(steps):
                node.step()
            step_us.append((time.perf_counter() - start) / steps * 1e6)
            start = time.perf_counter()
            for k in range(steps):
                node.viz.publish(k * dt_ns, k * dt_ns)
            view_us.append((time.perf_counter() - start) / steps * 1e6)
    finally:
        node.destroy_node()
        context.try_shutdown()
    step, view = statistics.median(step_us), statistics.median(view_us)
    return {'scene': scene, 'topics': ', '.join(node.viz.publishers), 'step_us': step,
            'view_us': view, 'share': 100.0 * view / step}


VIEW_COLUMNS = [Column('scene', 'scene'), Column('topics', 'view topics (none subscribed)'),
                Column('step_us', 'node step [µs]', '{:.1f}'),
                Column('view_us', 'views per step [µs]', '{:.2f}'),
                Column('share', 'share [%]', '{:.1f}')]
FAST_COLUMNS = [Column('scene', 'scene'), Column('viz_rate', 'markers [Hz sim]', '{:g}'),
                Column('viewer', 'viewer subscribed'),
                Column('runs', 'runs'),
                Column('published_per_s', 'joint_states published/s (node, median)', '{:.0f}'),
                Column('published_range', 'range'),
                Column('received_per_s', 'received/s (one rclpy subscriber)', '{:.0f}')]
LOCKSTEP_COLUMNS = [Column('scene', 'scene'), Column('round_trips', 'round trips'),
                    Column('median_ms', 'median [ms]', '{:.2f}'),
                    Column('p90_ms', 'p90 [ms]', '{:.2f}'), Column('p99_ms', 'p99 [ms]', '{:.2f}'),
                    Column('loop_steps_per_s', 'closed-loop steps/s', '{:.0f}')]


def _median_runs(settings: Settings) -> list[dict]:
    """Each FAST_RUNS row ``repeats`` times, the rows interleaved (a machine that slows down
    for a while slows every row alike); per row the median rates and the published range."""
    runs = [[] for _ in FAST_RUNS]
    for _ in range(settings.repeats):
        for row, (scene, rate, viewer) in zip(runs, FAST_RUNS):
            row.append(fast_rate(scene, settings, rate, viewer))
    medians = []
    for row in runs:
        published = [r['published_per_s'] for r in row]
        medians.append(dict(row[0], runs=len(row),
                            published_per_s=statistics.median(published),
                            published_range=f'{min(published):.0f}–{max(published):.0f}',
                            received_per_s=statistics.median(r['received_per_s'] for r in row)))
    return medians


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Measure both on the CPU node (the DDS side does not depend on the Warp device)."""
    use_loopback_dds()
    views = [view_cost(scene, settings) for scene in SCENES]
    fast = _median_runs(settings)
    lockstep = [lockstep_latency(scene, settings) for scene in SCENES]
    publish(results, 'ros_views', '### views at 30 Hz of sim time with nothing subscribed '
            '(in process, fast mode)\n\n' + markdown_table(views, VIEW_COLUMNS) + '\n', views)
    publish(results, 'ros_fast', '### joint_states rate, fast mode (CPU, dt 0.01 s)\n\n' +
            markdown_table(fast, FAST_COLUMNS) + '\n', fast)
    publish(results, 'ros_lockstep', '### lockstep: joint_commands published → next '
            'joint_states received\n\n' + markdown_table(lockstep, LOCKSTEP_COLUMNS) + '\n',
            lockstep)


def add_parser(sections) -> None:
    add_section(sections, 'ros_loop', run, FULL, QUICK,
                help='node over DDS: fast-mode joint_states rate, lockstep latency',
                description='Run the node in a child process and measure the joint_states '
                            'rate in fast mode and the command-to-state round trip in lockstep.',
                quick_help=f'{QUICK.fast_seconds:g} s fast runs, {QUICK.lockstep_steps} '
                           'round trips')
