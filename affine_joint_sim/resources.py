"""Where packaged files live: the source tree (editable install) or ``<prefix>/share``."""

import sys
from pathlib import Path

__all__ = ['config_dir', 'scene_path', 'packaged_scenes', 'packaged_file', 'packaged_names']

_SOURCE = Path(__file__).resolve().parents[1] / 'msg_configs'
_SHARE = Path(sys.prefix) / 'share' / 'affine_joint_sim' / 'msg_configs'


def config_dir() -> Path:
    """The msg_configs directory: the source tree's if present, else the installed share."""
    return _SOURCE if _SOURCE.is_dir() else _SHARE


def packaged_file(name_or_path, folder: str, what: str) -> Path:
    """A file: an existing path as given, else the packaged ``<folder>/<name>.yaml``.

    Raises:
        FileNotFoundError: neither exists; the message names the ``what`` and lists the
            packaged ones.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    packaged = config_dir() / folder / f'{name_or_path}.yaml'
    if packaged.is_file():
        return packaged
    raise FileNotFoundError(f'{what} {str(name_or_path)!r} is neither a file nor a packaged '
                            f'{what} ({", ".join(packaged_names(folder)) or "none"})')


def packaged_names(folder: str) -> list[str]:
    """Names of the packaged YAML files in ``folder`` of msg_configs."""
    return sorted(p.stem for p in (config_dir() / folder).glob('*.yaml'))


def scene_path(name_or_path: str) -> Path:
    """A scene file: an existing path as given, else a packaged scene by name (``arm``);
    FileNotFoundError listing the packaged scenes."""
    return packaged_file(name_or_path, 'scenes', 'scene')


def packaged_scenes() -> list[str]:
    """Names of the packaged scenes."""
    return packaged_names('scenes')
