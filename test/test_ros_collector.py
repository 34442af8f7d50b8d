"""The node's garbage collection (affine_joint_sim/ros/collector.py): set-up objects frozen out
of later collections, and collections timed while stepping; the node's use of them in a child
process (an rclpy node run in the test process once left the next tests' discovery broken)."""

import gc

import pytest

from affine_joint_sim.ros.collector import CollectorPauses, settle
from helpers.cli import cli


@pytest.fixture
def unfrozen():
    """Undo ``settle`` at the end: the test process's heap goes back to normal collection."""
    yield
    gc.unfreeze()


def test_settle_leaves_a_full_collection_nothing_of_the_set_up_to_walk(unfrozen):
    import warp  # noqa: F401     the node's set-up holds Warp, rclpy and NumPy objects
    import rclpy  # noqa: F401

    gc.collect()
    assert len(gc.get_objects(generation=2)) > 100_000      # what a full collection walks
    settle()
    assert gc.get_freeze_count() > 100_000
    assert len(gc.get_objects(generation=2)) < 1_000


def test_collections_are_timed_by_generation_while_installed():
    pauses = CollectorPauses()
    pauses.install()
    try:
        gc.collect(0)
        gc.collect(2)
    finally:
        pauses.remove()
    gc.collect(2)                   # removed: not counted
    assert [generation for generation, _ in pauses.pauses] == [0, 2]
    summary = pauses.summary()
    assert (summary['collections'], summary['full']) == (2, 1)
    assert summary['longest'] == max(duration for _, duration in pauses.pauses) > 0.0



def test_the_node_steps_with_its_set_up_frozen_and_counts_its_collections():
    """Before, the set-up's objects stayed in generation 2: once a minute a full collection
    walked them (107–154 ms), the largest joint_states gap of a realtime run."""
    done = cli('run', '--mode', 'fast', '--duration', 1.0)
    assert done.returncode == 0, done.stderr
    line = done.stdout.split('garbage collections while stepping: ')[1].splitlines()[0]
    frozen = int(line.split('; ')[1].split()[0].replace(',', ''))
    assert '(0 full)' in line and frozen > 100_000, line
