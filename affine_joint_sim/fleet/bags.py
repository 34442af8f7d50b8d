"""Which bags a command line names: bag directories, single .mcap/.db3 files, and shell-style
globs (quoted, so the shell leaves them) that match either."""

import glob
from pathlib import Path

from affine_joint_sim.ros.bag_metadata import UNLISTED_BAG, unlisted_bag

__all__ = ['expand_bags', 'holds_bags']


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / 'metadata.yaml').is_file()) or (
        path.is_file() and path.suffix in ('.mcap', '.db3'))


def holds_bags(path: Path) -> bool:
    """A directory that is not a bag itself but has bags in it (``bags/``)."""
    return path.is_dir() and not _is_bag(path) and not unlisted_bag(path) and any(
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
        bags, named = [], len(problems)
        for path in matches:
            if _is_bag(path):
                bags.append(path)
            elif unlisted_bag(path):
                problems.append((str(path), UNLISTED_BAG))
            elif path.is_dir():
                inside = sorted(path.iterdir())
                bags += [p for p in inside if _is_bag(p)]
                problems += [(str(p), UNLISTED_BAG) for p in inside if unlisted_bag(p)]
        if not bags and len(problems) == named:     # nothing found, nothing named yet
            problems.append((arg, _why_no_bag(matches)))
        found.update(dict.fromkeys(bags))
    return list(found), problems


def _why_no_bag(matches: list[Path]) -> str:
    if not any(p.exists() for p in matches):
        return 'no such file or directory'
    if all(p.is_dir() and not any(p.iterdir()) for p in matches):
        return 'an empty directory: no bags in it'
    return 'not a bag (no metadata.yaml, .mcap or .db3), and no bags inside'
