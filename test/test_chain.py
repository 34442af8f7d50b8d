"""Generated chain scenes: geometry that the scaling benchmark and extremes suite rely on."""

import math

import numpy as np
import pytest

from affine_joint_sim.chain import chain_scene


@pytest.mark.parametrize('angle', [0.0, 0.4])
def test_chain_hinges_sit_at_link_ends(angle):
    scene = chain_scene(5, link_length=0.3, angle=angle, section=0.1)
    assert [j.name for j in scene.joints] == [f'joint{k}' for k in range(5)]
    down = np.array([0.0, math.sin(angle), -math.cos(angle)])
    for k, (body, joint) in enumerate(zip(scene.bodies[1:], scene.joints)):
        hinge = (np.array(joint.x0) + np.array(joint.x1)) / 2
        np.testing.assert_allclose(hinge, k * 0.3 * down, atol=1e-12)
        np.testing.assert_allclose(body.position, (k + 0.5) * 0.3 * down, atol=1e-12)
        assert joint.parent == ('base' if k == 0 else f'link{k - 1}')
        assert list(body.shape.box) == [0.1, 0.1, 0.3]
        assert np.linalg.norm(np.subtract(joint.x1, joint.x0)) == pytest.approx(0.1)


def test_chain_rejects_zero_links():
    with pytest.raises(ValueError, match='links'):
        chain_scene(0)
