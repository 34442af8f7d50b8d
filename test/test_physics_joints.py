"""Joint coordinates (physics.joints): values against rigid motions of known angle or distance,
gradients against finite differences, at non-rigid states as Newton visits them."""

import math

import numpy as np
import pytest

from affine_joint_sim.physics.evaluate import Stages
from helpers.physics import Probe, random_rotation
from test_joints import every_joint_type


def _axis_rotation(axis, angle):
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * skew + (1 - math.cos(angle)) * skew @ skew


def _rigidly_moved(q, body, rotation, pivot, shift):
    """A copy of q with ``body`` turned by ``rotation`` about ``pivot`` and moved by shift."""
    q = q.copy()
    a = q[body, 3:].reshape(3, 3)
    q[body, :3] = pivot + rotation @ (q[body, :3] - pivot) + shift
    q[body, 3:] = (rotation @ a).reshape(9)
    return q


@pytest.mark.parametrize('angle', [0.3, -2.0, 3.0])
def test_coordinates_of_known_rigid_motions(angle):
    stages = Stages(every_joint_type())
    host = stages.host
    names = [j.name for j in every_joint_type().joints]
    cube = every_joint_type().body_index('cube')
    # the cube slides 0.04 m along the slide's axis (+x): distance 0.04, others unchanged
    q = _rigidly_moved(host.body_q0, cube, np.eye(3), np.zeros(3), [0.04, 0, 0])
    x = stages.joint_coordinates(q)[0]
    assert x[names.index('slide')] == pytest.approx(0.04, abs=1e-12)
    assert x[names.index('hinge')] == pytest.approx(0.0, abs=1e-12)
    assert x[names.index('weld')] == 0.0
    # every body below the hinge turns by angle about its axis (+x through the origin)
    q = host.body_q0
    for body in range(1, host.body_count):
        q = _rigidly_moved(q, body, _axis_rotation([1, 0, 0], angle), np.zeros(3), np.zeros(3))
    x = stages.joint_coordinates(q)[0]
    assert x[names.index('hinge')] == pytest.approx(angle, abs=1e-12)
    assert x[names.index('slide')] == pytest.approx(0.0, abs=1e-12)


def test_coordinate_gradients_match_finite_differences():
    probe = Probe(every_joint_type(), np.random.default_rng(8), stretch=False)
    stages, h = probe.stages, 1e-7
    x, g_parent, g_child = stages.joint_coordinates(probe.q0)
    host = stages.host
    for k in range(host.joint_count):
        for side, body, gradient in (('parent', host.joint_parent[k], g_parent[k]),
                                     ('child', host.joint_child[k], g_child[k])):
            fd = np.zeros(12)
            for d in range(12):
                plus, minus = probe.q0.copy(), probe.q0.copy()
                plus[body, d] += h
                minus[body, d] -= h
                fd[d] = (stages.joint_coordinates(plus)[0][k]
                         - stages.joint_coordinates(minus)[0][k]) / (2 * h)
            np.testing.assert_allclose(gradient, fd, rtol=1e-6, atol=1e-7,
                                       err_msg=f'joint {k} {side}')
    weld = [j.name for j in every_joint_type().joints].index('weld')
    assert x[weld] == 0.0 and np.all(g_parent[weld] == 0.0) and np.all(g_child[weld] == 0.0)


def test_random_rotation_helper_is_proper():
    r = random_rotation(np.random.default_rng(0))
    assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)
