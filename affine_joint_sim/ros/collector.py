"""Python's garbage collector in the node's process: timed, and kept out of the stepping loop.

A collection stops every thread of the process (the GIL). A full collection (generation 2)
walks every tracked object: after the node is built (Warp, rclpy, NumPy, the scene) that is
about a million objects and 40–100 ms here, long enough to show as a gap in ``joint_states``
of a realtime run. ``settle`` collects once, then freezes what exists (``gc.freeze``: those
objects are never walked again; they stay alive for the node's life anyway), so a later
collection walks only what the run itself allocates. ``CollectorPauses`` times the
collections that happen while it is installed.
"""

import gc
import time

__all__ = ['CollectorPauses', 'settle']


def settle() -> None:
    """Collect what the set-up left, then freeze the surviving objects out of later
    collections (call once, when the node is built and before it steps)."""
    gc.collect()
    gc.freeze()


class CollectorPauses:
    """Durations of the garbage collections [s] while installed (``install``/``remove``),
    by generation; the callback costs about a microsecond a collection."""

    def __init__(self):
        self.pauses: list[tuple[int, float]] = []     # (generation, duration [s])
        self._started = 0.0

    def _on_collection(self, phase: str, info: dict) -> None:
        if phase == 'start':
            self._started = time.perf_counter()
        else:
            self.pauses.append((info['generation'], time.perf_counter() - self._started))

    def install(self) -> None:
        gc.callbacks.append(self._on_collection)

    def remove(self) -> None:
        if self._on_collection in gc.callbacks:
            gc.callbacks.remove(self._on_collection)

    def summary(self) -> dict:
        """{'collections': count, 'full': generation-2 count, 'longest': [s], 'frozen':
        objects frozen out of every collection (``settle``)}."""
        return {'collections': len(self.pauses),
                'full': sum(1 for generation, _ in self.pauses if generation == 2),
                'longest': max((duration for _, duration in self.pauses), default=0.0),
                'frozen': gc.get_freeze_count()}
