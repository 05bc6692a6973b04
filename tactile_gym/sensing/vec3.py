"""Arithmetic on 3-vectors held as tuples of Python floats, and the norm of a small array.

The sensing runs on every env step, and NumPy's per-call overhead dominates on 3-vectors, so
the per-reading work is done on floats (``docs/design.md`` 5). NumPy only.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["cross", "dot", "norm"]


def cross(a, b):
    """a x b."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def dot(a, b) -> float:
    """a . b."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(v: np.ndarray) -> float:
    """``np.linalg.norm`` of a 1-D float array, to the bit (it is sqrt(v . v) with NumPy's dot),
    without its per-call overhead."""
    return math.sqrt(v.dot(v))
