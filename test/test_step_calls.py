"""What a step called, counted in its statistics: ``hessians`` (assembled and factored),
``gradient_tries`` (a gradient solved on the last factors, the convergence check that spares a
Hessian), ``energies`` and, with contact, ``near_gathers``. A robot's usual step factors once
and evaluates no energy (from the last step's correction its first update ends it), nor does
a step with contact that converges on its first update (a resting body's first step
compares E at q_n and at its start); where friction is loaded the last factors are never
tried (they could not end Newton); a contact scene gathers its near list at its first step
and again only where a body outruns its margin."""

import numpy as np

from affine_joint_sim import Scene, Stepper
from affine_joint_sim.resources import scene_path


def _calls(sim):
    stats = sim.stats
    return (stats['newton_iterations'], stats['hessians'], stats['gradient_tries'],
            stats['energies'])


def _resting_box(mu: float) -> Stepper:
    return Stepper(Scene.from_dict({
        'dt': 0.01, 'ground': {'height': 0.0}, 'contact': {'friction': mu},
        'bodies': [{'name': 'box', 'mass': 1.0, 'shape': {'box': [0.1, 0.1, 0.1]},
                    'position': [0.0, 0.0, 0.0506], 'collision': 'shape'}]}))


def test_a_robot_step_factors_once_and_evaluates_no_energy():
    sim = Stepper(Scene.load(scene_path('pendulum')))
    sim.step()      # from the prediction: the second iteration is the check alone
    assert _calls(sim) == (2, 1, 1, 0)
    calls = []
    for _ in range(50):     # from the last step's correction: its first update ends most
        sim.step()
        calls.append(_calls(sim))
    assert set(calls) <= {(1, 1, 0, 0), (2, 1, 1, 0)}
    assert calls.count((1, 1, 0, 0)) >= 45
    assert 'near_gathers' not in sim.stats      # a statistic of scenes with contact


def test_a_step_with_contact_that_converges_on_its_first_update_evaluates_no_energy():
    sim = _resting_box(0.5)
    pose = np.eye(4)
    pose[2, 3] = 1.0
    sim.set_body_state('box', pose)
    for _ in range(20):     # falling freely 1 m above the ground: the prediction is the step
        sim.step()
        assert _calls(sim) == (1, 1, 0, 0)
    sim = _resting_box(0.5)
    sim.step()
    assert _calls(sim)[3] >= 2      # resting: E at q_n and at the prediction, compared
    for _ in range(10):     # settled onto its resting gap
        sim.step()
    for _ in range(20):     # from the last step's correction, which carries its support
        sim.step()
        assert _calls(sim) == (1, 1, 0, 0)


def test_loaded_friction_spares_the_check_on_the_last_factors():
    counts = {}
    for mu in (0.5, 0.0):
        sim = _resting_box(mu)
        tries = hessians = 0
        for _ in range(100):
            sim.step()
            iterations, fresh, tried, energies = _calls(sim)
            assert fresh + tried >= iterations
            tries += tried
            hessians += fresh
        counts[mu] = tries, hessians
    # resting with friction: never tried; without: tried and refused (the barrier is active),
    # a Hessian following each time, so both assemble alike
    assert counts[0.5][0] == 0 < counts[0.0][0]
    assert counts[0.0][1] >= counts[0.5][1] - 5


def test_a_contact_scene_gathers_at_its_first_step_and_where_bodies_outrun_their_margins():
    sim = _resting_box(0.5)
    sim.step()
    assert sim.stats['near_gathers'] >= 1
    gathers = 0
    for _ in range(100):
        sim.step()
        gathers += sim.stats['near_gathers']
    assert gathers <= 2                         # a box at rest stays within its margin
    sim = Stepper(Scene.load(scene_path('ramp')))
    total = 0
    for _ in range(100):
        sim.step()
        total += sim.stats['near_gathers']
    assert total >= 10                          # a box sliding down the ramp outruns it
