"""The lockstep gate: when a lockstep node may compute its next step (README.md#the-ros-2-node).

After the node publishes the state stamped t_n it waits for ``publishers`` answers: command
messages on the answer topics (``ros.topics.ANSWER_KEYS``: ``joint_commands``,
``effort_commands``, ``position_commands``) stamped t_n, or unstamped (stamp 0, which answers
whatever state is current; the array topics carry no stamp). A command stamped with another
time answers a state that is gone (a controller that lags or restarted): it is dropped, counted
and reported, so every step applies exactly the answers to its own state and the loop stays
deterministic. Answers are counted by source: the topic and the joints a message commands (one
controller per set of joints). A second answer from the same source to one state (a controller
answering the state again when it is republished, or its lost answer resent) applies to that
state's step, the latest command winning, but counts once: it is counted as a repeat, so one
controller answering twice never stands in for another whose answer is still on its way. An
answer from a source beyond ``publishers`` (more controllers than ``publishers``) also applies
to that step and is counted as surplus. In a scene of several robots ``publishers`` counts
each robot's controllers: a step waits for that many answers on every robot's topics.

While it waits, the gate says when to publish the waiting state again and when to log that it
is waiting. A copy goes out only to reach a controller that does not have the state: one that
joined after it was published (a volatile subscriber, started late or restarted: both a
``joint_states`` subscription and an answer-topic publisher matched since), or, failing all
answers for ``republish_every``, one whose answer was lost (sent before its publisher matched
the node). A controller that has the state never gets a copy that it could answer a second
time: an unstamped second answer would count for the next state. A viewer subscribing alone
(no answer publisher) gets none either. ROS-free: the node feeds it stamps, matched counts and
wall-clock time.
"""

import time

__all__ = ['LockstepGate']


class LockstepGate:
    """Answers counted against the state the node waits on.

    Args:
        publishers: answers a step waits for (one per controller in the loop, >= 1), from
            each of ``robots``.
        republish_every: wall seconds [s] without all answers after which a waiting state is
            published again when no controller joined (its answer may have been lost).
        report_every: wall seconds [s] between two "still waiting" reports.
        clock: wall clock in seconds (monotonic); injectable for tests.
        robots: the robots whose controllers answer (keys: the node's robot faces'; an
            answer says which robot it commands), changed as robots are spawned or deleted.
    """

    def __init__(self, publishers: int = 1, republish_every: float = 2.0,
                 report_every: float = 2.0, clock=time.monotonic, robots=(0,)):
        self.publishers = publishers
        self.robots = tuple(robots)
        self.republish_every = republish_every
        self.report_every = report_every
        self.clock = clock
        self.stamp_ns = 0
        self.stale = 0          # commands dropped for answering another state, since start
        self.surplus = 0        # answers from sources beyond ``publishers``, since start
        self.repeats = 0        # second answers from one source to one state, since start
        self._sources = set()   # (robot, source) that answered the waiting state
        self._matched = None    # matched counts when it was last published (None: unknown)
        self._since = self._published_at = self._reported_at = clock()

    def expect(self, stamp_ns: int, matched: tuple[int, int] | None = None) -> None:
        """A state stamped ``stamp_ns`` was published: count answers to it from now on.
        ``matched``: (subscriptions on the state topic, publishers on the answer topics)
        matched as it went out; None when not known (then the first ``republish_due`` takes
        its counts as the reference)."""
        self.stamp_ns = stamp_ns
        self._sources = set()
        self._matched = matched
        self._since = self._published_at = self._reported_at = self.clock()

    def answer(self, stamp_ns: int, source, robot=0) -> str:
        """Count a command stamped ``stamp_ns`` (0: unstamped) from ``source`` (hashable: the
        topic and the joints it commands) for ``robot``. Returns 'stale' if it answers
        another state (drop it), 'repeat' if ``source`` answered this state already,
        'surplus' if it is a source beyond ``publishers`` for that robot, else 'counted'; all
        but 'stale' apply to the waiting state."""
        if stamp_ns not in (0, self.stamp_ns):
            self.stale += 1
            return 'stale'
        if (robot, source) in self._sources:
            self.repeats += 1
            return 'repeat'
        self._sources.add((robot, source))
        if self._answers_for(robot) > self.publishers:
            self.surplus += 1
            return 'surplus'
        return 'counted'

    def _answers_for(self, robot) -> int:
        return sum(1 for r, _ in self._sources if r == robot)

    @property
    def answers(self) -> int:
        """Sources that answered the waiting state (all robots)."""
        return len(self._sources)

    @property
    def released(self) -> bool:
        """Whether the next step may be computed: every robot has its answers."""
        return all(self._answers_for(r) >= self.publishers for r in self.robots)

    def republish_due(self, matched: tuple[int, int]) -> bool:
        """Whether the waiting state should be published again now, given the counts matched
        now (as in ``expect``): a controller joined since it was last published (both counts
        grew), or it has waited ``republish_every`` since. Then the interval restarts."""
        before = matched if self._matched is None else self._matched
        joined = all(now > then for now, then in zip(matched, before))
        # one that leaves and comes back (a restarted controller) counts as joining
        self._matched = tuple(map(min, matched, before))
        now = self.clock()
        if self.released or (not joined and now - self._published_at < self.republish_every):
            return False
        self._matched, self._published_at = matched, now
        return True

    def report_due(self) -> float | None:
        """Seconds waited so far, if a "still waiting" report is due now, else None."""
        now = self.clock()
        if self.released or now - self._reported_at < self.report_every:
            return None
        self._reported_at = now
        return now - self._since
