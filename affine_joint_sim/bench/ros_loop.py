"""The node over DDS: joint_states rate in ``fast`` mode, command-to-state latency in ``lockstep``,
the steps/s the quadruped keeps with sensors (an IMU, then two contact sensors too) beside none,
and in process what the views (markers, body_poses, /tf) add to a step when nothing subscribes.

The node runs in a child process (``affine-joint-sim run``); this process subscribes (and, for
lockstep, answers every state with a ``joint_commands`` message, as a controller would).
Discovery stays on loopback.
"""

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import yaml

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.resources import scene_path
from affine_joint_sim.ros.collector import settle
from affine_joint_sim.ros.dds import use_loopback_dds

__all__ = ['add_parser', 'client', 'node_process', 'run', 'spin_until']


class Settings(NamedTuple):
    fast_seconds: float         # wall seconds of each fast-mode run (about)
    lockstep_steps: int         # lockstep round trips measured
    repeats: int                # fast-mode runs of each row, interleaved (the median shown)
    view_steps: int             # in-process node steps (and view ticks) timed per round
    sensor_steps: int           # in-process node steps of each sensor row, in SENSOR_ROUNDs


FULL = Settings(fast_seconds=3.0, lockstep_steps=2000, repeats=5, view_steps=20000,
                sensor_steps=20000)
QUICK = Settings(fast_seconds=1.0, lockstep_steps=300, repeats=1, view_steps=1000,
                 sensor_steps=1000)
SCENES = ('pendulum', 'arm')
# fast-mode runs: (scene, viz_rate [Hz of sim time], a viewer subscribes markers,
# body_poses and /tf); the 0 Hz rows price the views
FAST_RUNS = (('pendulum', 30.0, True), ('pendulum', 30.0, False), ('pendulum', 0.0, False),
             ('arm', 30.0, True), ('arm', 30.0, False), ('arm', 0.0, False))
# fast-mode sim seconds per wall second of each scene (about): a run lasts ~fast_seconds
FAST_PACE = {'pendulum': 100.0, 'arm': 50.0, 'quadruped': 2.5}
# SENSOR_SCENE's rows, run with these sensors instead of its own: (label, sensors)
SENSOR_SCENE = 'quadruped'
_IMU = {'name': 'trunk_imu', 'type': 'imu', 'body': 'trunk'}
SENSOR_RUNS = (('none', []), ('IMU', [_IMU]),
               ('IMU + 2 contact', [_IMU, {'name': 'FL_foot', 'type': 'contact', 'body': 'FL_foot'},
                                    {'name': 'FR_foot', 'type': 'contact', 'body': 'FR_foot'}]))
SENSOR_ROUND = 500          # in-process node steps of one sensor row before the next row's


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
              viewer: bool = False, pace: float | None = None) -> dict:
    """Steps/s the node publishes in fast mode, and how many one rclpy subscriber of
    joint_states takes; with ``viewer`` the same process subscribes markers, body_poses and
    /tf (where tf2_msgs is built) too (the node then makes them; a Python viewer on the same
    2 cores also takes CPU). ``scene``: a packaged scene or a scene file; ``pace``: its
    fast-mode sim seconds per wall second (about; default: ``FAST_PACE`` by name)."""
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
    sim_seconds = (pace or FAST_PACE.get(scene, 50.0)) * settings.fast_seconds
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


def sensor_scene(folder: Path, sensors: list[dict]) -> Path:
    """The packaged SENSOR_SCENE with ``sensors`` for its own, written into ``folder`` (its
    ``urdf:`` path made absolute, as the file is read from there)."""
    packaged = scene_path(SENSOR_SCENE)
    spec = yaml.safe_load(packaged.read_text())
    spec['urdf'] = str((packaged.parent / spec['urdf']).resolve())
    spec['sensors'] = sensors
    path = folder / f'{SENSOR_SCENE}_{len(sensors)}_sensors.yaml'
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return path


def sensor_rates(settings: Settings) -> list[dict]:
    """Per SENSOR_RUNS row, SENSOR_SCENE with its sensors: the node's fast-mode steps/s over
    DDS (``_median_runs``) and a node step in process (``sensor_cost``) [µs], each also as a
    share of the steps/s without sensors [%]. Nothing subscribes to the sensors: the node reads
    and publishes them every step all the same."""
    with tempfile.TemporaryDirectory() as folder:
        cases = [(label, str(sensor_scene(Path(folder), sensors)))
                 for label, sensors in SENSOR_RUNS]
        step_us = sensor_cost(cases, settings)
        rows = _median_runs(lambda label, scene: dict(fast_rate(
            scene, settings, pace=FAST_PACE[SENSOR_SCENE]), scene=SENSOR_SCENE,
            sensors=label), cases, settings.repeats)
    for row in rows:
        row['share'] = 100.0 * row['published_per_s'] / rows[0]['published_per_s']
        row['step_us'] = step_us[row['sensors']]
        row['step_share'] = 100.0 * step_us[rows[0]['sensors']] / row['step_us']
    return rows


def sensor_cost(cases: list[tuple[str, str]], settings: Settings) -> dict[str, float]:
    """In process, nothing subscribed and nothing recorded: a node step in ``fast`` mode of
    each (label, scene file) of ``cases`` [µs], their nodes taking SENSOR_ROUND steps in turn
    (the same sim times: the scene may fall and settle meanwhile), ``sensor_steps`` each; per
    label the median of its rounds."""
    nodes = [(label, *_in_process_node(scene, namespace=f'/case{k}'))
             for k, (label, scene) in enumerate(cases)]
    settle()            # as the node's run does: the set-up's objects are walked no more
    times = {label: [] for label, _ in cases}
    try:
        for _ in range(max(1, settings.sensor_steps // SENSOR_ROUND)):
            for label, node, _ in nodes:
                start = time.perf_counter()
                for _ in range(SENSOR_ROUND):
                    node.step()
                times[label].append((time.perf_counter() - start) / SENSOR_ROUND * 1e6)
    finally:
        for _, node, context in nodes:
            node.destroy_node()
            context.try_shutdown()
    return {label: statistics.median(us) for label, us in times.items()}


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


def _in_process_node(scene: str, namespace: str = '/'):
    """(a SimNode of ``scene`` in ``fast`` mode, views at 30 Hz of sim time, in ``namespace``,
    reset; its own rclpy context)."""
    import rclpy
    from rclpy.parameter import Parameter

    from affine_joint_sim.ros.node import SimNode

    context = rclpy.Context()
    rclpy.init(context=context)
    node = SimNode(context=context, namespace=namespace, parameter_overrides=[
        Parameter('scene', value=scene), Parameter('mode', value='fast'),
        Parameter('viz_rate', value=30.0)])
    node.reset()
    return node, context


def view_cost(scene: str, settings: Settings, rounds: int = 5) -> dict:
    """In process, nothing subscribed and nothing recorded: a node step in ``fast`` mode
    (state published, views at 30 Hz of sim time included) and the views' share of it, timed
    on their own over the same sim times (median of ``rounds``) [µs]."""
    node, context = _in_process_node(scene)
    steps, dt_ns = settings.view_steps, round(node.sim.dt * 1e9)
    step_us, view_us = [], []
    try:
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
SENSOR_COLUMNS = [Column('scene', 'scene'), Column('sensors', 'sensors'), Column('runs', 'runs'),
                  Column('published_per_s', 'steps/s (node over DDS, median)', '{:.0f}'),
                  Column('published_range', 'range'),
                  Column('share', 'of the steps/s without sensors [%]', '{:.0f}'),
                  Column('step_us', 'node step in process [µs]', '{:.1f}'),
                  Column('step_share', 'its steps/s, of those without sensors [%]', '{:.0f}')]
LOCKSTEP_COLUMNS = [Column('scene', 'scene'), Column('round_trips', 'round trips'),
                    Column('median_ms', 'median [ms]', '{:.2f}'),
                    Column('p90_ms', 'p90 [ms]', '{:.2f}'), Column('p99_ms', 'p99 [ms]', '{:.2f}'),
                    Column('loop_steps_per_s', 'closed-loop steps/s', '{:.0f}')]


def _median_runs(measure, cases, repeats: int) -> list[dict]:
    """``measure(*case)`` (a ``fast_rate`` row) of each case ``repeats`` times, the cases
    interleaved (a machine that slows down for a while slows every case alike); per case the
    median rates and the published range."""
    runs = [[] for _ in cases]
    for _ in range(repeats):
        for row, case in zip(runs, cases):
            row.append(measure(*case))
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
    fast = _median_runs(lambda scene, rate, viewer: fast_rate(scene, settings, rate, viewer),
                        FAST_RUNS, settings.repeats)
    sensors = sensor_rates(settings)
    lockstep = [lockstep_latency(scene, settings) for scene in SCENES]
    publish(results, 'ros_views', '### views at 30 Hz of sim time with nothing subscribed '
            '(in process, fast mode)\n\n' + markdown_table(views, VIEW_COLUMNS) + '\n', views)
    publish(results, 'ros_fast', '### joint_states rate, fast mode (CPU, dt 0.01 s)\n\n' +
            markdown_table(fast, FAST_COLUMNS) + '\n', fast)
    publish(results, 'ros_sensors', f'### sensors: steps/s in fast mode ({SENSOR_SCENE}, CPU, '
            'dt 1 ms, nothing subscribed to the sensors)\n\n' +
            markdown_table(sensors, SENSOR_COLUMNS) + '\n', sensors)
    publish(results, 'ros_lockstep', '### lockstep: joint_commands published → next '
            'joint_states received\n\n' + markdown_table(lockstep, LOCKSTEP_COLUMNS) + '\n',
            lockstep)


def add_parser(sections) -> None:
    add_section(sections, 'ros_loop', run, FULL, QUICK,
                help='node over DDS: fast-mode joint_states rate, with sensors, lockstep '
                     'latency',
                description='Run the node in a child process and measure the joint_states '
                            'rate in fast mode (also of the quadruped with and without '
                            'sensors) and the command-to-state round trip in lockstep.',
                quick_help=f'{QUICK.fast_seconds:g} s fast runs, {QUICK.lockstep_steps} '
                           'round trips')
