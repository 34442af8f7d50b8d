"""Wall-clock pacing of the realtime mode, and the achieved real-time factor.

A step that ends at simulated time t is due at wall time ``anchor_wall + (t - anchor_sim) /
real_time_factor``. The schedule is anchored, so timer jitter does not accumulate; when the
simulation falls further behind than ``max_lag`` it re-anchors instead of bursting to catch up,
and counts the event.
"""

import time

__all__ = ['Pacer']


class Pacer:
    """Schedule of realtime steps.

    Args:
        real_time_factor: simulated seconds per wall second (> 0).
        max_lag: wall seconds [s] behind schedule after which the schedule re-anchors.
        clock: wall clock in seconds (monotonic); injectable for tests.
    """

    def __init__(self, real_time_factor: float = 1.0, max_lag: float = 0.1,
                 clock=time.monotonic):
        self.real_time_factor = real_time_factor
        self.max_lag = max_lag
        self._clock = clock
        self.fell_behind = 0
        self.anchor(0.0)
        self._start_wall, self._start_sim = self._anchor_wall, 0.0

    def anchor(self, sim_time: float) -> None:
        """Restart the schedule at ``sim_time`` [s] from now (start, resume, reset, new factor)."""
        self._anchor_wall = self._clock()
        self._anchor_sim = sim_time

    def wait(self, next_sim_time: float) -> float:
        """Wall seconds until the step ending at ``next_sim_time`` is due (0 when due now)."""
        due = self._anchor_wall + (next_sim_time - self._anchor_sim) / self.real_time_factor
        late = self._clock() - due
        if late > self.max_lag:
            self.fell_behind += 1
            self._anchor_wall = self._clock() - (next_sim_time - self._anchor_sim) / \
                self.real_time_factor
            return 0.0
        return max(0.0, -late)

    def achieved(self, sim_time: float) -> float:
        """Simulated seconds per wall second since the window began (see ``restart_window``)."""
        wall = self._clock() - self._start_wall
        return (sim_time - self._start_sim) / wall if wall > 0.0 else 0.0

    def restart_window(self, sim_time: float) -> None:
        """Begin a new window for ``achieved`` at ``sim_time`` [s]."""
        self._start_wall, self._start_sim = self._clock(), sim_time
