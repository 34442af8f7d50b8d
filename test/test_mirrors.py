"""The GPU's host-mirror path (commands uploaded when written, outputs downloaded when read, one
trouble count per step), run on the CPU where CI can test it: ``_mirror_on_cpu`` gives the
Stepper separate host arrays and the same captured copies a CUDA device gets."""

import numpy as np
import pytest

from affine_joint_sim import Stepper
from affine_joint_sim.physics.fields import STAT_INT_NAMES
from affine_joint_sim.physics.model import SimulationWarning
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
    sim.stats                                                  # stats, and q for the strain
    bodies = 2 * 4 * len(sim.body_names) * 12 * 8
    assert moves.copies == 3 and moves.bytes_moved == joints + bodies + 4 * (8 * 4 + 2 * 8)
    assert not sim._uploads.pending
    sim.set_torque('slide', 1.0)
    assert sim._uploads.pending
    sim.step()
    assert not sim._uploads.pending


@pytest.mark.parametrize('kind', [Stepper, MirroredStepper])
def test_the_trouble_count_is_the_number_of_flagged_envs_and_warns_once(kind):
    sim = kind(pendulum(0.0, solver={'newton_max_iter': 2, 'newton_tol': 1e-6}), num_envs=4)
    sim.set_torque('joint0', [0.0, 0.0, 50.0, 50.0])
    flags = slice(STAT_INT_NAMES.index('converged'), None)
    clear = np.array([name == 'converged' for name in STAT_INT_NAMES[flags]])
    with pytest.warns(SimulationWarning, match='did not converge') as caught:
        for _ in range(10):
            sim.step()
            ints = np.column_stack([sim.stats[name] for name in STAT_INT_NAMES[flags]])
            flagged = int(np.sum(np.any(ints != clear, axis=1)))
            assert sim._troubled[0] == flagged
            assert 0 < flagged < 4          # the resting environments stay clear
    assert len([w for w in caught if 'did not converge' in str(w.message)]) == 1
