"""The simulation side of the node, without ROS: stepper, command buffer, pacer, lockstep gate
and the bag-time rule. The node runs it from its stepping thread under its lock and does the
ROS and bag work around it; tests drive it directly, without DDS.

Bag time [ns] is simulated time continued across resets: a reset after n steps starts the next
epoch one dt after the last state, ``epoch += n·dt + dt``, so bag time never runs backwards and
every state has its own.
"""

__all__ = ['SimLoop']


class SimLoop:
    """One run of a Stepper under commands.

    Args:
        sim: the Stepper.
        commands: the CommandBuffer its commands go through (``ros.robots.RobotCommands``
            for several robots).
        pacer: the realtime schedule (Pacer).
        gate: the lockstep gate (LockstepGate).
    """

    def __init__(self, sim, commands, pacer, gate):
        self.sim, self.commands, self.pacer, self.gate = sim, commands, pacer, gate
        self.dt_ns = round(sim.dt * 1e9)
        self.epoch_ns = 0

    @property
    def sim_time_ns(self) -> int:
        """Simulated time of the current state [ns], from the step counter."""
        return self.sim.step_count * self.dt_ns

    @property
    def bag_ns(self) -> int:
        """Bag time of the current state [ns]."""
        return self.epoch_ns + self.sim_time_ns

    def reset(self) -> None:
        """Back to the scene's initial state at t = 0 in a new epoch of bag time; pending
        commands are dropped and the scene's count as the last ones."""
        if self.sim.step_count:
            self.epoch_ns += self.sim_time_ns + self.dt_ns
        self.sim.reset()
        self.commands.reset(self.sim.torques[self.commands.scene_index])
        self.pacer.anchor(0.0)
        self.pacer.restart_window(0.0)

    def step(self) -> list[str]:
        """Apply the queued commands and advance one dt; returns the command timeouts'
        notices."""
        notices = self.commands.apply(self.sim, self.sim.time)
        self.sim.step()
        return notices

    def wait_before_step(self, mode: str, paused: bool) -> float:
        """Wall seconds [s] until the next step is due: inf while paused or while lockstep
        waits for answers to the current state, the pacer's wait in realtime, else 0."""
        if paused or (mode == 'lockstep' and not self.gate.released):
            return float('inf')
        if mode == 'realtime':
            return self.pacer.wait(self.sim.time + self.sim.dt)
        return 0.0

    def finished(self, duration: float) -> bool:
        """Whether ``duration`` [s] of simulated time (> 0) has been run since the reset."""
        return duration > 0.0 and self.sim.step_count >= round(duration / self.sim.dt)
