"""SimLoop: the node's stepping without ROS: bag time across resets, lockstep waits,
commands at the step they arrive before, the run's duration."""

import pytest

from affine_joint_sim import Stepper
from affine_joint_sim.ros.commands import CommandBuffer
from affine_joint_sim.ros.lockstep import LockstepGate
from affine_joint_sim.ros.loop import SimLoop
from affine_joint_sim.ros.pacing import Pacer

DT_NS = 10_000_000


def make_loop():
    sim = Stepper('msg_configs/scenes/pendulum.yaml')
    loop = SimLoop(sim, CommandBuffer.for_stepper(sim), Pacer(), LockstepGate())
    loop.reset()
    return loop


def test_bag_time_goes_on_across_resets():
    loop = make_loop()
    for _ in range(3):
        loop.step()
    assert loop.bag_ns == 3 * DT_NS
    loop.reset()
    assert loop.sim_time_ns == 0 and loop.bag_ns == 4 * DT_NS     # one dt after the last state
    loop.step()
    assert loop.bag_ns == 5 * DT_NS
    loop.reset()
    loop.reset()                                   # nothing stepped since: the same epoch
    assert loop.bag_ns == 6 * DT_NS


def test_a_command_applies_to_the_next_step_and_lockstep_waits_for_its_answer():
    loop = make_loop()
    assert loop.wait_before_step('fast', paused=False) == 0.0
    assert loop.wait_before_step('fast', paused=True) == float('inf')
    loop.gate.expect(loop.sim_time_ns)
    assert loop.wait_before_step('lockstep', paused=False) == float('inf')
    loop.commands.torque('shoulder', 2.0)
    assert loop.gate.answer(0, ('joint_commands', None)) == 'counted'
    assert loop.wait_before_step('lockstep', paused=False) == 0.0
    loop.step()
    assert loop.sim.efforts[0] == 2.0


def test_duration_ends_the_run():
    loop = make_loop()
    assert not loop.finished(0.0)
    for _ in range(5):
        loop.step()
    assert loop.finished(0.05) and not loop.finished(0.06)


@pytest.mark.parametrize('factor', [1.0, 4.0])
def test_realtime_waits_for_the_pacer(factor):
    loop = make_loop()
    loop.pacer.real_time_factor = factor
    loop.pacer.anchor(0.0)
    wait = loop.wait_before_step('realtime', paused=False)
    assert 0.0 < wait <= 0.01 / factor


class FailingBag:
    """A BagRecorder stand-in whose writes fail like a full disk after ``room`` of them."""

    def __init__(self, room):
        self.room, self.written, self.abandoned, self.closed = room, [], False, False
        self.path, self.last_split, self.bytes_written = 'bag', 'bag_0.mcap', 1234

    def write(self, topic, t_ns, raw):
        if len(self.written) >= self.room:
            raise OSError(28, 'No space left on device')
        self.written.append((topic, t_ns, raw))

    def abandon(self):
        self.abandoned = True

    def close(self):
        self.closed = True


def test_recording_records_commands_at_their_step_and_stops_on_a_failed_write():
    from affine_joint_sim.ros.recording import RunRecording

    said = []
    bag = FailingBag(room=3)
    recording = RunRecording(bag, said.append, said.append)
    recording.take('/cmd', b'a')
    recording.take('/cmd', b'b')
    recording.record_taken(5)
    assert bag.written == [('/cmd', 5, b'a'), ('/cmd', 5, b'b')]
    recording.write('/joint_states', 5, b's')
    recording.write('/joint_states', 6, b't')            # the disk is full now
    assert not recording.active and bag.abandoned and len(said) == 1
    assert 'No space left on device' in recording.stopped
    assert 'last closed split (bag_0.mcap, 1234 bytes' in said[0]
    recording.take('/cmd', b'c')
    recording.record_taken(7)
    recording.close()                                     # nothing more, nothing raised
    assert len(said) == 1 and bag.closed                  # its writer thread was waited for
