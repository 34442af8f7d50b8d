"""The node's recording policy on top of a BagRecorder: commands are recorded at the bag time
of the step they apply to, and a failed write (a full disk, a lost drive) stops the recording,
said once with what the bag keeps, while the run goes on. ROS-free.
"""

__all__ = ['RunRecording']


class RunRecording:
    """Recording of one run (or none).

    Args:
        recorder: the BagRecorder, or None when the run is not recorded.
        report: called once with the error message if recording stops early.
    """

    def __init__(self, recorder, report):
        self.recorder = recorder
        self.report = report
        self.stopped: str | None = None        # why recording stopped early, if it did
        self._inbox: list[tuple[str, bytes]] = []   # commands taken, not yet recorded

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

    def write(self, topic: str, t_ns: int, raw: bytes) -> None:
        self._do(lambda bag: bag.write(topic, t_ns, raw))

    def flush(self) -> None:
        self._do(lambda bag: bag.flush())

    def flush_if_due(self) -> None:
        self._do(lambda bag: bag.flush_if_due())

    def close(self) -> None:
        self._do(lambda bag: bag.close())

    def _do(self, action):
        if self.recorder is None:
            return
        try:
            action(self.recorder)
        except OSError as exc:
            recorder, self.recorder = self.recorder, None
            recorder.abandon()
            self._inbox.clear()
            self.stopped = str(exc)
            self.report(
                f'recording stopped: {exc}; the bag {recorder.path} stays readable up to its '
                f'last closed split ({recorder.last_split or "none"}, {recorder.bytes_written} '
                'bytes in closed splits); the simulation goes on')
