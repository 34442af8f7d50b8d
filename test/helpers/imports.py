"""What a fresh interpreter imports to do something: light paths must stay light."""

import json
import subprocess
import sys

__all__ = ['modules_loaded_by']


def modules_loaded_by(code: str, timeout: float = 300) -> set[str]:
    """The names in ``sys.modules`` after ``code`` ran in a fresh ``python -c`` (which must
    succeed; its own output is ignored)."""
    done = subprocess.run(
        [sys.executable, '-c', f'{code}\nimport json, sys\nprint(json.dumps(list(sys.modules)))'],
        capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, done.stdout + done.stderr
    return set(json.loads(done.stdout.splitlines()[-1]))
