"""``affine-joint-sim render``: GIFs and PNGs of real recorded bags, drawn from their
body_poses or re-simulated when a bag has none; bad input gets one line and exit 2."""

import numpy as np
import pytest
from PIL import Image

from affine_joint_sim.ros.recorder import BagRecorder
from affine_joint_sim.viz.render import load_track
from helpers.cli import cli
from helpers.imports import modules_loaded_by


@pytest.fixture(scope='module')
def bags(tmp_path_factory):
    """The upright arm falling for 0.5 s, recorded with and without its views."""
    root = tmp_path_factory.mktemp('bags')
    made = {}
    for name, rate in (('views', '30'), ('plain', '0')):
        done = cli('run', '--scene', 'arm', '--mode', 'fast', '--duration', '0.5',
                   '--viz-rate', rate, '--record', root / name)
        assert done.returncode == 0, done.stdout + done.stderr
        made[name] = root / name
    return made


def test_a_gif_has_a_frame_per_step_of_fps_and_shows_the_motion(bags, tmp_path):
    out = tmp_path / 'run.gif'
    done = cli('render', bags['views'], '--out', out, '--fps', 10, '--width', 320,
               '--height', 200)
    assert done.returncode == 0, done.stderr
    assert f'{out}: 6 frames of \'arm\' (from body_poses)' in done.stdout
    with Image.open(out) as gif:
        assert (gif.n_frames, gif.size) == (6, (320, 200))       # 0, 0.1, ..., 0.5 s
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(np.asarray(gif.convert('RGB'), dtype=int))
    left = slice(0, 190)                       # the 3-D view: the arm falls there
    assert np.abs(frames[-1][:, left] - frames[0][:, left]).sum() > 1000


def test_a_png_is_one_frame(bags, tmp_path):
    out = tmp_path / 'frame.png'
    done = cli('render', bags['views'], '--out', out, '--from', 0.2, '--width', 320,
               '--height', 200)
    assert done.returncode == 0, done.stderr
    with Image.open(out) as png:
        assert png.format == 'PNG' and png.size == (320, 200)


def test_drawing_a_bag_with_poses_imports_no_warp(bags, tmp_path):
    out = tmp_path / 'frame.png'
    loaded = modules_loaded_by(
        'from affine_joint_sim.cli import main\n'
        f'assert main(["render", {str(bags["views"])!r}, "--out", {str(out)!r}, '
        '"--width", "160", "--height", "100"]) == 0\n')
    assert out.is_file() and 'affine_joint_sim.viz.render' in loaded and 'warp' not in loaded


def test_a_bag_without_poses_is_resimulated_to_the_same_poses(bags):
    recorded, resimulated = load_track(bags['views']), load_track(bags['plain'])
    assert not recorded.resimulated and resimulated.resimulated
    at = np.searchsorted(resimulated.pose_times, recorded.pose_times)
    np.testing.assert_allclose(resimulated.pose_times[at], recorded.pose_times, atol=1e-12)
    np.testing.assert_allclose(resimulated.bodies[at], recorded.bodies, atol=1e-9)


def test_bad_input_is_one_line_and_exit_2(bags, tmp_path):
    blank = tmp_path / 'blank'
    BagRecorder(blank, 'mcap', []).close()
    for args, words in (
            ((tmp_path / 'nowhere', '--out', tmp_path / 'x.gif'), 'no such file or directory'),
            ((blank, '--out', tmp_path / 'x.gif'), 'the bag holds no scene (~/scene): empty'),
            ((bags['views'], '--out', tmp_path / 'x.avi'), 'must end in .gif, .mp4 or .png'),
            ((bags['views'], '--out', tmp_path / 'no' / 'x.gif'), 'no such directory'),
            ((bags['views'], '--out', tmp_path / 'x.gif', '--from', 2), '--from 2 and --to'),
            ((bags['views'], '--out', tmp_path / 'x.gif', '--view', 'up'), '--view')):
        done = cli('render', *args)
        assert done.returncode == 2, done.stdout + done.stderr
        lines = [line for line in done.stderr.splitlines() if 'Warp' not in line]
        assert len(lines) == 1 and words in lines[0], done.stderr
