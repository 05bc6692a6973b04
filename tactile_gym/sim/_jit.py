"""How the simulator's kernels are compiled: one decorator for all of them.

Set ``TACTILE_GYM_BOUNDSCHECK=1`` in the environment before importing ``tactile_gym.sim`` to
compile every kernel with numba's index checks: an index out of bounds then raises an
``IndexError`` instead of reading or writing past an array. That build is never cached (numba's
cache would otherwise hand a checked process the unchecked machine code, or the reverse);
``tests/test_sim_kernel_input.py`` runs the kernels so in a subprocess.
"""

from __future__ import annotations

import os

from numba import njit

#: Whether this process compiles the kernels with index checks (read once, at import).
BOUNDSCHECK = os.environ.get("TACTILE_GYM_BOUNDSCHECK", "0") not in ("", "0")


def kernel(**options):
    """``numba.njit`` with the simulator's options: cached machine code, or index checks in
    the debug build (module docstring). ``options`` are numba's (``inline="always"``)."""
    return njit(cache=not BOUNDSCHECK, boundscheck=True if BOUNDSCHECK else None, **options)
