"""``Stepper.contacts`` (one replay of the report kernel over the pairs the last step listed)
against the reference: every pair of the host model evaluated one by one in plain NumPy
(``helpers.contact_reference``), in scenes with the ground, fixed shapes and bodies touching
each other, resting, sliding and landing."""

from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper
from helpers.contact_reference import active_contacts

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'


def _reference(sim, env=0):
    scratch = sim._scratch
    q = sim.body_q if sim.num_envs == 1 else sim.body_q[env]
    listed = scratch.near_pairs.numpy()[env, :scratch.near_count.numpy()[env]]

    def per_pair(lagged):       # the listed pairs' lagged values, by pair
        values = np.zeros(sim._host.pair_count)
        values[listed] = lagged.numpy()[env, :len(listed)]
        return values
    return active_contacts(sim._host, q, scratch.q_n.numpy()[env],
                           per_pair(scratch.friction_normal), per_pair(scratch.normal_damping),
                           sim.body_names, sim._host.static_names)


def _assert_same(contacts, reference):
    assert [(c['body'], c['other']) for c in contacts] == \
        [(c['body'], c['other']) for c in reference]
    scale = max([1.0] + [c['normal_force'] for c in reference])
    for ours, theirs in zip(contacts, reference):
        assert ours['distance'] == pytest.approx(theirs['distance'], rel=1e-9, abs=1e-15)
        np.testing.assert_allclose(ours['normal'], theirs['normal'], atol=1e-12)
        np.testing.assert_allclose(ours['point'], theirs['point'], atol=1e-12)
        assert ours['normal_force'] == pytest.approx(theirs['normal_force'], abs=1e-9 * scale)
        np.testing.assert_allclose(ours['friction_force'], theirs['friction_force'],
                                   atol=1e-9 * scale)


@pytest.mark.parametrize('name, steps', [('quadruped', 150), ('stack', 120), ('ramp', 150),
                                         ('pile', 60)])
def test_the_reported_contacts_are_the_reference_pair_by_pair(name, steps):
    sim = Stepper(Scene.load(SCENES / f'{name}.yaml'))
    seen = 0
    for k in range(steps):
        sim.step()
        if k % 10 == 9:         # through landing, sliding and resting
            contacts = sim.contacts
            _assert_same(contacts, _reference(sim))
            seen += len(contacts)
    assert seen > 0


def test_each_environment_reports_its_own_contacts():
    scene = Scene.load(SCENES / 'stack.yaml')
    batch = Stepper(scene, num_envs=2)
    for _ in range(60):
        batch.step()
    for env in range(2):
        _assert_same(batch.contacts[env], _reference(batch, env))
    assert batch.contacts[0] and len(batch.contacts) == 2


def test_a_read_with_too_little_room_makes_more_and_reads_again():
    sim = Stepper(Scene.load(SCENES / 'stack.yaml'))
    for _ in range(60):
        sim.step()
    sim._report = sim._capture_report(1)        # room for one contact per environment
    contacts = sim.contacts
    assert len(contacts) > 1
    _assert_same(contacts, _reference(sim))


def test_bodies_of_every_shape_report_the_reference_pairs_between_them():
    """Spheres, cylinders and boxes of two sizes dropped in a heap: pairs of bodies whose
    blocks of pairs are a single pair (two spheres), a few dozen and thousands, so that
    finding a pair's bodies (``touch_chunk``, then the touch pairs that start within its
    chunk) crosses several pairs of bodies within one chunk, and across chunks."""
    shapes = [{'sphere': {'radius': 0.03}}, {'cylinder': {'radius': 0.02, 'length': 0.06}},
              {'box': [0.05, 0.05, 0.05]}, {'sphere': {'radius': 0.02}},
              {'box': [0.03, 0.06, 0.02]}]
    bodies = [{'name': f'b{i}', 'mass': 0.2, 'shape': shapes[i % len(shapes)],
               'position': [0.07 * (i % 3) - 0.07, 0.07 * (i // 3 % 2) - 0.035,
                            0.05 + 0.08 * (i // 6)],
               'orientation': {'rpy': [0.3 * i, 0.2 * i, 0.1]}, 'collision': 'shape'}
              for i in range(12)]
    sim = Stepper(Scene.from_dict({'name': 'heap', 'dt': 0.005, 'ground': {'height': 0.0},
                                   'contact': {'friction': 0.5}, 'bodies': bodies}))
    sizes = np.diff(sim._host.touch_first)
    assert sizes.min() == 1 and sizes.max() > 1000
    between = 0
    for k in range(150):
        sim.step()
        if k % 10 == 9:
            contacts = sim.contacts
            _assert_same(contacts, _reference(sim))
            between += sum(c['other'] in sim.body_names for c in contacts)
    assert between > 100
