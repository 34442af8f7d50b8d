"""Where packaged files live: the source tree (editable install) or ``<prefix>/share``."""

import sys
from pathlib import Path

__all__ = ['config_dir', 'scene_path', 'packaged_scenes']

_SOURCE = Path(__file__).resolve().parents[1] / 'msg_configs'
_SHARE = Path(sys.prefix) / 'share' / 'affine_joint_sim' / 'msg_configs'


def config_dir() -> Path:
    """The msg_configs directory: the source tree's if present, else the installed share."""
    return _SOURCE if _SOURCE.is_dir() else _SHARE


def scene_path(name_or_path: str) -> Path:
    """A scene file: an existing path as given, else a packaged scene by name (``arm``).

    Raises:
        FileNotFoundError: neither exists; the message lists the packaged scenes.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    packaged = config_dir() / 'scenes' / f'{name_or_path}.yaml'
    if packaged.is_file():
        return packaged
    raise FileNotFoundError(f'scene {name_or_path!r} is neither a file nor a packaged scene '
                            f'({", ".join(packaged_scenes())})')


def packaged_scenes() -> list[str]:
    """Names of the packaged scenes."""
    return sorted(p.stem for p in (config_dir() / 'scenes').glob('*.yaml'))
