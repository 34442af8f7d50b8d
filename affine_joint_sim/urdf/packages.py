"""Where a URDF's ``package://`` and relative file URIs point on this machine.

Search order for ``package://NAME/rest`` (ROS 1 and ROS 2 conventions, then the URDF's own
place): the scene's ``package_paths`` {NAME: dir}; every ``ROS_PACKAGE_PATH`` entry (the entry
itself when it is the package, else ``entry/NAME`` or ``entry/*/NAME``); every
``AMENT_PREFIX_PATH`` prefix as ``prefix/share/NAME``; finally the directories above the URDF,
the nearest one named NAME (a description package checked out anywhere).
"""

import os
from pathlib import Path
from urllib.parse import unquote

__all__ = ['resolve_uri', 'package_roots']


def package_roots(package: str, package_paths: dict, urdf_dir: Path):
    """Candidate directories of ``package``, in search order (not checked for existence)."""
    if package in package_paths:
        yield Path(package_paths[package]).expanduser()
    for entry in filter(None, os.environ.get('ROS_PACKAGE_PATH', '').split(os.pathsep)):
        entry = Path(entry).expanduser()
        if entry.name == package:
            yield entry
        yield entry / package
        if entry.is_dir():
            yield from (child / package for child in sorted(entry.iterdir()) if child.is_dir())
    for prefix in filter(None, os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)):
        yield Path(prefix) / 'share' / package
    here = urdf_dir.resolve()
    yield from (folder for folder in (here, *here.parents) if folder.name == package)


def resolve_uri(uri: str, package_paths: dict, urdf_dir: Path) -> Path | None:
    """The existing file a URDF ``filename`` names, or None when it cannot be found.

    ``package://NAME/rest`` is searched as the module docstring says; ``file://`` URIs are
    absolute; anything else is a path relative to the URDF's directory.
    """
    if uri.startswith('package://'):
        package, _, rest = uri[len('package://'):].partition('/')
        for root in package_roots(package, package_paths, urdf_dir):
            if (root / rest).is_file():
                return root / rest
        return None
    path = Path(unquote(uri[len('file://'):])) if uri.startswith('file://') else urdf_dir / uri
    return path if path.is_file() else None
