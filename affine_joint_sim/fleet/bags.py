"""Which bags a command line names: bag directories, single .mcap/.db3 files, and shell-style
globs (quoted, so the shell leaves them) that match either."""

import glob
import re
from pathlib import Path

__all__ = ['expand_bags', 'holds_bags']

_NO_METADATA = ('split files but no metadata.yaml (a recording killed before it listed its '
                'first split?): not a bag rosbags can read')


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / 'metadata.yaml').is_file()) or (
        path.is_file() and path.suffix in ('.mcap', '.db3'))


def _unlisted(path: Path) -> bool:
    """A directory with split files named as its own (``NAME/NAME_0.mcap``) or the recorder's
    scratch splits (``.split_0/``) but no metadata.yaml: a recording killed before it listed
    its first split, or copied without its metadata (a directory of separate .mcap bags is not
    one)."""
    return path.is_dir() and not (path / 'metadata.yaml').is_file() and any(
        (p.suffix in ('.mcap', '.db3') and re.fullmatch(rf'{re.escape(path.name)}_\d+', p.stem))
        or (p.is_dir() and re.fullmatch(r'\.split_\d+', p.name)) for p in path.iterdir())


def holds_bags(path: Path) -> bool:
    """A directory that is not a bag itself but has bags in it (``bags/``)."""
    return path.is_dir() and not _is_bag(path) and not _unlisted(path) and any(
        _is_bag(p) for p in path.iterdir())


def expand_bags(args: list[str]) -> tuple[list[Path], list[tuple[str, str]]]:
    """(bags in the order given, without repeats; [(argument or path, why it is no bag)]).

    A directory that is not a bag but holds bags (``bags/``) stands for the bags in it; a
    directory in it with split files but no metadata.yaml is named as a problem, not skipped.
    """
    found, problems = {}, []            # a dict: the bags in order, each once
    for arg in args:
        matches = [Path(p) for p in sorted(glob.glob(arg))] if glob.has_magic(arg) else [
            Path(arg)]
        bags = []
        for path in matches:
            if _is_bag(path):
                bags.append(path)
            elif _unlisted(path):
                problems.append((str(path), _NO_METADATA))
            elif path.is_dir():
                inside = sorted(path.iterdir())
                bags += [p for p in inside if _is_bag(p)]
                problems += [(str(p), _NO_METADATA) for p in inside if _unlisted(p)]
        if not bags and not any(_unlisted(m) or (m.is_dir() and any(map(_unlisted, m.iterdir())))
                                for m in matches):
            problems.append((arg, _why_no_bag(matches)))
        found.update(dict.fromkeys(bags))
    return list(found), problems


def _why_no_bag(matches: list[Path]) -> str:
    if not any(p.exists() for p in matches):
        return 'no such file or directory'
    if all(p.is_dir() and not any(p.iterdir()) for p in matches):
        return 'an empty directory: no bags in it'
    return 'not a bag (no metadata.yaml, .mcap or .db3), and no bags inside'
