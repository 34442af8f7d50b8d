"""Warp started once per process without its banner, its info log, or what its native library
prints while it starts (on a machine without a GPU: that it found no CUDA driver, a line on
every command otherwise); a device asked for that is not there still fails, naming it."""

import functools
import os
import sys

__all__ = ['quiet_warp']


@functools.cache
def quiet_warp() -> None:
    """Initialise Warp in this process, quietly (see the module); later calls do nothing."""
    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, 'w') as null:
            os.dup2(null.fileno(), 2)
        wp.init()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
