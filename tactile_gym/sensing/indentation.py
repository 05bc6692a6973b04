"""Skin indentation: how deep a Winkler skin sinks under a load, and the corrected contact point.

The Bicchi point lies on the undeformed skin; the object touches it deeper, by the
indentation (``docs/design.md`` 4.5). Near an edge a press indents like a plane, which is why
``"plane"`` is the default shape.

Conventions (``docs/design.md`` 2): SI units; stiffness as a Winkler modulus, N/m^3; vectors in
the sensor frame, as tuples of floats on the per-reading path, whose functions are compiled
(``tactile_gym._jit``, rounding as Python floats do). NumPy and numba only.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.vec3 import dot_kernel as dot

__all__ = ["CONTACT_SHAPES", "indentation_correction", "indentation_depth"]

CONTACT_SHAPES = ("edge", "plane")


def indentation_depth(
    normal_force, skin_stiffness: float, radius: float, contact_shape: str = "plane"
):
    """Indentation depth of a Winkler (elastic-foundation) skin of the given curvature.

    The skin is a bed of independent springs: pressure = ``skin_stiffness`` x local
    penetration. Near the contact the skin is the paraboloid z = (x^2 + y^2) / (2 R).

    * ``"plane"``: a rigid plane pushed delta into it,
      F = k_n integral (delta - rho^2/(2R))_+ dA = k_n pi R delta^2.
    * ``"edge"``: a rigid 90-degree wedge whose ridge line (along y) is tangent to the skin,
      pressed symmetrically; its faces have slope 1, so the penetration is
      (delta - |x| - y^2/(2R))_+ (the x^2/(2R) term is dropped since |x| <= delta << R).
      Integrating over x gives (delta - y^2/(2R))^2, then over y,
      F = k_n (16/15) sqrt(2R) delta^(5/2).

    Args:
        normal_force: normal load on the skin, N; float or array, >= 0.
        skin_stiffness: Winkler modulus k_n, N/m^3; > 0 (e.g. E/h = 8.8e7).
        radius: radius of curvature of the skin, m; > 0.
        contact_shape: one of ``CONTACT_SHAPES``.

    Returns:
        delta, m: a float for a scalar ``normal_force``, else an array of its shape.
    """
    if contact_shape not in CONTACT_SHAPES:
        raise ValueError(f"contact_shape must be one of {CONTACT_SHAPES}, got {contact_shape!r}")
    k = float(skin_stiffness)
    if not math.isfinite(k) or k <= 0.0:
        raise ValueError(f"skin_stiffness must be a finite number > 0 N/m^3, got {k!r}")
    rad = float(radius)
    if not math.isfinite(rad) or rad <= 0.0:
        raise ValueError(f"radius must be a finite number > 0 m, got {rad!r}")
    load = np.asarray(normal_force, dtype=float)
    if not np.all(np.isfinite(load)) or np.any(load < 0.0):
        raise ValueError(f"normal_force must be finite and >= 0 N, got {normal_force!r}")
    if load.ndim == 0:
        return _depth(float(load), k, rad, contact_shape == "edge")
    if contact_shape == "plane":
        return np.sqrt(load / (k * math.pi * rad))
    return (load / (k * (16.0 / 15.0) * math.sqrt(2.0 * rad))) ** 0.4


@kernel()
def _depth(load: float, k: float, rad: float, edge: bool) -> float:
    """``indentation_depth`` for checked scalar input, on floats (the per-call fast path);
    ``edge``: the ``"edge"`` shape, else ``"plane"``."""
    if not edge:
        return math.sqrt(load / (k * math.pi * rad))
    return (load / (k * (16.0 / 15.0) * math.sqrt(2.0 * rad))) ** 0.4


@kernel()
def indentation_correction(f, r, n, k_n, radius, thickness, edge):
    """Indentation depth and the contact point moved in by it (docs/design.md 4.5).

    Args:
        f: (3,) force, N; r: (3,) contact point, m; n: (3,) outward unit normal. Sensor frame.
        k_n: Winkler modulus, N/m^3; > 0.
        radius: outer skin radius, m; thickness: skin thickness, m (``FingertipGeometry``).
        edge: the ``"edge"`` contact shape, else ``"plane"`` (``CONTACT_SHAPES``).

    Returns:
        (r - delta n, delta): the corrected point (3,), m, and delta, m, the depth of
        ``indentation_depth`` for the normal load -f . n capped at the skin thickness (the
        shell is rigid).
    """
    load = -dot(f, n)
    load = 0.0 if 0.0 > load else load  # max(load, 0.0), as Python takes it
    delta = _depth(load, k_n, radius, edge)
    delta = thickness if thickness < delta else delta
    return (r[0] - delta * n[0], r[1] - delta * n[1], r[2] - delta * n[2]), delta
