"""/tf and /tf_static (README.md#transforms) from a real node's bag: every link frame (a URDF's
links, a YAML scene's bodies) is the child of exactly one transform, welded links and fixed
bodies on /tf_static, and composing the transforms from ``world`` gives each link's pose as an
independent in-process Stepper computes it after the same steps (``link_transforms``)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.resources import scene_path
from affine_joint_sim.rotations import quaternion_matrix

pytest.importorskip('tf2_msgs', reason='tf2_msgs not built (make venv says why)')


def _matrix(transform) -> np.ndarray:
    out = np.eye(4)
    r, t = transform.rotation, transform.translation
    out[:3, :3] = quaternion_matrix(r.x, r.y, r.z, r.w)
    out[:3, 3] = t.x, t.y, t.z
    return out


def _read(bag: Path) -> tuple[dict, list]:
    """(/tf_static's {child: (parent, T)}, /tf's messages) of a bag."""
    from rosbags.highlevel import AnyReader

    static, moving = {}, []
    with AnyReader([bag]) as reader:
        wanted = [c for c in reader.connections if c.topic in ('/tf', '/tf_static')]
        for connection, _, raw in reader.messages(wanted):
            msg = reader.deserialize(raw, connection.msgtype)
            if connection.topic == '/tf_static':
                static.update({t.child_frame_id: (t.header.frame_id, _matrix(t.transform))
                               for t in msg.transforms})
            else:
                moving.append(msg)
    return static, moving


@pytest.mark.parametrize('scene, still', [
    ('arm6_gripper', {'base_link', 'flange', 'hand', 'tool0'}),   # URDF: welded links
    ('quadruped', set()),                       # URDF: a floating base under world
    ('gantry', set()),                          # a YAML scene: its bodies under world
])
def test_composed_transforms_give_every_link_pose(tmp_path, scene, still):
    bag = tmp_path / 'run'
    done = subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', 'run', '--scene', scene,
                           '--mode', 'fast', '--duration', '0.2', '--record', str(bag)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    static, moving = _read(bag)
    assert set(static) >= still and len(moving) >= 5
    last = moving[-1]
    edges = dict(static, **{t.child_frame_id: (t.header.frame_id, _matrix(t.transform))
                            for t in last.transforms})
    assert len(edges) == len(static) + len(last.transforms)      # each frame once
    stamp = last.transforms[0].header.stamp
    sim = Stepper(Scene.load(scene_path(scene)))
    for _ in range(round((stamp.sec + stamp.nanosec * 1e-9) / sim.dt)):
        sim.step()
    truth = dict(zip(sim.link_names, sim.link_transforms))
    assert set(edges) == set(truth) - {'world'}
    for name, pose in truth.items():
        composed, frame = np.eye(4), name
        while frame != 'world':
            parent, transform = edges[frame]
            composed, frame = transform @ composed, parent
        np.testing.assert_allclose(composed, pose, atol=1e-9, err_msg=name)
