"""Steps granted while paused: the simulation standard's StepSimulation and SimulateSteps
(README.md#the-simulation-standard).

The node's loop takes granted steps as it takes steps in play, lockstep included (each waits
for the controllers' answers to the state before it, so a controller stays in the loop), but
unpaced (a realtime node steps them flat out, as Gazebo does); only steps taken while paused
count. A future is done when the last one is (result None), or with the reason the grant
ended first (the simulation resumed or reset, the request canceled, the node stopping); the
service that asked awaits it in the ROS executor, which goes on taking commands meanwhile.
One grant at a time.
"""

import threading

from rclpy.task import Future

__all__ = ['StepGrant']


class StepGrant:
    """The steps granted and not yet taken; guarded by the node's lock."""

    def __init__(self):
        self.remaining = 0
        self._done = None
        self._executor = None
        self.answered = threading.Event()   # set by the service once it has its end
        self.answered.set()

    def open(self, count: int, executor) -> Future | None:
        """Grant ``count`` steps; the future of their end, or None while a grant runs.
        ``executor``: the one awaiting the future (woken when it is done)."""
        if self._done is not None:
            return None
        future = Future()
        if count <= 0:
            future.set_result(None)
            return future
        self.remaining, self._done, self._executor = count, future, executor
        self.answered.clear()
        return future

    @property
    def active(self) -> bool:
        return self.remaining > 0

    def took_step(self) -> None:
        """The loop took a step while paused (while a grant runs: one of the granted)."""
        if self.remaining:
            self.remaining -= 1
            if not self.remaining:
                self._end(None)

    def end(self, reason: str, future: Future | None = None) -> None:
        """End the running grant (only if it is ``future``, when given) before its steps are
        taken: its future's result is ``reason``."""
        if self._done is not None and future in (None, self._done):
            self._end(reason)

    def _end(self, result: str | None) -> None:
        done, self._done, self.remaining = self._done, None, 0
        done.set_result(result)
        if self._executor is not None:
            self._executor.wake()       # the awaiting service runs on at its next wake
