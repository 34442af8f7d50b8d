"""The node's recording policy on top of a BagRecorder: commands are recorded at the bag time
of the step they apply to; a failed write (a full disk, a lost drive) stops the recording,
said once with what the bag keeps, while the run goes on; a split that stays open because the
bag's writer thread is behind is said, not waited for. ROS-free.
"""

import sqlite3

__all__ = ['RunRecording']


class RunRecording:
    """Recording of one run (or none).

    Args:
        recorder: the BagRecorder, or None when the run is not recorded.
        report: called once with the error message if recording stops early.
        warn: called with a warning each time a split stays open past its time because the
            bag's writer thread is still closing the previous one.
    """

    def __init__(self, recorder, report, warn):
        self.recorder = recorder
        self.report = report
        self.warn = warn
        self.stopped: str | None = None        # why recording stopped early, if it did
        self._inbox: list[tuple[str, bytes]] = []   # commands taken, not yet recorded
        self._abandoned = None                 # the recorder that stopped early
        self._late_said = 0                    # late splits warned about

    @property
    def active(self) -> bool:
        return self.recorder is not None

    def take(self, topic: str, raw: bytes) -> None:
        """A command as received (CDR bytes), recorded with the next step's bag time."""
        if self.recorder is not None:
            self._inbox.append((topic, raw))

    def record_taken(self, t_ns: int) -> None:
        """Record the commands taken since the last call at bag time ``t_ns`` [ns]."""
        inbox, self._inbox = self._inbox, []
        if inbox:
            self._do(lambda bag: [bag.write(topic, t_ns, raw) for topic, raw in inbox])

    def add_topic(self, topic) -> None:
        """Record ``topic`` (a BagTopic) too from now on."""
        self._do(lambda bag: bag.add_topic(topic))

    def write(self, topic: str, t_ns: int, raw: bytes) -> None:
        self._do(lambda bag: bag.write(topic, t_ns, raw))

    def flush(self) -> None:
        self._do(lambda bag: bag.flush())

    def flush_if_due(self) -> None:
        self._do(lambda bag: bag.flush_if_due())
        late = self.recorder.late_splits if self.recorder is not None else 0
        if late > self._late_said:
            self._late_said = late
            self.warn(f'recording: the bag writer is still closing the previous split, so the '
                      f'split being written stays open longer ({late} late split(s) so far); '
                      'the simulation does not wait for it')

    def close(self) -> None:
        """Finish the bag, or wait for a stopped recorder to clean up after itself."""
        if self._abandoned is not None:
            self._abandoned.close()
        self._do(lambda bag: bag.close())

    def _do(self, action):
        if self.recorder is None:
            return
        try:
            action(self.recorder)
        except (OSError, sqlite3.Error) as exc:     # a full disk, as the storage says it
            recorder, self.recorder = self.recorder, None
            recorder.abandon()
            self._abandoned = recorder
            self._inbox.clear()
            self.stopped = str(exc)
            self.report(
                f'recording stopped: {exc}; the bag {recorder.path} stays readable up to its '
                f'last closed split ({recorder.last_split or "none"}, {recorder.bytes_written} '
                'bytes in closed splits); the simulation goes on')
