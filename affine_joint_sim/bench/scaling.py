"""``bench scaling``: µs per step against the number of joints, on chains of 1 … 256 links.

The block-tree Cholesky makes a Newton iteration O(joints); the fitted exponents (least
squares in log-log) of µs/step and of µs per Newton iteration against links check it. Below
``LONG`` links a fixed per-step cost (Python around the launch) dominates, so the exponents are
also fitted on the long chains alone. Chains are released ``perf.CHAIN_ANGLE`` from vertical; short
ones then take more Newton iterations per step than long ones, hence the second exponent.
"""

from pathlib import Path
from typing import NamedTuple

from affine_joint_sim.bench.report import Column, loglog_plot, markdown_table, publish
from affine_joint_sim.bench.section import add_section

__all__ = ['LINKS', 'add_parser', 'loglog_exponent', 'measure', 'run']

LINKS = tuple(2 ** k for k in range(9))   # 1 … 256
LONG = 16                                  # chains from this many links fit the tail exponent


class Settings(NamedTuple):
    links: tuple    # chain lengths
    steps: int      # steps per run
    repeats: int    # timed runs (median reported)


FULL, QUICK = Settings(LINKS, 200, 5), Settings(LINKS[:7], 30, 3)


def loglog_exponent(x, y) -> float:
    """Slope p of the least-squares fit log y = p log x + c (y ∝ x^p)."""
    import numpy as np

    return float(np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)[0])


def measure(links: int, device: str, settings: Settings) -> dict:
    """One row: µs/step, Newton iterations, µs per iteration and per link of a ``links`` chain."""
    from affine_joint_sim.bench.perf import case
    from affine_joint_sim.bench.timing import measure_steps
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(case(f'chain{links}').scene(), device=device)
    timing = measure_steps(sim, {}, settings.steps, settings.repeats)
    return {'links': links, 'device': str(sim.device), 'us_per_step': timing['us_per_step'],
            'newton_iterations': timing['newton_iterations'],
            'us_per_iteration': timing['us_per_step'] / timing['newton_iterations'],
            'us_per_link': timing['us_per_step'] / links}


COLUMNS = [Column('links', 'links (= joints)'), Column('device', 'device'),
           Column('us_per_step', 'µs/step', '{:.1f}'),
           Column('newton_iterations', 'Newton it./step', '{:.2f}'),
           Column('us_per_iteration', 'µs/Newton it.', '{:.1f}'),
           Column('us_per_link', 'µs/(step·link)', '{:.2f}')]


def fitted_exponents(rows: list[dict], key: str) -> str:
    """``key`` ∝ links^p fitted over all ``rows`` and over those with at least LONG links."""
    x = [row['links'] for row in rows]
    y = [row[key] for row in rows]
    text = f'{loglog_exponent(x, y):.2f} over {x[0]}–{x[-1]} links'
    long = [(a, b) for a, b in zip(x, y) if a >= LONG]
    if len(long) >= 2:
        text += f', {loglog_exponent(*zip(*long)):.2f} over {long[0][0]}–{long[-1][0]}'
    return text


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Measure every chain length on every device; write scaling.md, .csv and .png."""
    rows = [measure(links, device, settings) for device in devices for links in settings.links]
    series, guides, fits = {}, {}, []
    for device in dict.fromkeys(row['device'] for row in rows):
        mine = [row for row in rows if row['device'] == device]
        x = [row['links'] for row in mine]
        series[device] = (x, [row['us_per_step'] for row in mine])
        last = mine[-1]
        guides[f'{device}: ∝ links'] = (x, [last['us_per_step'] * a / last['links'] for a in x])
        fits.append(f'- {device}: µs/step {fitted_exponents(mine, "us_per_step")}; '
                    f'µs/Newton it. {fitted_exponents(mine, "us_per_iteration")}')
    text = (f'## Cost against chain length (median of {settings.repeats} runs of '
            f'{settings.steps} steps)\n\n{markdown_table(rows, COLUMNS)}\n\n'
            'Fitted log-log exponents against links (1 = linear):\n' + '\n'.join(fits) + '\n')
    loglog_plot(results / 'scaling.png', series, 'links (= joints)', 'µs per step',
                'Step cost against chain length', guides)
    publish(results, 'scaling', text, rows, ('scaling.png',))


def add_parser(sections) -> None:
    add_section(sections, 'scaling', run, FULL, QUICK,
                help='µs/step of chains of 1 … 256 links, log-log exponent and plot',
                description='Time chains of 1, 2, 4, … 256 links and write scaling.md, '
                            'scaling.csv and scaling.png into --results.',
                quick_help=f'up to {QUICK.links[-1]} links, {QUICK.steps} steps x '
                           f'{QUICK.repeats} runs')
