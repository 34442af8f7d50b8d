"""``affine-joint-sim render``: GIFs and PNGs of real recorded bags, drawn from their
body_poses or re-simulated when a bag has none; bad input gets one line and exit 2."""

from pathlib import Path

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
            ((bags['views'], '--out', tmp_path / 'x.gif', '--view', 'up'), '--view'),
            # before: a .png past the end was drawn at the end silently
            ((bags['views'], '--out', tmp_path / 'x.png', '--from', 2),
             "--from 2 must be within the bag's time span [0, 0.5] s")):
        done = cli('render', *args)
        assert done.returncode == 2, done.stdout + done.stderr
        lines = [line for line in done.stderr.splitlines() if 'Warp' not in line]
        assert len(lines) == 1 and words in lines[0], done.stderr
    # before: matplotlib's errors; now argparse's usage and its one error line
    for flag, value in (('--width', 0), ('--height', -5)):
        done = cli('render', bags['views'], '--out', tmp_path / 'x.gif', flag, value)
        assert done.returncode == 2 and 'Traceback' not in done.stderr, done.stderr
        assert done.stderr.splitlines()[-1].endswith(
            f"argument {flag}: expected a whole number of pixels in 16..8192, got '{value}'")


def test_a_robot_that_falls_far_stays_in_frame(tmp_path):
    """A floating pendulum falls 20 m in 2 s: before, the view held the whole fall and the
    robot shrank to a dot; now the view follows it at its own size, as a short run shows it."""
    import yaml

    scene = yaml.safe_load((Path(__file__).parents[1] / 'msg_configs' / 'scenes' /
                            'pendulum.yaml').read_text())
    scene['bodies'][0]['fixed'] = False
    (tmp_path / 'falling.yaml').write_text(yaml.safe_dump(scene))

    def robot_pixels(duration):
        bag, out = tmp_path / f'bag_{duration}', tmp_path / f'end_{duration}.png'
        done = cli('run', '--scene', tmp_path / 'falling.yaml', '--mode', 'fast', '--duration',
                   duration, '--record', bag)
        assert done.returncode == 0, done.stderr
        done = cli('render', bag, '--out', out, '--from', duration, '--width', 320,
                   '--height', 200)
        assert done.returncode == 0, done.stderr
        with Image.open(out) as png:
            view = np.asarray(png.convert('RGB'), dtype=int)[:, :190]
        return int((view.max(axis=2) - view.min(axis=2) > 60).sum())   # coloured: the robot

    assert robot_pixels(2.0) > 0.5 * robot_pixels(0.1) > 100   # before: 5 against 736


def test_a_large_mesh_is_drawn_decimated_keeping_its_outline():
    """Before, a mesh under 4,000 faces was drawn face by face (a mesh robot took seconds a
    frame) and one over it as a box."""
    import trimesh

    from affine_joint_sim.meshes import decimated
    from affine_joint_sim.viz.render import MESH_FACES

    sphere = trimesh.creation.uv_sphere(radius=0.05, count=[30, 30])
    triangles = decimated(np.asarray(sphere.vertices), np.asarray(sphere.faces), MESH_FACES)
    assert len(sphere.faces) > 3000 and 20 <= len(triangles) <= MESH_FACES
    corners = triangles.reshape(-1, 3)
    np.testing.assert_allclose(corners.max(axis=0), sphere.vertices.max(axis=0), rtol=0.15)
    np.testing.assert_allclose(corners.min(axis=0), sphere.vertices.min(axis=0), rtol=0.15)


def test_a_window_is_read_alone_from_a_bag_with_poses():
    """Before, --from and --to near the end of a long bag decoded all of it first."""
    bag = Path(__file__).parents[1] / 'bags' / 'torque_step'
    whole, window = load_track(bag), load_track(bag, 2.0, 2.4)
    assert whole.state_times.min() == 0.0 and whole.state_times.max() >= 2.49
    assert window.state_times.min() >= 1.0 - 1e-9 and window.state_times.max() <= 2.4 + 1e-9
    assert window.pose_times.min() >= 1.0 - 1e-9 and window.span == whole.span


def test_the_ground_is_a_checkerboard_on_its_plane_and_a_jointless_scene_fills_the_picture(
        tmp_path):
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.viz.render import GROUND_TILES, ground_tiles

    tilted = Scene.from_dict({'bodies': [{'name': 'box', 'mass': 1.0,
                                          'shape': {'box': [0.1, 0.1, 0.1]}}],
                              'ground': [{'height': -0.5},
                                         {'point': [0, 0, 1], 'normal': [0.3, 0.0, 1.0]}]})
    tiles = ground_tiles(tilted, np.array([0.2, 0.1, 0.3]), 0.5)
    assert len(tiles) == 2 * GROUND_TILES ** 2
    flat = np.array([corners for corners, _ in tiles[:GROUND_TILES ** 2]])
    assert np.allclose(flat[..., 2], -0.5)
    assert np.allclose(flat[..., 0].min(), -0.3) and np.allclose(flat[..., 0].max(), 0.7)
    normal = np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0])
    slope = np.array([corners for corners, _ in tiles[GROUND_TILES ** 2:]])
    assert np.allclose((slope - [0.0, 0.0, 1.0]) @ normal, 0.0)
    bag, out = tmp_path / 'ramp', tmp_path / 'ramp.png'
    assert cli('run', '--scene', 'ramp', '--mode', 'fast', '--duration', 0.2,
               '--record', bag).returncode == 0
    done = cli('render', bag, '--out', out, '--width', 320, '--height', 200)
    assert done.returncode == 0, done.stderr
    with Image.open(out) as png:
        view = np.asarray(png.convert('RGB'), dtype=int)
    grey = (view.max(axis=2) - view.min(axis=2) < 8) & (view.min(axis=2) > 120) \
        & (view.max(axis=2) < 225)                              # the tiles' greys
    assert grey[:, 240:].sum() > 100          # no joint plots beside: the view spans it all
