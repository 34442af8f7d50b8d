"""What recording a bag costs a run: the node with and without ``--record``, and the bag
writer's work per split at split 1 and split 10,000.

Runs: the node in a child process (``affine-joint-sim run``) in ``realtime`` mode, where this
process subscribes to joint_states and reports the gaps between two arrivals (median, p99,
largest, how many over 50 ms), the node's garbage collections while stepping and the
real-time factor the node reached, and in ``fast`` mode (steps/s); and ``hiccup_runs``
realtime runs of the arm with a bag, for the gaps a long run shows. Per split: a synthetic bag
with the node's topics whose metadata already lists N − 1 splits, then one split of a second
of the pendulum in realtime (100 joint_states and /clock messages) opened, written and
listed; the time the writer thread spends on it is measured directly, on this thread. And the
recording thread's part of a split: ``BagRecorder.flush`` handing it over.
"""

import itertools
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

from affine_joint_sim.bench.report import Column, markdown_table, publish
from affine_joint_sim.bench.ros_loop import client, node_process, spin_until
from affine_joint_sim.bench.section import add_section
from affine_joint_sim.ros.collector import settle
from affine_joint_sim.ros.dds import use_loopback_dds

__all__ = ['add_parser', 'run']


class Settings(NamedTuple):
    realtime_seconds: float     # simulated (= wall) seconds of each realtime run
    fast_seconds: float         # wall seconds of each fast-mode run (about)
    splits: int                 # the later split whose cost is measured
    repeats: int                # splits measured at each place (median)
    hiccup_runs: int            # realtime runs of the arm with a bag, for their gaps
    hiccup_seconds: float       # simulated (= wall) seconds of each of them


FULL = Settings(realtime_seconds=12.0, fast_seconds=3.0, splits=10_000, repeats=5,
                hiccup_runs=10, hiccup_seconds=60.0)
QUICK = Settings(realtime_seconds=3.0, fast_seconds=1.0, splits=1_000, repeats=3,
                 hiccup_runs=2, hiccup_seconds=5.0)
SCENES = ('pendulum', 'arm')
_STEPS_PER_SIM_SECOND = {'pendulum': 100.0, 'arm': 50.0}   # fast-mode sim s per wall s (about)
_GAP = 0.05         # a gap between two joint_states longer than this [s] is counted


def _run_node(scene: str, flags: list[str], record: bool) -> dict:
    """Run the node to its end with one joint_states subscriber here; the arrival gaps, the
    node's garbage collections while stepping, its summary and warnings."""
    node, executor, topics = client()
    settle()        # this subscriber's own collections are no gap of the node's
    arrivals = []
    states = topics['joint_states']
    node.create_subscription(states.msg_class, states.name(),
                             lambda m: arrivals.append(time.monotonic()), states.qos)
    with tempfile.TemporaryDirectory() as tmp:
        bag = ['--record', str(Path(tmp) / 'bag')] if record else []
        child = node_process('--scene', scene, *flags, *bag, stderr=subprocess.PIPE)
        try:
            spin_until(executor, lambda: child.poll() is not None, 600.0)
            summary, log = child.communicate()
        finally:
            node.destroy_node()
            node.context.try_shutdown()
    gaps = sorted(b - a for a, b in zip(arrivals, arrivals[1:])) or [float('nan')]
    collections = summary.split('garbage collections while stepping: ')[1].split()
    return {'scene': scene, 'record': 'yes' if record else 'no',
            'steps_per_s': float(summary.split(' steps/s')[0].rsplit(' ', 1)[1]),
            'factor': float(summary.split('real-time factor ')[1].split()[0]),
            'median_gap_ms': 1e3 * statistics.median(gaps),
            'p99_gap_ms': 1e3 * gaps[int(0.99 * (len(gaps) - 1))],
            'largest_gap_ms': 1e3 * gaps[-1],
            'long_gaps': sum(g > _GAP for g in gaps),
            'full_collections': int(collections[1].strip('(')),
            'longest_collection_ms': float(collections[4]),
            'behind_warnings': log.count('cannot keep up'),
            'late_splits': log.count('late split')}


def realtime(scene: str, settings: Settings, record: bool) -> dict:
    """A realtime run of ``realtime_seconds``."""
    return _run_node(scene, ['--mode', 'realtime', '--duration',
                             str(settings.realtime_seconds)], record)


def hiccups(settings: Settings) -> list[dict]:
    """``hiccup_runs`` realtime runs of the arm with a bag, ``hiccup_seconds`` each."""
    return [dict(realtime('arm', settings._replace(realtime_seconds=settings.hiccup_seconds),
                          True), run=k + 1) for k in range(settings.hiccup_runs)]


def fast(scene: str, settings: Settings, record: bool) -> dict:
    """A fast-mode run of about ``fast_seconds`` of wall time."""
    sim_seconds = _STEPS_PER_SIM_SECOND[scene] * settings.fast_seconds
    return _run_node(scene, ['--mode', 'fast', '--duration', str(sim_seconds)], record)


def _node_topics(scene: str):
    """The topics the node records for ``scene``: every joint's commands and the rest."""
    from affine_joint_sim.physics.host.joint_kinds import joint_kind
    from affine_joint_sim.resources import scene_path
    from affine_joint_sim.ros.recorder import BagTopic
    from affine_joint_sim.ros.topics import JOINT_COMMAND_KEYS, load_topics
    from affine_joint_sim.scene import Scene

    topics = load_topics()
    return [BagTopic(topics[key].name(j.name), topics[key].type, topics[key].qos)
            for j in Scene.load(scene_path(scene)).joints
            for key in JOINT_COMMAND_KEYS.get(joint_kind(j.type).command, ())] + [
        BagTopic(t.name(), t.type, t.qos) for t in topics.values() if '{joint}' not in t.template]


def _second_of_pendulum(write) -> None:
    """Write 100 joint_states and 100 /clock messages, 10 ms apart, through
    ``write(topic, t_ns, raw)``."""
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    state = serialize_message(JointState(name=['shoulder', 'elbow'], position=[0.1, 0.2],
                                         velocity=[0.3, 0.4], effort=[0.0, 0.0]))
    clock = serialize_message(Clock())
    for k in range(100):
        write('joint_states', k * 10_000_000, state)
        write('/clock', k * 10_000_000, clock)


def _split_writes(split):
    return lambda topic, t_ns, raw: split.write(split.connections_by_topic[topic], t_ns, raw)


def hand_off(repeats: int) -> dict:
    """What a due split costs the recording thread [ms]: ``BagRecorder.flush`` handing it to
    the writer thread (median and largest of ``repeats`` splits)."""
    from affine_joint_sim.ros.recorder import BagRecorder

    with tempfile.TemporaryDirectory() as tmp:
        recorder = BagRecorder(Path(tmp) / 'bag', 'mcap', _node_topics('pendulum'))
        took = []
        while len(took) < repeats:
            _second_of_pendulum(recorder.write)
            late, start = recorder.late_splits, time.perf_counter()
            recorder.flush()
            if recorder.late_splits == late:        # handed over (else it stays open)
                took.append(time.perf_counter() - start)
            time.sleep(0.1)                         # the writer lists it, opens the next
        recorder.close()
    return {'splits': repeats, 'median_ms': 1e3 * statistics.median(took),
            'max_ms': 1e3 * max(took)}


def split_cost(splits: int, repeats: int) -> dict:
    """Writer-thread work [ms] to open a split and to close and list it, when ``splits`` − 1
    splits are listed before it (median of ``repeats`` successive splits)."""
    from affine_joint_sim.ros.bag_metadata import BagIndex
    from affine_joint_sim.ros.split_closer import list_split
    from affine_joint_sim.ros.split_writer import SplitWriter

    topics = _node_topics('pendulum')
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / 'bag'
        path.mkdir()
        scratch = (path / f'.split_{k}' for k in itertools.count())
        first = SplitWriter(next(scratch), 'mcap', topics)
        _second_of_pendulum(_split_writes(first))
        info = first.close('bag_0.mcap')
        first.discard()
        index = BagIndex()
        for k in range(splits - 1):         # earlier splits, listed in memory only
            name = f'bag_{k}.mcap'
            index.add(dict(info, relative_file_paths=[name],
                           files=[dict(info['files'][0], path=name)]), 0)
        opening, listing = [], []
        for k in range(splits - 1, splits - 1 + repeats):
            start = time.perf_counter()
            split = SplitWriter(next(scratch), 'mcap', topics)
            opening.append(time.perf_counter() - start)
            _second_of_pendulum(_split_writes(split))
            start = time.perf_counter()
            list_split(path, index, split, f'bag_{k}.mcap')
            listing.append(time.perf_counter() - start)
        size = (path / 'metadata.yaml').stat().st_size
    return {'split': splits, 'open_ms': 1e3 * statistics.median(opening),
            'list_ms': 1e3 * statistics.median(listing), 'metadata_kib': size / 1024}


RUN_COLUMNS = [Column('scene', 'scene'), Column('record', '--record'),
               Column('factor', 'real-time factor', '{:.2f}'),
               Column('steps_per_s', 'steps/s', '{:.0f}'),
               Column('median_gap_ms', 'joint_states gap: median [ms]', '{:.1f}'),
               Column('p99_gap_ms', 'p99 [ms]', '{:.1f}'),
               Column('largest_gap_ms', 'largest [ms]', '{:.1f}'),
               Column('long_gaps', f'gaps > {_GAP * 1e3:.0f} ms'),
               Column('full_collections', 'full garbage collections while stepping'),
               Column('longest_collection_ms', 'longest collection [ms]', '{:.2f}'),
               Column('behind_warnings', '"cannot keep up" warnings'),
               Column('late_splits', 'late splits')]
SPLIT_COLUMNS = [Column('split', 'split'), Column('open_ms', 'open [ms]', '{:.1f}'),
                 Column('list_ms', 'close and list [ms]', '{:.1f}'),
                 Column('metadata_kib', 'metadata.yaml [KiB]', '{:.0f}')]


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Measure on the CPU node (recording does not depend on the Warp device)."""
    use_loopback_dds()
    realtime_rows = [realtime(scene, settings, record) for scene in SCENES
                     for record in (False, True)]
    fast_rows = [fast(scene, settings, record) for scene in SCENES for record in (False, True)]
    splits = [split_cost(n, settings.repeats) for n in (1, settings.splits)]
    handed = hand_off(settings.repeats)
    hiccup_rows = hiccups(settings)
    publish(results, 'record_realtime',
            f'### realtime runs of {settings.realtime_seconds:g} s, with and without a bag\n\n'
            + markdown_table(realtime_rows, RUN_COLUMNS) + '\n', realtime_rows)
    publish(results, 'record_hiccups',
            f'### the arm in realtime with a bag: {settings.hiccup_runs} runs of '
            f'{settings.hiccup_seconds:g} s\n\n' + markdown_table(
                hiccup_rows, [Column('run', 'run'), *RUN_COLUMNS[2:]]) + '\n', hiccup_rows)
    publish(results, 'record_fast', '### fast mode, with and without a bag\n\n'
            + markdown_table(fast_rows, RUN_COLUMNS) + '\n', fast_rows)
    publish(results, 'record_splits', "### the bag writer's work per split (pendulum topics, "
            'a second of realtime messages)\n\n' + markdown_table(splits, SPLIT_COLUMNS) +
            f"\n\nThe recording thread's part, handing a split over: median "
            f"{handed['median_ms']:.3f} ms, largest {handed['max_ms']:.3f} ms "
            f"({handed['splits']} splits).\n", splits)


def add_parser(sections) -> None:
    add_section(sections, 'record', run, FULL, QUICK,
                help='what recording costs: realtime factor, joint_states gaps, split cost',
                description='Run the node with and without --record (realtime: factor and the '
                            'largest joint_states gap a subscriber sees; fast: steps/s), and '
                            'measure the bag writer per split at split 1 and split 10,000.',
                quick_help=f'{QUICK.realtime_seconds:g} s realtime runs, split '
                           f'{QUICK.splits:,}')
