"""sim_warnings.summarised: one summary warning per load, every item counted, details apart."""

import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from affine_joint_sim.sim_warnings import SimulationDetail, SimulationWarning, summarised

REPO = Path(__file__).resolve().parent.parent


def _item(message, kind, size=0.0, worst='', item=''):
    warnings.warn(SimulationWarning(message, kind, size, worst, item), stacklevel=2)


def test_the_summary_counts_each_kind_once_per_item_with_its_worst():
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        with summarised('robot.urdf'):
            _item("joint 'a' has no limits", 'joints without limits')
            _item("mesh m.stl: 900 vertices → 64", 'meshes reduced', 14.1, 'm.stl 900 → 64',
                  item='m.stl')
            warnings.warn('a warning of its own', SimulationWarning)
            _item("mesh m.stl: 300 triangles → 64", 'meshes reduced', 4.7, 'm.stl 300 → 64',
                  item='m.stl')
            _item("mesh n.stl: 2000 vertices → 64", 'meshes reduced', 31.3, 'n.stl 2000 → 64',
                  item='n.stl')
            _item("joint 'b' has no limits", 'joints without limits')
            warnings.warn('not ours', DeprecationWarning)
    messages = [(w.category, str(w.message)) for w in said]
    # what is not an item passes through first, as raised; then each item; then the summary
    assert messages[:2] == [(SimulationWarning, 'a warning of its own'),
                            (DeprecationWarning, 'not ours')]
    assert [m for c, m in messages[2:-1] if c is SimulationDetail] == [
        "joint 'a' has no limits", 'mesh m.stl: 900 vertices → 64',
        'mesh m.stl: 300 triangles → 64', 'mesh n.stl: 2000 vertices → 64',
        "joint 'b' has no limits"]
    assert messages[-1] == (SimulationWarning, 'robot.urdf: joints without limits: 2; meshes '
                            'reduced: 2 (worst: n.stl 2000 → 64) (each one: run --verbose, or '
                            'show SimulationDetail warnings)')


def test_no_items_no_summary_and_an_error_inside_still_says_them():
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        with summarised('quiet.urdf'):
            pass
        with pytest.raises(ValueError, match='bad file'):
            with summarised('broken.urdf'):
                _item("joint 'a' has no limits", 'joints without limits')
                raise ValueError('bad file')
    assert [str(w.message) for w in said] == [
        "joint 'a' has no limits",
        'broken.urdf: joints without limits: 1 (each one: run --verbose, or show '
        'SimulationDetail warnings)']


def test_by_default_python_shows_the_summary_and_not_the_details(tmp_path):
    robot = (REPO / 'msg_configs' / 'robots' / 'arm6.urdf').read_text().replace(
        'lower="-3.0" upper="3.0"', 'lower="0.5" upper="3.0"')
    (tmp_path / 'rubbing.urdf').write_text(robot)
    load = 'import sys; from affine_joint_sim import Scene; Scene.from_urdf(sys.argv[1])'
    done = subprocess.run([sys.executable, '-c', load, tmp_path / 'rubbing.urdf'],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    shown = [line for line in done.stderr.splitlines() if 'Warning: ' in line]
    assert len(shown) == 1, done.stderr
    assert ('SimulationWarning: rubbing.urdf: joints starting at a limit (zero outside their '
            'limits): 3') in shown[0]
    assert 'SimulationDetail:' not in done.stderr and "'shoulder_lift'" not in done.stderr
