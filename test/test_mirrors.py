"""The GPU's host-mirror path (commands uploaded when written, outputs downloaded when read, one
trouble count per step), run on the CPU where CI can test it: ``_mirror_on_cpu`` gives the
Stepper separate host arrays and the same captured copies a CUDA device gets."""

import numpy as np
import pytest

from affine_joint_sim import Stepper
from affine_joint_sim.physics.host.fields import STAT_FLOAT_NAMES, STAT_INT_NAMES
from affine_joint_sim.sim_warnings import SimulationWarning
from test_extremes import pendulum
from test_joints import every_joint_type


class MirroredStepper(Stepper):
    _mirror_on_cpu = True


def outputs(sim):
    stats = sim.stats
    return [sim.angles, sim.velocities, sim.efforts, sim.body_q, sim.body_qdot, sim.energy,
            sim.link_transforms, stats['newton_iterations'], stats['residual']]


def test_mirrored_path_equals_the_direct_views_while_commands_change():
    scene = every_joint_type()
    direct, mirrored = Stepper(scene, num_envs=3), MirroredStepper(scene, num_envs=3)
    forces = np.random.default_rng(7).uniform(-2.0, 2.0, (60, 3))
    for step in range(60):
        for sim in (direct, mirrored):
            if step % 7 == 0:
                sim.set_torque('slide', forces[step])
            if step == 20:
                sim.set_enabled('hinge', [True, False, True])
            if step % 11 == 0:
                sim.set_target('hinge', 0.1 * step / 60)
            if step == 40:
                sim.set_drive_enabled('slide', False)
            if step == 50:
                sim.reset()             # uploads the scene's commands, stales every output
            sim.step()
        if step % 5 == 4:   # outputs not read for four steps must still be current when read
            for a, b in zip(outputs(direct), outputs(mirrored)):
                assert np.array_equal(a, b)
    assert np.array_equal(direct.torques, mirrored.torques)


def test_a_step_moves_only_what_is_read():
    sim = MirroredStepper(every_joint_type(), num_envs=4)
    moves = sim._downloads
    for _ in range(5):
        sim.step()
    assert (moves.copies, moves.bytes_moved) == (0, 0)
    sim.angles, sim.velocities, sim.efforts, sim.angles
    joints = 3 * 4 * len(sim.joint_names) * 8                  # three float64 (env, joint)
    assert (moves.copies, moves.bytes_moved) == (1, joints)
    sim.step()
    sim.body_q
    sim.stats                                                  # the statistics alone
    bodies = 2 * 4 * len(sim.body_names) * 12 * 8
    stats = 4 * (len(STAT_INT_NAMES) * 4 + len(STAT_FLOAT_NAMES) * 8)   # int32 and float64
    assert moves.copies == 3 and moves.bytes_moved == joints + bodies + stats
    assert not sim._uploads.pending
    sim.set_torque('slide', 1.0)
    assert sim._uploads.pending
    sim.step()
    assert not sim._uploads.pending


@pytest.mark.parametrize('kind', [Stepper, MirroredStepper])
def test_the_problem_counts_match_the_stats_flags_and_warn_once(kind):
    sim = kind(pendulum(0.0, solver={'newton_max_iter': 2, 'newton_tol': 1e-6}), num_envs=4)
    sim.set_torque('joint0', [0.0, 0.0, 50.0, 50.0])
    with pytest.warns(SimulationWarning, match='did not converge') as caught:
        for _ in range(10):
            sim.step()
            stats = sim.stats
            kinds = np.array([~stats['converged'] & ~stats['step_rejected'],
                              stats['non_finite'], stats['angle_aliased'],
                              stats['torque_dropped'], stats['line_search_failures'] != 0])
            expected = [int(np.sum(kinds.any(axis=0)))] + [int(np.sum(k)) for k in kinds]
            expected.append(0)      # near_full: without contact there is no near list
            assert list(sim._problems.sum(axis=0)) == expected     # summed over the launches
            assert 0 < expected[0] < 4       # the resting environments stay clear
    assert len([w for w in caught if 'did not converge' in str(w.message)]) == 1


def test_a_problem_already_warned_about_moves_no_stats():
    sim = MirroredStepper(pendulum(0.0, solver={'newton_max_iter': 2, 'newton_tol': 1e-6}),
                          num_envs=2)
    sim.set_torque('joint0', 50.0)
    with pytest.warns(SimulationWarning, match='did not converge'):
        for _ in range(10):
            sim.step()
    # the first message's residual
    assert sim._problems.sum(axis=0)[1] == 2 and sim._downloads.copies == 1


def test_commands_written_without_a_setter_are_not_uploaded():
    direct, mirrored = Stepper(every_joint_type()), MirroredStepper(every_joint_type())
    mirrored.step(), direct.step()
    mirrored._torque[:, mirrored.joint_names.index('slide')] = 5.0   # no written(): stays here
    for _ in range(5):
        mirrored.step(), direct.step()
    assert np.array_equal(mirrored.angles, direct.angles)
