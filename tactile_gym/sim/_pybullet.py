"""PyBullet imported without its start-up line, once for every process.

PyBullet prints "pybullet build time: ..." from C when it is imported, past ``sys.stdout``
and ``sys.stderr``, in every process that imports it: a command's own, and the worker
processes of the vector env (their forkserver preloads the simulator). ``tactile_gym.sim``
imports this module before its other modules, which all import pybullet, so the line never
shows.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator

__all__ = ["quiet_c_output"]


@contextlib.contextmanager
def quiet_c_output(fds: tuple[int, ...] = (1,)) -> Iterator[None]:
    """File descriptors (stdout by default) sent to /dev/null for the block: silences what C
    code prints there.

    Python's own output to those streams inside the block is lost too; keep the block to
    the C calls.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        libc = ctypes.CDLL(None)  # this process's C library (Linux, macOS)
    except (OSError, TypeError):  # Windows has no such handle: C output is not buffered away
        libc = None
    saved = {}
    try:
        for fd in fds:
            with contextlib.suppress(OSError):  # no such stream (a daemon): nothing to hide
                saved[fd] = os.dup(fd)
        with open(os.devnull, "w") as devnull:
            for fd in saved:
                os.dup2(devnull.fileno(), fd)
            try:
                yield
            finally:
                if libc is not None:  # C's buffered lines go to /dev/null, not the restored fd
                    libc.fflush(None)
                for fd, copy in saved.items():
                    os.dup2(copy, fd)
    finally:
        for copy in saved.values():
            os.close(copy)


if "pybullet" not in sys.modules:
    with quiet_c_output((1, 2)):
        import pybullet  # noqa: F401
