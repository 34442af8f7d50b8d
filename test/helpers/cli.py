"""The command line as a user runs it: ``python -m affine_joint_sim.cli ARGS`` in a child
process, output captured."""

import subprocess
import sys

__all__ = ['cli']


def cli(*args, timeout: float = 300):
    """Run ``affine-joint-sim ARGS``; the CompletedProcess (text stdout and stderr)."""
    return subprocess.run([sys.executable, '-m', 'affine_joint_sim.cli', *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)
