"""Pacer: the realtime schedule against a fake wall clock."""

import pytest

from affine_joint_sim.ros.pacing import Pacer
from helpers.clock import FakeClock


def test_steps_are_due_at_sim_time_over_the_factor():
    clock = FakeClock()
    pacer = Pacer(real_time_factor=2.0, clock=clock)
    assert pacer.wait(0.01) == pytest.approx(0.005)
    clock.now += 0.005
    assert pacer.wait(0.01) == 0.0
    clock.now += 0.5
    assert pacer.achieved(1.0) == pytest.approx(1.0 / 0.505)


def test_falling_far_behind_reanchors_instead_of_bursting():
    clock = FakeClock()
    pacer = Pacer(real_time_factor=1.0, max_lag=0.1, clock=clock)
    clock.now += 0.05                       # 50 ms late for the step due at 10 ms: catch up
    assert pacer.wait(0.01) == 0.0 and pacer.fell_behind == 0
    clock.now += 1.0                        # far behind: re-anchor at this step
    assert pacer.wait(0.02) == 0.0 and pacer.fell_behind == 1
    assert pacer.wait(0.03) == pytest.approx(0.01)


def test_anchor_restarts_the_schedule():
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    clock.now += 10.0                       # e.g. paused for 10 s
    pacer.anchor(0.5)
    assert pacer.wait(0.51) == pytest.approx(0.01)
