"""The warning categories of the simulator (no dependencies: the URDF import, the model build
and the stepper all raise them) and the per-robot summary of a load's warnings.

Filter them with ``warnings.simplefilter(action, SimulationWarning)``. A load says what it
simulates differently from what a file asks in one ``SimulationWarning`` per robot and phase
(``summarised``): each kind counted, with its worst item. Every item behind the summary is a
``SimulationDetail``, hidden unless asked for (README.md#robots-from-urdf):
``warnings.simplefilter('default', SimulationDetail)`` in Python, ``affine-joint-sim run
--verbose`` on the command line.
"""

import warnings
from contextlib import contextmanager

__all__ = ['SimulationWarning', 'SimulationDetail', 'DETAILS_HINT', 'summarised']

DETAILS_HINT = 'each one: run --verbose, or show SimulationDetail warnings'


class SimulationWarning(UserWarning):
    """A scene or a step the simulator can run but whose result the user should know about.

    One item of a load that ``summarised`` sums up carries ``kind``, what the summary counts it
    as (``"collision meshes simplified for contact"``), and optionally ``size``, how bad it is
    (larger is worse, in the unit of its kind) with ``worst``, how the summary names the worst
    one (``"forearm.stl within 0.99 mm"``), and ``item``, what it is about: warnings of one kind
    about the same item count once (two reductions of one mesh). Without a kind it is a
    warning of its own.
    """

    def __init__(self, message: str = '', kind: str = '', size: float = 0.0, worst: str = '',
                 item: str = ''):
        super().__init__(message)
        self.kind, self.size, self.worst, self.item = kind, size, worst, item


class SimulationDetail(UserWarning):
    """One item behind a summary ``SimulationWarning``: its full text. Ignored unless a filter
    shows it (appended last, so any filter of the user's wins)."""


warnings.filterwarnings('ignore', category=SimulationDetail, append=True)


@contextmanager
def summarised(subject: str):
    """Hold the SimulationWarnings with a ``kind`` raised inside; on leaving (on an error
    too), raise each again as a SimulationDetail, then one SimulationWarning
    ``"<subject>: <kind>: <count> (worst: <worst>); ..."``. Every other warning passes through
    as it was raised."""
    caught = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter('always')
            yield
    finally:
        _release(subject, caught)


def _release(subject: str, caught: list) -> None:
    held = []
    for record in caught:
        if isinstance(record.message, SimulationWarning) and record.message.kind:
            held.append(record.message)
        else:
            warnings.warn_explicit(record.message, record.category, record.filename,
                                   record.lineno, source=record.source)
    for item in held:
        warnings.warn(SimulationDetail(str(item)), stacklevel=4)
    if held:
        warnings.warn(SimulationWarning(_summary(subject, held)), stacklevel=4)


def _summary(subject: str, items: list[SimulationWarning]) -> str:
    """One line: ``subject``, then each kind in order of first appearance with its count of
    items and its worst (the largest ``size`` among those with a ``worst``)."""
    kinds = {}
    for item in items:
        kinds.setdefault(item.kind, []).append(item)
    parts = []
    for kind, of_kind in kinds.items():
        count = len({item.item or id(item) for item in of_kind})
        ranked = [item for item in of_kind if item.worst]
        worst = f' (worst: {max(ranked, key=lambda i: i.size).worst})' if ranked else ''
        parts.append(f'{kind}: {count}{worst}')
    return f'{subject}: {"; ".join(parts)} ({DETAILS_HINT})'
