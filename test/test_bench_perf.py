"""The bench's own logic: fits, call counting, tables, the N scan and the files each section
writes. Tiny runs only, and no assertion on wall-clock figures."""

import csv

import numpy as np
import pytest
import warp as wp

from affine_joint_sim import Stepper
from affine_joint_sim.bench import batch, perf, scaling
from affine_joint_sim.bench.mujoco_ref import MujocoChain
from affine_joint_sim.bench.report import Column, markdown_table
from affine_joint_sim.bench.timing import WarpCalls
from affine_joint_sim.resources import scene_path


@pytest.mark.parametrize('power', [0.5, 1.0, 3.0])
def test_loglog_exponent_recovers_a_power_law(power):
    x = np.array([1, 2, 4, 8, 16, 32])
    assert scaling.loglog_exponent(x, 3.0 * x ** power) == pytest.approx(power, abs=1e-12)


def test_loglog_exponent_of_a_constant_plus_linear_cost_lies_between_0_and_1():
    x = np.array([1, 4, 16, 64, 256])
    assert 0.0 < scaling.loglog_exponent(x, 20.0 + 6.0 * x) < 1.0


def test_warp_calls_counts_one_launch_and_no_sync_per_cpu_step_and_restores_warp():
    sim = Stepper(scene_path('pendulum'))
    originals = (wp.launch, wp.Launch.launch, wp.capture_launch, wp.synchronize_device,
                 wp.array.numpy)
    with WarpCalls() as calls:
        for _ in range(5):
            sim.step()
    assert calls.counts == {'launches': 5, 'syncs': 0}
    assert calls.seconds['launches'] > 0.0 and calls.seconds['syncs'] == 0.0
    assert (wp.launch, wp.Launch.launch, wp.capture_launch, wp.synchronize_device,
            wp.array.numpy) == originals


def test_warp_calls_counts_only_the_outermost_of_nested_calls():
    def launch_twice(*args, **kwargs):
        return [wp.synchronize(), wp.synchronize()]

    calls = WarpCalls()
    wrapped = calls._wrap(launch_twice, 'launches', False)
    with calls:
        wrapped()
    assert calls.counts == {'launches': 1, 'syncs': 0}


def test_markdown_table_formats_cells_and_marks_missing_values():
    table = markdown_table([{'a': 1.234, 'b': None}, {'a': 2.0, 'b': 'x'}],
                           [Column('a', 'A', '{:.1f}'), Column('b', 'B')])
    assert table.splitlines() == ['| A | B |', '|---|---|', '| 1.2 | — |', '| 2.0 | x |']


def test_batch_scan_stops_before_a_step_would_exceed_the_limit(monkeypatch):
    # a step of N environments takes 10 µs · N; the limit of 1 ms admits N ≤ 100
    monkeypatch.setattr(batch, 'measure', lambda scene, envs, device, settings, threads: {
        'envs': envs, 'us_per_step': 10.0 * envs})
    settings = batch.Settings(envs=(1, 4, 16, 64, 256, 1024), run_s=0.0, repeats=1,
                              max_step_s=1e-3)
    assert [row['envs'] for row in batch.scan('pendulum', 'cpu', settings)] == [1, 4, 16, 64]


def test_cases_name_targets_chains_and_packaged_scenes():
    assert perf.case('arm').target_us == 150.0
    assert len(perf.case('chain8').scene().joints) == 8
    assert perf.case('wheel').target_us is None
    assert perf.default_names()[:3] == ['pendulum', 'arm', 'chain64']


def test_mujoco_chain_has_one_hinge_per_link_and_its_tilt_in_radians():
    mujoco = pytest.importorskip('mujoco')
    model = mujoco.MjModel.from_xml_string(MujocoChain(3, 0.5, 0.05, 1.0, angle=0.4).mjcf())
    assert (model.nbody, model.njnt) == (4, 3)
    np.testing.assert_allclose(model.body_quat[1], [np.cos(0.2), np.sin(0.2), 0.0, 0.0])


def _csv_columns(path):
    with open(path, newline='') as stream:
        rows = list(csv.DictReader(stream))
    return list(rows[0]), len(rows)


def test_tiny_runs_write_their_tables_csv_and_plots(tmp_path):
    pytest.importorskip('matplotlib')
    perf.run(tmp_path, ['cpu'], perf.Settings(steps=3, repeats=1), ['pendulum'])
    scaling.run(tmp_path, ['cpu'], scaling.Settings(links=(1, 2), steps=3, repeats=1))
    batch.run(tmp_path, ['cpu'], batch.Settings(envs=(1, 4), run_s=1e-3, repeats=1,
                                                max_step_s=10.0))
    columns, count = _csv_columns(tmp_path / 'perf.csv')
    assert count == 1 and {'scene', 'us_per_step', 'target_us', 'launches_per_step',
                           'syncs_per_step', 'newton_iterations', 'launch_us'} <= set(columns)
    columns, count = _csv_columns(tmp_path / 'scaling.csv')
    assert count == 2 and {'links', 'us_per_step', 'us_per_iteration'} <= set(columns)
    columns, count = _csv_columns(tmp_path / 'batch.csv')
    # two scenes, N = 1 and 4, on one thread and on every core
    assert count == 8 and {'scene', 'envs', 'threads', 'env_steps_per_s'} <= set(columns)
    for name in ('perf.md', 'scaling.md', 'scaling.png', 'batch.md', 'batch.png'):
        assert (tmp_path / name).stat().st_size > 0
    assert 'exponents' in (tmp_path / 'scaling.md').read_text()


def test_the_view_cost_row_times_a_node_in_process():
    from affine_joint_sim.bench import ros_loop

    row = ros_loop.view_cost('pendulum', ros_loop.QUICK._replace(view_steps=20), rounds=1)
    assert row['scene'] == 'pendulum' and row['topics'].startswith('markers, body_poses')
    assert row['step_us'] > 0.0 and row['view_us'] > 0.0
    assert row['share'] == pytest.approx(100.0 * row['view_us'] / row['step_us'])


def test_the_sensor_rows_time_the_packaged_quadruped_with_each_set_of_sensors(tmp_path):
    import gc

    from affine_joint_sim import Scene
    from affine_joint_sim.bench import ros_loop

    cases = [(label, str(ros_loop.sensor_scene(tmp_path, sensors)))
             for label, sensors in ros_loop.SENSOR_RUNS]
    packaged = Scene.load(scene_path(ros_loop.SENSOR_SCENE))
    scenes = [Scene.load(path) for _, path in cases]
    assert [[s.name for s in scene.sensors] for scene in scenes] == [
        [], ['trunk_imu'], ['trunk_imu', 'FL_foot', 'FR_foot']]
    assert all(scene.model_copy(update={'sensors': packaged.sensors}) == packaged
               for scene in scenes)                 # the packaged scene but for its sensors
    try:
        step_us = ros_loop.sensor_cost(cases, ros_loop.QUICK._replace(sensor_steps=20))
    finally:
        gc.unfreeze()           # sensor_cost freezes the heap (``settle``), as the node does
    assert list(step_us) == [label for label, _ in cases] and min(step_us.values()) > 0.0
