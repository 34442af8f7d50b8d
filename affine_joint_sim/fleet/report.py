"""The result of a many-bag replay: a table for people, a JSON or CSV file for tools."""

import csv
import json
import math
from pathlib import Path

__all__ = ['table', 'write_report', 'FIELDS']

FIELDS = ('bag', 'status', 'states', 'max_angle', 'max_velocity', 'worst', 'seconds', 'error')


def _number(value, spec) -> str:
    return '—' if isinstance(value, float) and math.isnan(value) else format(value, spec)


def table(results: list[dict]) -> str:
    """One row per bag: states compared, max |Δθ| [rad], max |Δω| [rad/s], result, seconds."""
    width = max([3] + [len(r['bag']) for r in results])
    lines = [f'{"bag":<{width}}  {"states":>6}  {"max |Δθ| [rad]":>14}  '
             f'{"max |Δω| [rad/s]":>16}  {"result":<6}  {"time [s]":>8}']
    for r in results:
        lines.append(f'{r["bag"]:<{width}}  {r["states"]:>6}  {_number(r["max_angle"], "14.3e")}  '
                     f'{_number(r["max_velocity"], "16.3e")}  {r["status"]:<6}  '
                     f'{r["seconds"]:8.2f}' + (f'  {r["error"]}' if r['error'] else ''))
    return '\n'.join(lines)


def write_report(path: Path, results: list[dict], summary: dict) -> None:
    """``.json``: {summary, bags: [...]}; ``.csv``: one row per bag (FIELDS)."""
    if path.suffix.lower() == '.csv':
        with path.open('w', newline='') as stream:
            writer = csv.DictWriter(stream, fieldnames=FIELDS)
            writer.writeheader()
            writer.writerows({k: r[k] for k in FIELDS} for r in results)
        return
    clean = [{k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
             for r in results]
    path.write_text(json.dumps({'summary': summary, 'bags': clean}, indent=2) + '\n')
