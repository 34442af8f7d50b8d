"""Which bags a command line names: bag directories, single .mcap/.db3 files, and shell-style
globs (quoted, so the shell leaves them) that match either."""

import glob
from pathlib import Path

__all__ = ['expand_bags', 'holds_bags']


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / 'metadata.yaml').is_file()) or (
        path.is_file() and path.suffix in ('.mcap', '.db3'))


def holds_bags(path: Path) -> bool:
    """A directory that is not a bag itself but has bags in it (``bags/``)."""
    return path.is_dir() and not _is_bag(path) and any(_is_bag(p) for p in path.iterdir())


def expand_bags(args: list[str]) -> tuple[list[Path], list[tuple[str, str]]]:
    """(bags in the order given, without repeats; [(argument, why it names no bag)]).

    A directory that is not a bag but holds bags (``bags/``) stands for the bags in it.
    """
    found, problems = [], []
    for arg in args:
        matches = [Path(p) for p in sorted(glob.glob(arg))] if glob.has_magic(arg) else [
            Path(arg)]
        bags = []
        for path in matches:
            if _is_bag(path):
                bags.append(path)
            elif path.is_dir():
                bags += [p for p in sorted(path.iterdir()) if _is_bag(p)]
        if not bags:
            problems.append((arg, 'no such file or directory' if not matches or not any(
                p.exists() for p in matches) else 'not a bag (no metadata.yaml, .mcap or '
                '.db3), and no bags inside'))
        found += [b for b in bags if b not in found]
    return found, problems
