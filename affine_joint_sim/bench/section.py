"""The command-line glue that every bench section shares: ``bench <name> [--quick]``.

Not a section itself.
"""

__all__ = ['add_section']


def add_section(sections, name: str, run, full, quick, *, help: str, description: str,
                quick_help: str, extra: tuple = ()):
    """Add the ``bench <name>`` subcommand and return its parser (to add more arguments).

    Its ``bench_func`` creates ``--results`` and calls ``run(results, devices, settings,
    *extra_values)``: ``settings`` is ``quick`` with ``--quick``, else ``full``;
    ``extra_values`` are the parsed arguments named by ``extra``.
    """
    parser = sections.add_parser(name, help=help, description=description)
    parser.add_argument('--quick', action='store_true', help=quick_help)

    def bench(args, devices) -> int:
        args.results.mkdir(parents=True, exist_ok=True)
        run(args.results, devices, quick if args.quick else full,
            *(getattr(args, dest) for dest in extra))
        return 0

    parser.set_defaults(bench_func=bench)
    return parser
