"""Host views of a Stepper's device arrays: commands uploaded when changed, outputs downloaded
when read (docs/architecture.md#host-mirrors).

On the CPU a host view is the device array itself and nothing moves. On a GPU every array has
a pinned host mirror: ``Uploads`` copies the command mirrors to the device before a step only
after a setter wrote them; ``Downloads`` copies a group of outputs to the host the first time
one of them is read after a step (one captured graph of copies and one wait per group), so a
step moves bytes in proportion to what the user writes and reads, not to the state size.
"""

import warp as wp

__all__ = ['Uploads', 'Downloads', 'host_copy']


def host_copy(array, separate: bool):
    """``array`` itself, or (``separate``) a host copy of it, pinned for a GPU. The copy has
    landed when this returns (a setter may write it at once)."""
    if not separate:
        return array
    device = wp.get_device(array.device)
    copy = wp.clone(array, device='cpu', pinned=device.is_cuda)
    wp.synchronize_device(device)
    return copy


class Uploads:
    """Host views of the command arrays ``arrays`` (name → device array).

    ``views[name]`` is the NumPy array a setter writes; it must then call ``written()``, and
    the step asks ``take()`` whether to upload. ``separate`` is False on the CPU (the views are
    the device arrays: nothing to upload)."""

    def __init__(self, arrays: dict, separate: bool):
        self._pairs = {name: (array, host_copy(array, separate))
                       for name, array in arrays.items()}
        self.views = {name: host.numpy() for name, (_, host) in self._pairs.items()}
        self.separate = separate
        self.pending = False
        self.writes = 0             # calls of written(): readers cache what they derive

    def written(self) -> None:
        """A view was written: the next step uploads the commands (when they are separate)."""
        self.pending = self.separate
        self.writes += 1

    def take(self) -> bool:
        """Whether this step must upload the commands (then they count as uploaded)."""
        pending, self.pending = self.pending, False
        return pending

    def record(self) -> None:
        """Issue the host → device copies (inside a graph capture)."""
        for device_array, host_array in self._pairs.values():
            wp.copy(device_array, host_array)


class Downloads:
    """Host views of output arrays in named groups (group → {name → device array}).

    ``read(name)`` returns the NumPy view of ``name``; after ``stale()`` (every step, every
    reset) the first read of each group copies that group to the host and waits for it.
    ``separate`` is False on the CPU (the views are the device arrays, always current).
    ``copies`` counts the group downloads (bytes moved: ``bytes_moved``)."""

    def __init__(self, device, groups: dict, separate: bool):
        self._device = wp.get_device(device)
        self._group_of, self._views, self._graphs, self._sizes = {}, {}, {}, {}
        for group, arrays in groups.items():
            pairs = [(array, host_copy(array, separate)) for array in arrays.values()]
            for name, (_, host) in zip(arrays, pairs):
                self._group_of[name] = group
                self._views[name] = host.numpy()
            self._sizes[group] = sum(array.capacity for array, _ in pairs)
            if separate:
                self._graphs[group] = self._capture(pairs)
        self._fresh = set(groups)
        self.copies = 0
        self.bytes_moved = 0

    def _capture(self, pairs):
        with wp.ScopedCapture(device=self._device) as capture:
            for device_array, host_array in pairs:
                wp.copy(host_array, device_array)
        return capture.graph

    def stale(self) -> None:
        """The device arrays changed: the next read of each group downloads it."""
        if self._graphs:
            self._fresh = set()

    def read(self, name: str):
        """The current host view of output ``name`` (valid until the next step)."""
        group = self._group_of[name]
        if group not in self._fresh:
            wp.capture_launch(self._graphs[group])
            wp.synchronize_device(self._device)
            self._fresh.add(group)
            self.copies += 1
            self.bytes_moved += self._sizes[group]
        return self._views[name]
