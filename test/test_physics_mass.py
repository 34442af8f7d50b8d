"""Mass properties of primitives against numerical integration over a voxel grid."""

import numpy as np
import pytest

from affine_joint_sim.physics.host.mass import mass_properties
from affine_joint_sim.scene import Shape


def _voxel_integrals(inside, half, density, n=120):
    """m and diag ∫ρ x̄x̄ᵀ dV by the midpoint rule over the bounding box (half extents)."""
    axes = [(np.arange(n) + 0.5) / n * 2 * h - h for h in half]
    x, y, z = np.meshgrid(*axes, indexing='ij')
    mask = inside(x, y, z)
    cell = np.prod(2 * np.asarray(half) / n)
    mass = density * cell * mask.sum()
    moment = [density * cell * (c * c)[mask].sum() for c in (x, y, z)]
    return mass, np.array(moment)


@pytest.mark.parametrize('shape, inside, half', [
    ({'box': [0.2, 0.4, 1.0]}, lambda x, y, z: np.ones_like(x, dtype=bool), (0.1, 0.2, 0.5)),
    ({'cylinder': {'radius': 0.3, 'length': 0.8}}, lambda x, y, z: x * x + y * y <= 0.09,
     (0.3, 0.3, 0.4)),
    ({'sphere': {'radius': 0.25}}, lambda x, y, z: x * x + y * y + z * z <= 0.0625,
     (0.25, 0.25, 0.25)),
])
def test_closed_forms_match_numerical_integration(shape, inside, half):
    props = mass_properties(Shape(**shape), density=800.0)
    mass, moment = _voxel_integrals(inside, half, 800.0)
    assert props.mass == pytest.approx(mass, rel=2e-3)
    np.testing.assert_allclose(props.second_moment, moment, rtol=5e-3)
    np.testing.assert_allclose(props.half_extent, half)
    assert props.volume == pytest.approx(props.mass / 800.0)


def test_mass_given_directly_and_the_spec_cube():
    # libuipc's 0.4 m test cube, ρ = 1000 (docs/physics.md#primitives): m = 64 kg, S = 0.853333 I,
    # I_cm = 1.706667
    props = mass_properties(Shape(box=(0.4, 0.4, 0.4)), density=1000.0)
    assert props.mass == pytest.approx(64.0)
    np.testing.assert_allclose(props.second_moment, 0.8533333333, rtol=1e-9)
    np.testing.assert_allclose(np.diag(props.inertia), 1.7066666667, rtol=1e-9)
    assert mass_properties(Shape(sphere={'radius': 1.0}), mass=2.0).mass == 2.0
