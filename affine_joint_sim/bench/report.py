"""Output of the bench sections: CSV files, markdown tables and log-log plots.

Not a section itself. Matplotlib is imported inside ``loglog_plot`` only.
"""

import csv
from pathlib import Path
from typing import NamedTuple

__all__ = ['Column', 'loglog_plot', 'markdown_row', 'markdown_table', 'publish', 'times',
           'write_csv']


class Column(NamedTuple):
    """A table column: row key, header and format (e.g. ``'{:.1f}'``); None prints ``—``."""

    key: str
    header: str
    fmt: str = '{}'

    def cell(self, row: dict) -> str:
        value = row.get(self.key)
        return '—' if value is None else self.fmt.format(value)


def times(ours: float, theirs: float | None) -> float | None:
    """How many times ``theirs`` ``ours`` is (a cost over a peer's), None without the peer."""
    return None if theirs is None else ours / theirs


def markdown_row(row: dict, columns: list[Column]) -> str:
    """One markdown table line of ``row`` (to print rows as they are measured)."""
    return '| ' + ' | '.join(c.cell(row) for c in columns) + ' |'


def markdown_table(rows: list[dict], columns: list[Column]) -> str:
    """A markdown table of ``rows`` with one column per ``Column``."""
    lines = ['| ' + ' | '.join(c.header for c in columns) + ' |',
             '|' + '---|' * len(columns)]
    lines += [markdown_row(row, columns) for row in rows]
    return '\n'.join(lines)


def write_csv(path: Path, rows: list[dict]) -> None:
    """Write ``rows`` (dicts with the same keys, in order) as CSV with a header line."""
    with open(path, 'w', newline='') as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def publish(results: Path, stem: str, text: str, rows: list[dict], plots: tuple = ()) -> None:
    """Print ``text``, write it to ``<stem>.md`` and ``rows`` to ``<stem>.csv`` in ``results``,
    then say where those files and the already written ``plots`` (file names) are."""
    print(text)
    (results / f'{stem}.md').write_text(text)
    write_csv(results / f'{stem}.csv', rows)
    print('wrote ' + ', '.join(str(results / name) for name in (f'{stem}.md', f'{stem}.csv',
                                                               *plots)))


def loglog_plot(path: Path, series: dict, xlabel: str, ylabel: str, title: str,
                guides: dict | None = None) -> None:
    """Save a log-log PNG: ``series`` (label -> (x, y)) as measured points joined by lines,
    ``guides`` (label -> (x, y)), e.g. fits, as dashed lines."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for label, (x, y) in series.items():
        ax.loglog(x, y, 'o-', label=label)
    for label, (x, y) in (guides or {}).items():
        ax.loglog(x, y, '--', label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which='both', alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
