"""The Newton warm start (physics.newton) against a NumPy polar decomposition."""

import numpy as np

from affine_joint_sim.physics.evaluate import Stages
from helpers.physics import random_rotation
from test_joints import every_joint_type


def _polar(a):
    u, sigma, vt = np.linalg.svd(a)
    return u @ vt, vt.T @ np.diag(sigma) @ vt


def test_a_sheared_prediction_starts_from_its_rotation_times_the_last_stretch():
    stages = Stages(every_joint_type())
    rng = np.random.default_rng(9)
    q_n, q_tilde = stages.host.body_q0.copy(), stages.host.body_q0.copy()
    for b in range(stages.host.body_count):
        stretch = random_rotation(rng) @ np.diag(1 + rng.uniform(-1e-4, 1e-4, 3))
        q_n[b, 3:] = (random_rotation(rng) @ stretch).reshape(9)
        q_tilde[b, 3:] = (random_rotation(rng) @ np.diag(rng.uniform(0.9, 1.1, 3))
                          @ random_rotation(rng)).reshape(9)
    start = stages.warm_start(q_tilde, q_n)
    for b in range(stages.host.body_count):
        rotation = _polar(q_tilde[b, 3:].reshape(3, 3))[0]
        expected = rotation @ _polar(q_n[b, 3:].reshape(3, 3))[1]
        np.testing.assert_allclose(start[b, 3:].reshape(3, 3), expected, atol=1e-12)
        np.testing.assert_array_equal(start[b, :3], q_tilde[b, :3])


def test_a_prediction_that_adds_no_shear_is_kept_as_it_is():
    stages = Stages(every_joint_type())
    rng = np.random.default_rng(10)
    q_n = stages.host.body_q0.copy()
    q_tilde = q_n.copy()
    for b in range(stages.host.body_count):
        a = random_rotation(rng) @ np.diag(1 + rng.uniform(-1e-3, 1e-3, 3))
        q_n[b, 3:] = a.reshape(9)
        q_tilde[b, 3:] = (random_rotation(rng) @ a).reshape(9)      # same stretch, turned
    q_tilde[0, 3:] = random_rotation(rng).reshape(9)                 # a rotation exactly
    np.testing.assert_array_equal(stages.warm_start(q_tilde, q_n), q_tilde)
