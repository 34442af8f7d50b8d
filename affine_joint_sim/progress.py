"""A progress bar for long commands (the bench sweep, render)."""

import sys
import time

__all__ = ['Progress', 'print_above']


def print_above(line: str) -> None:
    """``line`` on stderr, on a line of its own: a progress bar being drawn on the current line
    is cleared first (on a terminal) or ended there (elsewhere); its next update draws it
    again below."""
    sys.stderr.write(('\r\x1b[K' if sys.stderr.isatty() else '\n') + line + '\n')
    sys.stderr.flush()


class Progress:
    """A one-line progress bar on stderr: done/total, elapsed time and the current item."""

    def __init__(self, total: int, width: int = 30):
        self.total, self.width, self.done, self.start = total, width, 0, time.monotonic()

    def show(self, item: str) -> None:
        filled = self.width * self.done // max(self.total, 1)
        sys.stderr.write(f'\r[{"#" * filled}{"." * (self.width - filled)}] {self.done}/'
                         f'{self.total} {time.monotonic() - self.start:5.0f} s  {item:<48.48}')
        sys.stderr.flush()

    def advance(self) -> None:
        self.done += 1
        if self.done == self.total:
            self.show('done')
            sys.stderr.write('\n')
