"""The one home of 3-vector arithmetic: cross and dot products and norms without NumPy's
per-call overhead.

The sensing runs on every env step and the estimator on every measurement, and NumPy's
per-call cost dominates on 3-vectors, so the per-reading work is done on Python floats, with
the operations NumPy performs in its order (``docs/design.md`` 5, 7.1). The row-wise cross
product of (N, 3) arrays serves the estimator's residuals. ``cross`` and ``dot`` are also
compiled (``cross_kernel``, ``dot_kernel``) for the sensing's kernels: one source for both.
NumPy and numba only.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym._jit import kernel

__all__ = ["cross", "cross_array", "cross_kernel", "cross_rows", "dot", "dot_kernel", "norm"]


def cross(a, b):
    """a x b."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def cross_array(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two (3,) arrays, as an array (``np.cross`` has a large fixed cost)."""
    return np.array(cross(a.tolist(), b.tolist()))


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (N, 3) arrays (broadcast against each other)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def dot(a, b) -> float:
    """a . b."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


#: ``cross`` and ``dot`` compiled and inlined into the kernels that call them.
cross_kernel = kernel(inline="always")(cross)
dot_kernel = kernel(inline="always")(dot)


def norm(v: np.ndarray) -> float:
    """``np.linalg.norm`` of a 1-D float array, to the bit (it is sqrt(v . v) with NumPy's dot),
    without its per-call overhead."""
    return math.sqrt(v.dot(v))
