"""Stopping a fleet command: Ctrl-C (SIGINT) and SIGTERM become one exception, ``Stopped``, in
the main process, so that the executor ends its workers on the way out and the command prints
what finished and exits 128 + the signal's number (130, 143), as shells do.

Worker processes ignore SIGINT (``ignore_interrupts``): Ctrl-C reaches the whole process group,
and a worker that turned it into a failed job would keep taking jobs; the main process ends
them instead.
"""

import signal
from contextlib import contextmanager

__all__ = ['Stopped', 'SIGNALS', 'stoppable', 'ignore_interrupts']

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stopped(BaseException):
    """A stop signal arrived (a BaseException, like KeyboardInterrupt: no job's ``except
    Exception`` takes it for a failure)."""

    def __init__(self, number: int):
        super().__init__(signal.Signals(number).name)
        self.number = number

    @property
    def name(self) -> str:
        """SIGINT or SIGTERM."""
        return signal.Signals(self.number).name

    @property
    def exit_status(self) -> int:
        """128 + the signal's number: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.number


@contextmanager
def stoppable():
    """Within: SIGINT and SIGTERM raise ``Stopped``. The first one also ignores both from then
    on, so that a second Ctrl-C cannot cut the cleanup and the summary short (the command is
    ending anyway); otherwise leaving restores the handlers there were."""
    stops = []

    def stop(number, frame):
        for each in SIGNALS:
            signal.signal(each, signal.SIG_IGN)
        stops.append(number)
        raise Stopped(number)

    previous = {number: signal.signal(number, stop) for number in SIGNALS}
    try:
        yield
    finally:
        if not stops:
            for number, handler in previous.items():
                signal.signal(number, handler)


def ignore_interrupts() -> None:
    """In a worker process: Ctrl-C is the main process's to handle."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
