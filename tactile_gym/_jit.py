"""How the package's kernels are compiled: one decorator for all of them, the simulator's and
the sensing's and gate's per-reading cores alike.

It imports numba alone (no pybullet, no gymnasium), so ``tactile_gym.sensing`` and
``tactile_gym.perception`` stay importable on a robot. numba compiles without ``fastmath``:
LLVM then neither contracts a * b + c into a fused multiply-add nor reorders a sum, so a
kernel's arithmetic rounds as the same Python or NumPy expression does, operation by operation.

Set ``TACTILE_GYM_BOUNDSCHECK=1`` in the environment before importing ``tactile_gym`` to
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
    """``numba.njit`` with the package's options: cached machine code, or index checks in
    the debug build (module docstring). ``options`` are numba's (``inline="always"``)."""
    return njit(cache=not BOUNDSCHECK, boundscheck=True if BOUNDSCHECK else None, **options)
