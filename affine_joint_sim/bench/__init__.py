"""``affine-joint-sim bench`` (``make bench``): speed and accuracy measurements.

Wall-clock figures belong here, never in tests. Each section is a module of this package with
``add_parser(subparsers)`` (its own ``bench <section>`` subcommand, setting
``bench_func(args, devices) -> int``; see ``section.add_section``), and
``run(results: Path, devices: list[str], settings)`` with its full settings ``FULL``, which
``bench`` with no section runs. Section modules import Warp only inside functions, so
``--help`` stays fast.
"""

import argparse
import importlib
from pathlib import Path

__all__ = ['SECTIONS', 'add_arguments', 'main']

SECTIONS = ('perf', 'scaling', 'batch', 'sweep', 'ros_loop', 'record', 'robots', 'contact',
            'impacts', 'bodies', 'stages', 'reads')


def _section(name: str):
    return importlib.import_module(f'{__name__}.{name}')


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the common options and one subcommand per section to the ``bench`` parser."""
    parser.add_argument('--results', type=Path, default=Path('results/bench'),
                        help='directory for CSV, markdown and PNG output (default: %(default)s)')
    parser.add_argument('--device', dest='devices', action='append', default=None,
                        help='Warp device (repeatable; default: cpu, plus cuda when present)')
    sections = parser.add_subparsers(dest='section', metavar='SECTION')
    for name in SECTIONS:
        _section(name).add_parser(sections)


def default_devices() -> list[str]:
    """``cpu``, plus ``cuda`` where Warp sees a CUDA device."""
    import warp as wp

    return ['cpu'] + (['cuda'] if wp.is_cuda_available() else [])


def main(args) -> int:
    """Run one section (``bench SECTION``) or every section's default run."""
    devices = args.devices or default_devices()
    if args.section is not None:
        return args.bench_func(args, devices)
    args.results.mkdir(parents=True, exist_ok=True)
    for name in SECTIONS:
        section = _section(name)
        section.run(args.results, devices, section.FULL)
    print(f'bench results in {args.results.resolve()}')
    return 0
