"""The bag's writer thread: it closes the splits handed to it, moves each into the bag, lists
it in metadata.yaml (replaced atomically), and opens the next split ahead of time.

The hand-off is bounded and never waits: ``swap`` gives the thread one full split and takes
the next one only when the thread has listed the previous split and opened the next; otherwise
it returns None at once and the caller keeps writing into the split it has (which then closes
later). A failure of the thread (a full disk) is kept in ``failure`` for the recording thread
to report; from then on nothing more is listed.
"""

import threading
from collections.abc import Callable
from pathlib import Path
from queue import SimpleQueue

from affine_joint_sim.ros.bag_metadata import BagIndex
from affine_joint_sim.ros.split_writer import SplitWriter

__all__ = ['SplitCloser', 'list_split']


def list_split(path: Path, index: BagIndex, split: SplitWriter, name: str) -> None:
    """Close ``split``, move it into the bag at ``path`` as ``name``, list it in ``index`` and
    in metadata.yaml (replaced atomically): the writer thread's work per split."""
    info = split.close(name)
    target = path / name
    split.file.replace(target)
    split.discard()                 # its scratch directory, now empty
    index.add(info, target.stat().st_size)
    scratch = path / 'metadata.yaml.tmp'
    try:
        scratch.write_text(index.text())
        scratch.replace(path / 'metadata.yaml')
    except BaseException:
        index.retract()             # not listed: the bag ends at the split listed before
        raise


class SplitCloser:
    """The writer thread of one bag.

    Args:
        path: the bag directory.
        index: what metadata.yaml lists; only this thread adds to it.
        open_split: opens a new split (on this thread, after each listed split).
        spare: the next split, already open.
    """

    def __init__(self, path: Path, index: BagIndex, open_split: Callable[[], SplitWriter],
                 spare: SplitWriter):
        self.path = path
        self.index = index
        self.failure: BaseException | None = None   # what stopped the thread, if anything
        self._open_split = open_split
        self._lock = threading.Lock()
        self._spare: SplitWriter | None = spare     # the next split, None while it is opened
        self._busy = False              # a split was handed over and is not listed yet
        self._finishing = False         # no split will follow the ones handed over
        self._dropped = False           # the recording was abandoned: list nothing more
        self._jobs: SimpleQueue = SimpleQueue()    # (split, name) to list; None: end
        self._thread = threading.Thread(target=self._run, name='bag_writer', daemon=True)
        self._thread.start()

    def swap(self, full: SplitWriter, name: str) -> SplitWriter | None:
        """Hand ``full`` over, to be listed as ``name``, and take the next split; or None (at
        once, nothing handed over) while the thread is still busy or has failed."""
        with self._lock:
            if self._busy or self._spare is None or self.failure is not None:
                return None
            spare, self._spare, self._busy = self._spare, None, True
        self._jobs.put((full, name))
        return spare

    def finish(self, last: tuple[SplitWriter, str] | None) -> None:
        """List ``last`` (a split and its name) after what was handed over, end the thread and
        wait for it. Raises the thread's failure unless the recording was abandoned."""
        self._finishing = True
        if last is not None:
            self._jobs.put(last)
        self._jobs.put(None)
        self._thread.join()
        if self.failure is not None and not self._dropped:
            raise self.failure

    def abandon(self) -> None:
        """List nothing more and end the thread (without waiting: ``finish`` waits)."""
        self._dropped = True
        self._jobs.put(None)

    def _run(self):
        while (job := self._jobs.get()) is not None:
            split, name = job
            if self._dropped or self.failure is not None:
                split.discard()
                continue
            try:
                list_split(self.path, self.index, split, name)
                spare = None if self._finishing else self._open_split()
            except Exception as exc:     # noqa: BLE001 - reported by the recording thread
                split.discard()
                self.failure = exc
                continue
            with self._lock:
                self._busy = False
                if spare is not None:
                    self._spare = spare
        with self._lock:
            spare, self._spare = self._spare, None
        if spare is not None:
            spare.discard()

