"""The shipped gripper arm grasps (scene ``grasp``, control script ``grasp``; README.md#grasping):
run in process as the demo controller runs it over ROS, its fingers close on the cube on the
table and lift it 12 cm when friction can carry it (2 μ F > m g), and leave it on the table when
it cannot; at every step the fingers and the cube are apart by the separating-axis test and the
cube stays above the table."""

import numpy as np
import pytest

from affine_joint_sim.control_script import ControlScript, Gains, command_stepper
from affine_joint_sim.resources import scene_path
from affine_joint_sim.scene import Scene
from affine_joint_sim.stepper import Stepper
from helpers.separation import separation

FINGERS = {'left_finger': 0.01, 'right_finger': -0.01}  # finger box centre: x [m] in its link
FINGER_HALF, CUBE_HALF = [0.005, 0.01, 0.03], [0.02] * 3   # half sides [m]
TABLE_TOP = 0.2                                            # [m]


def _box(transform, offset) -> np.ndarray:
    """The 12-vector state (centre, A row by row) of a box at ``offset`` in a link frame."""
    q = np.empty(12)
    q[:3] = transform[:3, 3] + transform[:3, :3] @ offset
    q[3:] = transform[:3, :3].reshape(-1)
    return q


@pytest.mark.parametrize('finger_kp, lifted', [(200.0, True), (30.0, False)])
def test_the_gripper_arm_lifts_the_cube_only_when_friction_can_carry_it(finger_kp, lifted):
    """The fingers close 1.6 cm past the cube's sides: with kp 200 N/m each squeezes about
    3.2 N (2 μ F = 5.1 N against m g = 0.98 N) and the cube comes up with the hand; with
    kp 30 N/m about 0.47 N (0.76 N < m g) and it slips out, staying on the table."""
    script = ControlScript.load('grasp')
    gains = {**script.gains, **{f'{finger}_joint': Gains(kp=finger_kp, kd=2.0)
                                for finger in FINGERS}}
    script = script.model_copy(update={'gains': gains})
    sim = Stepper(Scene.load(scene_path('grasp')))
    names = sim.link_names
    cube = names.index('cube')
    start = sim.link_transforms[cube, 2, 3]
    for _ in range(3000):
        command_stepper(sim, script)
        sim.step()
        assert sim.stats['min_distance'] > 0.0
        links = sim.link_transforms
        cube_q = _box(links[cube], np.zeros(3))
        for finger, x in FINGERS.items():
            finger_q = _box(links[names.index(finger)], np.array([x, 0.0, 0.03]))
            assert separation(finger_q, cube_q, FINGER_HALF, CUBE_HALF) > 0.0, finger
        corners = cube_q[:3] + np.abs(cube_q[3:].reshape(3, 3)) @ np.array(CUBE_HALF)
        assert 2 * cube_q[2] - corners[2] > TABLE_TOP             # the lowest corner's z
    assert sim.problem_totals['not_converged'] == 0
    rise = sim.link_transforms[cube, 2, 3] - start
    if lifted:
        assert rise == pytest.approx(0.118, abs=0.005)
    else:
        assert abs(rise) < 1e-3


def test_the_arm_collapsing_onto_the_cube_converges_every_step():
    """Without its controller the arm falls onto the cube and wedges it against the table:
    every step converges within the default cap of a scene with contact and nothing
    penetrates. Its impact's steps took up to ~80 Newton iterations under BDF2 (one did not
    converge at 32); taken by BDF1 (docs/physics.md#impacts) they take 15."""
    sim = Stepper(Scene.load(scene_path('grasp')))
    iterations = []
    for _ in range(500):
        sim.step()
        assert sim.stats['converged'] and sim.stats['min_distance'] > 0.0, sim.step_count
        iterations.append(sim.stats['newton_iterations'])
    assert sim.stats['contacts'] > 0 and max(iterations) > 10      # it did hit the cube
