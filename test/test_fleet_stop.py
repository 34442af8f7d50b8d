"""Stopping a fleet command: Ctrl-C (SIGINT to the process group) and SIGTERM (to the main
process) end a running ``sweep`` or many-bag ``replay`` with every worker process, print what
finished, and exit 128 + the signal's number. Real commands, real signals; the timeouts only
detect a command that does not stop (before, it ran every queued job to the end)."""

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SAMPLES = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').exists())
BAGS = 6000          # replay jobs: minutes of work to cancel on two workers
JOBS = 2400          # sweep jobs of the large spec: minutes of work to cancel
STOP_WITHIN = 60.0   # s; running the queued jobs instead takes minutes
GONE_WITHIN = 10.0   # s after the command ended, for its worker processes


def group_members(group: int) -> list[int]:
    """The processes of process group ``group`` that still exist (zombies aside)."""
    members = []
    for entry in Path('/proc').iterdir():
        try:
            fields = (entry / 'stat').read_text().rsplit(')', 1)[1].split()
        except (OSError, IndexError):
            continue
        if fields[0] != 'Z' and int(fields[2]) == group:
            members.append(int(entry.name))
    return members


def run_until_started(tmp_path: Path, jobs: int, *args):
    """``affine-joint-sim ARGS`` as the leader of its own process group, returned once its
    progress bar shows a finished job of ``jobs``; (process, stdout file, stderr file)."""
    started = re.compile(rf'\] [1-9]\d*/{jobs} ')
    out, err = tmp_path / 'stdout.txt', tmp_path / 'stderr.txt'
    with out.open('w') as stdout, err.open('w') as stderr:
        child = subprocess.Popen([sys.executable, '-m', 'affine_joint_sim.cli', *map(str, args)],
                                 stdout=stdout, stderr=stderr, start_new_session=True)
    deadline = time.monotonic() + 240
    while not started.search(err.read_text()):
        assert child.poll() is None, err.read_text()
        assert time.monotonic() < deadline, 'no job finished within 240 s'
        time.sleep(0.05)
    return child, out, err


def stopped(child: subprocess.Popen) -> int:
    """The command's exit status once it and every process of its group ended; a command or
    a worker still running after the generous limits fails the test (and is killed)."""
    try:
        try:
            status = child.wait(timeout=STOP_WITHIN)
        except subprocess.TimeoutExpired:
            pytest.fail(f'still running {STOP_WITHIN:g} s after the signal')
        deadline = time.monotonic() + GONE_WITHIN
        while group_members(child.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = group_members(child.pid)
        assert not left, f'worker processes left running: {left}'
        return status
    finally:
        if group_members(child.pid):
            os.killpg(child.pid, signal.SIGKILL)
        child.wait()


@pytest.fixture
def many_bags(tmp_path):
    """BAGS bags: links to the sample bags under distinct names."""
    root = tmp_path / 'bags'
    root.mkdir()
    for k in range(BAGS):
        (root / f'b{k:04d}').symlink_to(SAMPLES[k % len(SAMPLES)])
    return root


def test_ctrl_c_stops_a_many_bag_replay_and_its_workers(tmp_path, many_bags):
    child, out, err = run_until_started(tmp_path, BAGS, 'replay', many_bags, '--workers', 2)
    os.killpg(child.pid, signal.SIGINT)
    assert stopped(child) == 128 + signal.SIGINT, err.read_text()
    summary = re.search(rf'stopped by SIGINT: (\d+) of {BAGS} bags replayed', out.read_text())
    assert summary, out.read_text() + err.read_text()
    done = int(summary[1])
    assert 1 <= done < BAGS
    assert len(re.findall(r'/b\d{4} .* pass ', out.read_text())) == done   # their rows


def large_spec(path: Path) -> Path:
    """A sweep of JOBS jobs: minutes on two workers."""
    dts = ', '.join(f'{0.0005 + 1e-6 * k:.6f}' for k in range(JOBS // 6))
    path.write_text(f'cases: [pendulum]\ndt: [{dts}]\nintegrator: [bdf1, bdf2]\n'
                    'newton_tol: [1.0e-4, 1.0e-6, 1.0e-8]\n')
    return path


@pytest.mark.parametrize('how', ['SIGINT to the group', 'SIGTERM to the command'])
def test_a_signal_stops_a_sweep_and_its_workers(tmp_path, how):
    spec = large_spec(tmp_path / 'spec.yaml')
    child, out, err = run_until_started(tmp_path, JOBS, 'sweep', spec, '--out', tmp_path / 'out',
                                        '--workers', 2)
    number = signal.SIGINT if how.startswith('SIGINT') else signal.SIGTERM
    if number == signal.SIGINT:
        os.killpg(child.pid, number)
    else:
        os.kill(child.pid, number)
    assert stopped(child) == 128 + number, err.read_text()
    assert f'warning: {JOBS} jobs' in err.read_text()      # above the size worth a warning
    summary = re.search(rf'stopped by {number.name}: (\d+) of {JOBS} jobs finished; their (\d+) '
                        r'rows are in (\S+)', out.read_text())
    assert summary, out.read_text() + err.read_text()
    rows = (tmp_path / 'out' / 'sweep.csv').read_text().splitlines()
    assert 1 <= int(summary[1]) < JOBS and len(rows) == 1 + int(summary[2]) == 1 + int(
        summary[1])
    assert Path(summary[3]) == tmp_path / 'out' / 'sweep.csv'
    assert not (tmp_path / 'out' / 'sweep.md').exists()
