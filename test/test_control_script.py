"""Control scripts (README.md#grasping): targets between keyframes follow the smooth step
3s² − 2s³ and hold outside them, each joint along the keyframes that name it; bad scripts and
bad flags are one line naming the file or flag, exit 2."""

import numpy as np
import pytest

from affine_joint_sim.control_script import ControlScript, pd_torques
from affine_joint_sim.scene import SceneError
from helpers.cli import cli

SCRIPT = {'gains': {'a': {'kp': 10.0, 'kd': 1.0}, 'b': {'kp': 20.0, 'kd': 2.0}},
          'keyframes': [{'t': 0.0, 'targets': {'a': 0.0, 'b': 1.0}},
                        {'t': 1.0, 'targets': {'a': 2.0}},
                        {'t': 3.0, 'targets': {'a': 4.0, 'b': -1.0}}]}


def test_targets_follow_the_smooth_step_between_the_keyframes_that_name_each_joint():
    script = ControlScript.model_validate(SCRIPT)
    for t, s_a, s_b in ((0.25, 0.25, 0.25 / 3), (0.5, 0.5, 0.5 / 3), (2.0, 0.5, 2 / 3)):
        step_a = 3 * s_a ** 2 - 2 * s_a ** 3
        a = 2.0 * step_a if t <= 1.0 else 2.0 + 2.0 * step_a
        b = 1.0 - 2.0 * (3 * s_b ** 2 - 2 * s_b ** 3)      # b: one smooth step from 0 to 3 s
        assert script.targets_at(t) == pytest.approx([a, b], abs=1e-12), t
    assert script.targets_at(0.0).tolist() == [0.0, 1.0]
    assert script.targets_at(1.0).tolist()[0] == 2.0
    assert script.targets_at(7.0).tolist() == [4.0, -1.0]           # holds after the last
    assert script.kp.tolist() == [10.0, 20.0] and script.joints == ['a', 'b']
    tau = pd_torques(script.kp, script.kd, np.array([1.0, 1.0]), np.array([0.5, 2.0]),
                     np.array([1.0, -1.0]), effort_limit=15.0)
    assert tau.tolist() == [10.0 * 0.5 - 1.0, -15.0]      # 20 (1 − 2) + 2 = −18, clipped


@pytest.mark.parametrize('change, message', [
    ({'keyframes': [{'t': 1.0, 'targets': {'a': 0.0, 'b': 0.0}},
                    {'t': 1.0, 'targets': {'a': 1.0}}]},
     'keyframes[1].t (1) must be later than keyframes[0].t (1)'),
    ({'keyframes': [{'t': 0.0, 'targets': {'a': 0.0, 'b': 0.0, 'knee': 1.0}}]},
     'keyframes[0].targets: knee not in gains (a, b)'),
    ({'keyframes': [{'t': 0.0, 'targets': {'a': 0.0}}]}, 'gains: b named in no keyframe'),
    ({'gains': {'a': {'kp': -1.0, 'kd': 0.0}}}, 'gains.a.kp'),
])
def test_a_bad_script_is_refused_naming_the_file_and_the_key(tmp_path, change, message):
    path = tmp_path / 'bad.yaml'
    path.write_text(__import__('yaml').safe_dump({**SCRIPT, **change}))
    with pytest.raises(SceneError, match=str(path)) as caught:
        ControlScript.load(path)
    assert message in str(caught.value)


@pytest.mark.parametrize('args, message', [
    (['demo', '--scene', 'pendulum', '--script', 'grasp'],
     "--script grasp: shoulder_pan, shoulder_lift, elbow, wrist_1, wrist_2, wrist_3, "
     "left_finger_joint, right_finger_joint not a moving joint of scene 'pendulum'"),
    (['demo', '--scene', 'grasp', '--script', 'grasp', '--target', 'elbow=1'],
     '--script replaces --target: give one of them'),
    (['demo', '--script', 'nowhere'], "control script 'nowhere' is neither a file nor a "
                                      'packaged control script (grasp)'),
    (['controller'], 'give --target JOINT=RAD (repeatable) or --script'),
])
def test_bad_script_flags_are_one_line_and_exit_2(args, message):
    done = cli(*args)
    assert done.returncode == 2 and message in done.stderr, done.stderr
    assert 'Traceback' not in done.stderr
