"""Type and range checks shared by every configuration dataclass.

NumPy only. Each check raises ``ValueError`` that names the field, what is allowed and the
offending value, e.g. ``ValueError("skin.friction must be a number in [0, 3], got -0.1")``.
Booleans are never accepted as numbers (``True`` is an ``int`` in Python, and
``substeps=True`` must not mean 1), and strings are never accepted as booleans
(``randomize="False"`` is truthy).

Upper bounds are part of each field's contract: they are where the physics stops making sense
or where one call would take unreasonably long (``substeps=1e6``).
"""

from __future__ import annotations

import dataclasses
import math
from numbers import Integral, Real
from typing import Any

import numpy as np

__all__ = [
    "build_config",
    "check_bool",
    "check_choice",
    "check_int",
    "check_number",
    "check_range",
    "check_vector",
]


def _show(value: Any) -> str:
    return repr(value.tolist() if isinstance(value, np.ndarray) else value)


def check_number(
    name: str,
    value: Any,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """A finite real number in [low, high] (ends excluded with ``*_open``), as float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Real):
        raise ValueError(f"{name} must be a number, got {_show(value)}")
    v = float(value)
    below = v <= low if low_open else v < low
    above = v >= high if high_open else v > high
    if not math.isfinite(v) or below or above:
        lo = "(" if low_open else "["
        hi = ")" if high_open else "]"
        raise ValueError(f"{name} must be a finite number in {lo}{low:g}, {high:g}{hi}, got {v!r}")
    return v


def check_int(name: str, value: Any, low: int, high: int) -> int:
    """An integer (not a bool, not a float) in [low, high]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Integral):
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {_show(value)}")
    v = int(value)
    if not low <= v <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {v}")
    return v


def check_bool(name: str, value: Any) -> bool:
    """A real boolean: ``True`` or ``False`` (not a string, not a number)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {_show(value)}")
    return bool(value)


def check_choice(name: str, value: Any, allowed: tuple) -> Any:
    """One of ``allowed``."""
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {_show(value)}")
    return value


def check_range(
    name: str, value: Any, low: float, high: float, *, allow_equal: bool = True
) -> tuple[float, float]:
    """A pair (a, b) of numbers in [low, high] with a <= b (a < b without ``allow_equal``)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ValueError(f"{name} must be a pair (low, high), got {_show(value)}")
    a = check_number(f"{name}[0]", value[0], low, high)
    b = check_number(f"{name}[1]", value[1], low, high)
    if b < a or (b == a and not allow_equal):
        relation = "<=" if allow_equal else "<"
        raise ValueError(f"{name} must satisfy low {relation} high, got {_show(value)}")
    return a, b


def check_vector(
    name: str, value: Any, size: int = 3, *, bound: float = math.inf, nonzero: bool = False
) -> tuple[float, ...]:
    """``size`` finite numbers with absolute values up to ``bound``, as a tuple of floats."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != size:
        raise ValueError(f"{name} must be {size} numbers, got {_show(value)}")
    out = tuple(check_number(f"{name}[{i}]", v, -bound, bound) for i, v in enumerate(value))
    if nonzero and math.hypot(*out) < 1e-12:
        raise ValueError(f"{name} must not be the zero vector, got {_show(value)}")
    return out


class UnknownKeywordError(TypeError, ValueError):
    """An unknown keyword of a constructor, in Python's own wording ("got an unexpected keyword
    argument 'x'"): a ``TypeError``, as a function's own would be, so that tools which drop
    keywords an env does not take (TorchRL's ``GymEnv`` passes ``frameskip``) can tell; and a
    ``ValueError``, as every other configuration error here is."""


def check_keywords(owner: str, given: Any, allowed: list[str]) -> None:
    """Raise :class:`UnknownKeywordError` naming the first unknown keyword of ``given`` (all of
    them, and the allowed ones, follow)."""
    unknown = sorted(set(given) - set(allowed), key=str)
    if unknown:
        raise UnknownKeywordError(
            f"{owner}() got an unexpected keyword argument {unknown[0]!r}"
            f" (unknown: {unknown}; allowed: {allowed})"
        )


def build_config(cls: type, values: Any, name: str):
    """``cls(**values)`` for a dataclass, where ``values`` must be a mapping of its fields.

    Lists become tuples (YAML has no tuples). Unknown fields raise a ``ValueError`` that lists
    the allowed ones.
    """
    if isinstance(values, cls):
        return values
    if not isinstance(values, dict):
        raise ValueError(f"{name} must be a dict of {cls.__name__} fields, got {_show(values)}")
    allowed = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(values) - set(allowed), key=str)
    if unknown:
        raise ValueError(f"unknown {name} field(s) {unknown}; allowed: {allowed}")
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})
