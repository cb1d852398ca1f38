"""Keeps C libraries' own prints off a run's console: pybullet's build time on import, its EGL
plugin's driver lines on loading, "Destroy EGL OpenGL window" on disconnect."""
import contextlib
import ctypes
import os
import sys

_libc = ctypes.CDLL(None)


@contextlib.contextmanager
def quiet_c_output():
    """Send what C code writes to stdout and stderr to /dev/null for the duration (a Python
    exception still propagates, after both are back). When stdout is a pipe (roslaunch's
    screen output) C's stdio buffers it, so the buffers are flushed inside the block: flushed
    after it, the text would reach the console anyway."""
    sys.stdout.flush()
    sys.stderr.flush()
    _libc.fflush(None)
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        _libc.fflush(None)
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved + [devnull]:
            os.close(fd)
