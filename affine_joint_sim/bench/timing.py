"""Measuring tools of the bench sections: median wall time, and Warp launches and syncs counted.

Not a section itself. Warp is imported inside functions, so importing this module stays cheap.
"""

import statistics
import time

__all__ = ['WarpCalls', 'interleaved_us', 'measure_steps', 'median_us']


def median_us(run, calls: int, repeats: int, setup=None) -> float:
    """Median over ``repeats`` of the wall time per call of ``calls`` calls of ``run()`` [µs].

    ``setup()``, when given, runs untimed before every repeat (e.g. a reset, so that every
    repeat times the same work and the median only filters machine noise).
    """
    samples = []
    for _ in range(repeats):
        if setup is not None:
            setup()
        start = time.perf_counter()
        for _ in range(calls):
            run()
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


def interleaved_us(contestants: dict, calls: int, repeats: int) -> dict:
    """Wall time per call [µs] of each contestant, ``repeats`` samples each, the contestants
    timed in turn within every repeat (a burst of machine noise then falls on neighbouring
    samples of all of them, and a ratio of samples from one repeat cancels it).

    ``contestants`` maps a name to ``(setup, run)``: ``setup()`` runs untimed before each
    sample, then ``calls`` calls of ``run()`` are timed. Returns {name: [µs per call, ...]}.
    """
    samples = {name: [] for name in contestants}
    for _ in range(repeats):
        for name, (setup, run) in contestants.items():
            setup()
            start = time.perf_counter()
            for _ in range(calls):
                run()
            samples[name].append((time.perf_counter() - start) / calls * 1e6)
    return samples


def measure_steps(sim, commands: dict, steps: int, repeats: int) -> dict:
    """Time ``steps`` steps of Stepper ``sim`` from its initial state under ``commands``.

    ``commands`` maps joint names to torques [N·m] (scalars, or arrays of shape (num_envs,)),
    set after every reset. ``repeats`` runs are timed, as many again count Warp calls, and a
    last one reads the statistics (apart: reading them every step slows the kernel down by
    evicting its data from the caches). Returns ``us_per_step`` (median of the timed runs
    [µs]), ``launches_per_step`` and ``syncs_per_step``, ``launch_us`` and ``sync_us`` (wall
    time per step inside those calls [µs]) and ``other_us`` (the rest of the step: Python, and
    the counting itself), all medians of the counted runs, and ``newton_iterations``
    (mean per step and environment).
    """
    import numpy as np

    def start():
        sim.reset()
        for name, torque in commands.items():
            sim.set_torque(name, torque)

    us_per_step = median_us(sim.step, steps, repeats, setup=start)
    counted, other = [], []
    for _ in range(repeats):
        start()
        with WarpCalls() as calls:
            begin = time.perf_counter()
            for _ in range(steps):
                sim.step()
            elapsed = time.perf_counter() - begin
        counted.append(calls)
        other.append(elapsed - calls.seconds['launches'] - calls.seconds['syncs'])
    start()
    iterations = 0.0
    for _ in range(steps):
        sim.step()
        iterations += float(np.mean(sim.stats['newton_iterations']))
    return {'us_per_step': us_per_step,
            'launches_per_step': counted[0].counts['launches'] / steps,
            'syncs_per_step': counted[0].counts['syncs'] / steps,
            'launch_us': statistics.median(c.seconds['launches'] for c in counted) / steps * 1e6,
            'sync_us': statistics.median(c.seconds['syncs'] for c in counted) / steps * 1e6,
            'other_us': statistics.median(other) / steps * 1e6,
            'newton_iterations': iterations / steps}


class WarpCalls:
    """Counts and times, while active, the Warp calls that launch work or wait for a device.

    ``launches``: ``wp.launch``, a recorded ``wp.Launch.launch`` and ``wp.capture_launch`` (a
    graph replay counts once, whatever it holds). ``syncs``: ``wp.synchronize*`` and
    ``wp.array.numpy`` of an array that is not on the CPU (an implicit device-to-host wait).
    Only the outermost of nested calls counts. ``counts`` and ``seconds`` map those two kinds
    to the number of calls and the wall time spent inside them [s].

    Calls made through Warp's own internals, or through a function reference taken before the
    context was entered, are not seen.
    """

    def __init__(self):
        self.counts = {'launches': 0, 'syncs': 0}
        self.seconds = {'launches': 0.0, 'syncs': 0.0}
        self._depth = 0
        self._originals = []

    def __enter__(self):
        import warp as wp

        for owner, name, kind in (
                (wp, 'launch', 'launches'), (wp.Launch, 'launch', 'launches'),
                (wp, 'capture_launch', 'launches'), (wp, 'synchronize', 'syncs'),
                (wp, 'synchronize_device', 'syncs'), (wp, 'synchronize_stream', 'syncs'),
                (wp, 'synchronize_event', 'syncs'), (wp.array, 'numpy', 'syncs')):
            original = getattr(owner, name)
            self._originals.append((owner, name, original))
            setattr(owner, name, self._wrap(original, kind, name == 'numpy'))
        return self

    def __exit__(self, *exc):
        for owner, name, original in reversed(self._originals):
            setattr(owner, name, original)
        self._originals = []

    def _wrap(self, original, kind, device_arrays_only):
        def counted(*args, **kwargs):
            if self._depth or (device_arrays_only and args[0].device.is_cpu):
                return original(*args, **kwargs)
            self._depth += 1
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds[kind] += time.perf_counter() - start
                self.counts[kind] += 1
                self._depth -= 1
        return counted
