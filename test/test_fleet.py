"""Many bags at once: parallel replay equals serial replay exactly, a damaged or missing bag is
reported while the rest completes, a worker killed mid-run costs nothing but a retry, a
diverging bag fails the run, and (with Ray installed) a local Ray gives the same report."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from affine_joint_sim.fleet.bags import expand_bags
from affine_joint_sim.ros.replay import read_bag, replay
from helpers.cli import cli

REPO = Path(__file__).resolve().parent.parent
SAMPLES = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').exists())


@pytest.fixture(scope='module')
def fleet(tmp_path_factory):
    """The sample bags plus 8 generated ones (each sample re-simulated into a new bag)."""
    root = tmp_path_factory.mktemp('fleet')
    for sample in SAMPLES:
        shutil.copytree(sample, root / sample.name)
    for k in range(8):
        replay(read_bag(SAMPLES[k % len(SAMPLES)]), out=root / f'made{k}')
    return root


def report(tmp_path, name, *args):
    path = tmp_path / f'{name}.json'
    done = cli('replay', *args, '--report', path)
    rows = json.loads(path.read_text())['bags'] if path.exists() else []
    return done, [{k: v for k, v in row.items() if k != 'seconds'} for row in rows]


def test_parallel_replay_equals_serial_replay_exactly(fleet, tmp_path):
    serial, rows = report(tmp_path, 'serial', fleet, '--workers', 1)
    parallel, rows2 = report(tmp_path, 'parallel', fleet, '--workers', 2)
    assert serial.returncode == parallel.returncode == 0, serial.stderr + parallel.stderr
    assert len(rows) == len(SAMPLES) + 8 and rows == rows2
    assert all(r['status'] == 'pass' and r['worst'] == 0.0 for r in rows)
    assert 'on 2 worker processes' in parallel.stdout


def test_a_damaged_or_missing_bag_is_listed_and_the_rest_done(fleet, tmp_path):
    damaged = tmp_path / 'damaged'
    shutil.copytree(fleet / 'made0', damaged)
    for part in damaged.glob('*.mcap'):
        part.write_bytes(part.read_bytes()[:len(part.read_bytes()) // 2])
    done, rows = report(tmp_path, 'damaged', f'{fleet}/made[1-3]', damaged,
                        tmp_path / 'nowhere', '--workers', 2)
    assert done.returncode == 2, done.stdout + done.stderr
    by_bag = {Path(r['bag']).name: r for r in rows}
    assert [by_bag[f'made{k}']['status'] for k in (1, 2, 3)] == ['pass'] * 3
    assert by_bag['damaged']['status'] == 'error' and by_bag['damaged']['error']
    assert by_bag['nowhere'] == {**by_bag['nowhere'], 'status': 'error',
                                 'error': 'no such file or directory'}
    assert '3 within --tol' in done.stdout and '2 unreadable' in done.stdout


def test_a_diverging_bag_fails_the_run(fleet, tmp_path):
    scene = (REPO / 'msg_configs' / 'scenes' / 'pendulum.yaml').read_text()
    other = tmp_path / 'heavier_gravity.yaml'
    other.write_text(scene + 'gravity: [0.0, 0.0, -12.0]\n')
    done, rows = report(tmp_path, 'whatif', fleet / 'torque_step', fleet / 'made1',
                        '--scene', other, '--workers', 2)
    assert done.returncode == 1, done.stdout + done.stderr
    assert [r['status'] for r in rows] == ['fail', 'fail'] and rows[0]['worst'] > 1e-3


def _processes():
    """(pid, parent pid, command line bytes) of every process that can be read."""
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / 'stat').read_text().rsplit(')', 1)[1].split()[1])
            yield int(entry.name), ppid, (entry / 'cmdline').read_bytes()
        except (OSError, IndexError, ValueError):
            continue


def replay_killing_a_worker(tmp_path, executor: list, is_worker) -> list[dict]:
    """Run ``replay`` on the fleet with ``executor`` flags, SIGKILL the first process for which
    ``is_worker(pid, ppid, cmdline, cli_pid)`` holds while it runs; return the report's rows."""
    path = tmp_path / 'killed.json'
    child = subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', 'replay',
                              *executor, '--report', path],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline, victim = time.monotonic() + 120, None
    while victim is None and time.monotonic() < deadline and child.poll() is None:
        victim = next((pid for pid, ppid, command in _processes()
                       if is_worker(pid, ppid, command, child.pid)), None)
        if victim is not None:
            os.kill(victim, signal.SIGKILL)
        time.sleep(0.01)
    out, err = child.communicate(timeout=300)
    assert victim is not None, 'no worker to kill'
    assert child.returncode == 0, out + err
    return json.loads(path.read_text())['bags'], err


def test_a_worker_killed_mid_run_still_yields_a_complete_report(fleet, tmp_path):
    # a spawned worker of the command, starting up or inside its first jobs
    rows, err = replay_killing_a_worker(
        tmp_path, [fleet, '--workers', '2'],
        lambda pid, ppid, command, cli_pid: ppid == cli_pid and b'spawn_main' in command)
    assert 'a worker process died' in err
    assert len(rows) == len(SAMPLES) + 8 and all(r['status'] == 'pass' for r in rows)


def test_a_pool_that_breaks_while_jobs_are_handed_out_still_runs_every_job(monkeypatch):
    # under load a spawned worker can die (here: the pool reports it) before every job is
    # submitted; submit then raises instead of a future doing so, which ended the command
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    from affine_joint_sim.fleet.executors import run_pool

    real, calls = ProcessPoolExecutor.submit, []

    def submit(self, fn, /, *args, **kwargs):
        calls.append(fn)
        if len(calls) == 3:
            raise BrokenProcessPool('A child process terminated abruptly')
        return real(self, fn, *args, **kwargs)

    monkeypatch.setattr(ProcessPoolExecutor, 'submit', submit)
    jobs, said = [{'job': k} for k in range(5)], []
    assert run_pool(dict, jobs, workers=2, say=said.append) == jobs
    assert said == ['a worker process died: 3 unfinished job(s) run again on fresh workers']


def test_local_ray_gives_the_same_report(fleet, tmp_path):
    pytest.importorskip('ray')
    _, serial = report(tmp_path, 'serial', fleet, '--workers', 1)
    done, rows = report(tmp_path, 'ray', fleet, '--ray', 'local')
    assert done.returncode == 0, done.stderr
    assert rows == serial and 'on Ray at local' in done.stdout


def test_without_ray_the_ray_flag_says_what_to_install(fleet, tmp_path, monkeypatch):
    try:
        import ray  # noqa: F401
        pytest.skip('Ray is installed here')
    except ImportError:
        pass
    done = cli('replay', fleet / 'made0', '--ray', 'local')
    assert done.returncode == 2 and "pip install -e '.[cluster]'" in done.stderr


def test_bag_arguments_expand_to_bags(fleet, tmp_path):
    (tmp_path / 'empty').mkdir()
    bags, problems = expand_bags([str(fleet), str(fleet / 'made1'), f'{fleet}/made[12]',
                                  str(tmp_path / 'empty'), str(tmp_path / 'gone*')])
    assert len(bags) == len(SAMPLES) + 8 and len(set(bags)) == len(bags)
    assert problems == [(str(tmp_path / 'empty'), 'an empty directory: no bags in it'),
                        (str(tmp_path / 'gone*'), 'no such file or directory')]


SPEC = '''cases: [pendulum]
scenes:
  - {scene: double_pendulum, torques: {shoulder: 1.0}, duration: 0.3}
dt: [0.01, 0.005]
integrator: [bdf1, bdf2]
'''
TIMING = ('us_per_step', 'ms_per_sim_s')


def sweep_rows(tmp_path, name, *args):
    import csv

    spec = tmp_path / 'spec.yaml'
    spec.write_text(SPEC)
    done = cli('sweep', spec, '--out', tmp_path / name, *args)
    assert done.returncode == 0, done.stdout + done.stderr
    with (tmp_path / name / 'sweep.csv').open() as stream:
        return [{k: v for k, v in row.items() if k not in TIMING}
                for row in csv.DictReader(stream)], done


@pytest.mark.parametrize('executor', [('--workers', '2'), ('--ray', 'local')],
                         ids=['workers', 'ray'])
def test_a_parallel_sweep_writes_the_rows_of_a_serial_one(tmp_path, executor):
    if executor[0] == '--ray':
        pytest.importorskip('ray')
    serial, _ = sweep_rows(tmp_path, 'serial', '--workers', '1')
    rows, done = sweep_rows(tmp_path, 'parallel', *executor)
    ours = [r for r in rows if not r['integrator'].startswith('mujoco')]   # (compare extra)
    assert [(r['scene'], r['integrator'], float(r['dt'])) for r in ours] == [
        (scene, integrator, dt) for scene in ('pendulum', 'double_pendulum[shoulder=1]')
        for integrator in ('bdf1', 'bdf2') for dt in (0.01, 0.005)]
    assert rows == serial                    # every figure but wall time, bit for bit
    assert all(float(r['error_rad']) < 0.05 for r in rows)
    assert (tmp_path / 'parallel' / 'sweep_double_pendulum[shoulder=1].png').exists()
    assert 'Warp' not in done.stdout + done.stderr     # no banner, no CUDA driver notice


def test_a_sweep_says_its_size_and_what_it_is_doing(tmp_path):
    _, done = sweep_rows(tmp_path, 'said', '--workers', '2')
    said = done.stderr.replace('\r', '\n')
    assert 'sweep: 8 jobs (2 cases × 4 settings) on 2 worker processes' in said
    assert 'sweep: computing the rigid-body reference of 2 cases' in said
    assert said.index('reference of 2 cases') < said.index('] 0/8 ') < said.index('] 8/8 ')
    assert 'warning' not in said                       # 8 jobs are no large sweep


def test_a_bad_sweep_spec_is_refused(tmp_path):
    spec = tmp_path / 'spec.yaml'
    for text, words in (('cases: [nope]\n', "cases ['nope'] are not sweep cases"),
                        ('dt: [0.01]\n', 'at least one entry in cases: or scenes:'),
                        ('cases: [pendulum]\ndt: [-1]\n', 'dt[0]'),
                        ('scenes: [{scene: gantry}]\n', 'gantry')):
        spec.write_text(text)
        done = cli('sweep', spec, '--out', tmp_path / 'out')
        assert done.returncode == 2 and words in done.stderr, done.stderr


def test_an_unknown_joint_or_device_is_refused_in_one_line_before_any_job(tmp_path):
    spec = tmp_path / 'spec.yaml'
    for text, words in (
            ('scenes: [{scene: double_pendulum, torques: {elbw: 1.0}}]\n',
             "scenes[0].torques: joint 'elbw' is not in double_pendulum (joints: shoulder, "
             "elbow)"),
            ('scenes: [{scene: arm, torques: [{yaw: 0.1}, {yaw: 0.3, hand: 1}]}]\n',
             "scenes[0].torques[1]: joint 'hand' is not in arm (joints: yaw, shoulder, "
             'elbow, wrist_pitch, wrist_yaw, wrist_roll)'),
            ('cases: [pendulum]\ndevice: [cpu, cuda:99]\n', "device[1]: 'cuda:99' is not a "
             'device of this machine (it has: cpu'),
            ('cases: [pendulum]\ndevice: [gpu]\n', "device[0]: 'gpu' is not a device of this "
             'machine (it has: cpu')):
        spec.write_text(text)
        done = cli('sweep', spec, '--out', tmp_path / 'out')
        assert done.returncode == 2 and words in done.stderr, done.stderr
        assert len(done.stderr.splitlines()) == 1, done.stderr
        assert not (tmp_path / 'out').exists()          # no job ran


def test_cuda_on_a_machine_without_a_gpu_is_refused_in_one_line(tmp_path):
    import warp as wp

    from affine_joint_sim.quiet_warp import quiet_warp

    quiet_warp()
    if wp.get_cuda_device_count():
        pytest.skip('this machine has a CUDA device')
    spec = tmp_path / 'spec.yaml'
    spec.write_text('cases: [pendulum]\ndevice: [cuda]\n')
    done = cli('sweep', spec, '--out', tmp_path / 'out', '--workers', 1)
    assert done.returncode == 2 and done.stderr == (
        f"affine-joint-sim sweep: error: {spec}: device[0]: 'cuda' is not a device of this "
        'machine (it has: cpu)\n'), done.stderr


def test_sweep_refuses_fewer_than_one_worker(tmp_path):
    spec = tmp_path / 'spec.yaml'
    spec.write_text('cases: [pendulum]\ndt: [0.01]\nintegrator: [bdf2]\n')
    done = cli('sweep', spec, '--out', tmp_path / 'out', '--workers', 0)
    assert done.returncode == 2 and done.stderr == (
        'affine-joint-sim sweep: error: --workers 0: must be >= 1\n'), done.stderr
    assert not (tmp_path / 'out').exists()


def test_worker_warnings_are_lines_of_their_own_naming_the_bag(fleet, tmp_path):
    # a scene whose solver cannot converge in one iteration: every replay warns once
    scene = (REPO / 'msg_configs' / 'scenes' / 'pendulum.yaml').read_text()
    stiff = tmp_path / 'one_iteration.yaml'
    stiff.write_text(scene.replace('newton_max_iter: 32', 'newton_max_iter: 1').replace(
        'newton_tol: 1.0e-4', 'newton_tol: 1.0e-14'))
    bags = [fleet / 'torque_step', fleet / 'made1']
    done = cli('replay', *bags, '--scene', stiff, '--workers', 2)
    assert done.returncode == 1, done.stdout + done.stderr
    # what each line shows last (a progress bar redraws its line after a carriage return)
    lines = [line.rsplit('\r', 1)[-1].replace('\x1b[K', '') for line in done.stderr.split('\n')]
    for bag in bags:
        assert any(line.startswith(f'warning: {bag}: SimulationWarning: t = 0.01 s: Newton '
                                   'did not converge') for line in lines), done.stderr
    assert 'Warp' not in done.stderr and 'loop.py' not in done.stderr, done.stderr


def test_a_ray_worker_killed_mid_run_still_yields_a_complete_report(fleet, tmp_path):
    """Ray retries the task of a worker that died (max_retries): SIGKILL one while it runs a
    replay job (its process title is then ray::replay_job)."""
    pytest.importorskip('ray')
    rows, _ = replay_killing_a_worker(
        tmp_path, [fleet, '--ray', 'local'],
        lambda pid, ppid, command, cli_pid: command.startswith(b'ray::replay_job'))
    assert len(rows) == len(SAMPLES) + 8 and all(r['status'] == 'pass' for r in rows)


def test_command_profiles_run_as_environments_of_one_batched_stepper(tmp_path):
    """A scene entry's torque profiles are one job per setting (num_envs = profiles); each
    environment's row equals the row of its profile run alone."""
    import csv

    def rows(name, torques):
        spec = tmp_path / f'{name}.yaml'
        spec.write_text(f'scenes: [{{scene: double_pendulum, torques: {torques}, '
                        'duration: 0.3}]\ndt: [0.01]\nintegrator: [bdf2]\n')
        done = cli('sweep', spec, '--out', tmp_path / name, '--workers', 1)
        assert done.returncode == 0, done.stderr
        with (tmp_path / name / 'sweep.csv').open() as stream:
            return {r['scene']: r for r in csv.DictReader(stream)}

    batched = rows('batched', '[{shoulder: 1.0}, {shoulder: -0.5}]')
    assert {r['envs'] for r in batched.values()} == {'2'}
    for profile, name in (('{shoulder: 1.0}', 'double_pendulum[shoulder=1]'),
                          ('{shoulder: -0.5}', 'double_pendulum[shoulder=-0.5]')):
        alone = rows(name.replace('[', '_').replace(']', '').replace('=', '_'), profile)[name]
        assert alone['envs'] == '1'
        for column in ('error_rad', 'newton_iterations', 'joint_gap_m', 'energy_drift_j',
                       'converged_pct', 'rejected_steps'):
            assert batched[name][column] == alone[column], column


def test_a_directory_of_bags_names_a_bag_without_metadata_instead_of_skipping_it(tmp_path):
    """Before, `replay DIR` skipped such a bag (a recording killed before its first split was
    listed) without a word."""
    from shutil import copytree

    copytree(REPO / 'bags' / 'demo_pd', tmp_path / 'good')
    (tmp_path / 'killed').mkdir()
    (tmp_path / 'killed' / 'killed_0.mcap').write_bytes(b'')   # a split named as its bag
    bags, problems = expand_bags([str(tmp_path)])
    assert bags == [tmp_path / 'good']
    assert problems == [(str(tmp_path / 'killed'),
                         'split files but no metadata.yaml (a recording killed before it listed '
                         'its first split?): not a bag rosbags can read')]


def test_a_killed_recording_with_only_scratch_splits_is_named_too(tmp_path):
    """A recorder killed before it listed its first split leaves only its scratch splits."""
    (tmp_path / 'killed' / '.split_0').mkdir(parents=True)
    bags, problems = expand_bags([str(tmp_path)])
    assert bags == [] and problems[0][0] == str(tmp_path / 'killed'), problems
