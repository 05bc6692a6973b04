"""Regime map, the analysis: the gate's rules applied to the probes' readings.

The rules are the env's own (``tactile_gym.perception.gate``: ``friction_free``, ``drag_bias``,
``bias_within_budget``, ``link_held`` over a ``GateConfig``), so the map tests the gate it
supports rather than a restatement of it (``docs/design.md`` 4.2, 7.2). Angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from regime_experiment import Readings

from tactile_gym.perception.gate import GateConfig, bias_within_budget, drag_bias, friction_free

#: The env's gate, whose rules the map checks.
GATE = GateConfig()
#: Drag-to-tilt gain of a straight press along an oblique path: each node's tangential offset
#: is its penetration times tan(alpha), so friction tilts the force by alpha k_t/k_n = alpha/3
#: for the Winkler skin and the drag is 2 alpha/3 (``docs/design.md`` 4.2). A sideways move
#: after the press drags harder: the gate's ``drag_gain``.
STRAIGHT_PRESS = 0.5
FIELDS = ("errors", "observables", "drags", "deviations", "tilts", "edge_stds")
GATE_DRAGS = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, math.inf)  # deg
GATE_STD = 1.5  # deg


def pool(readings: list[Readings], kind: str) -> dict[str, np.ndarray]:
    """The ``kind`` ("single", "mean" or "clean": the noise-free reading) readings of many
    probes, concatenated: {field: array} with ``FIELDS`` as names."""
    if kind == "clean":
        names = ("error", "observable", "drag", "deviation", "tilt", "edge_std")
        return {f: np.array([getattr(r, n) for r in readings]) for f, n in zip(FIELDS, names)}
    return {f: np.concatenate([getattr(getattr(r, kind), f) for r in readings]) for f in FIELDS}


def passes(
    p: dict[str, np.ndarray],
    drag: float = math.inf,
    std: float = math.inf,
    budget: float | None = None,
) -> np.ndarray:
    """Readings that pass a gate: edge observable, the gate's friction share, drag at most
    ``drag`` (rad), ``edge_std`` at most ``std`` (rad), and, with ``budget`` (rad), the gate's
    drag rule within that budget."""
    with np.errstate(invalid="ignore"):
        keep = p["observables"].astype(bool) & (p["drags"] <= drag)
        keep &= friction_free(p["deviations"], p["tilts"], GATE) & (p["edge_stds"] <= std)
        if budget is not None:
            bias = drag_bias(p["drags"], p["tilts"], GATE.drag_gain)
            keep &= bias_within_budget(bias, p["edge_stds"], replace(GATE, bias_budget=budget))
    return keep


def p95(x) -> float:
    """The 95th percentile, NaN for fewer than 5 values."""
    return float(np.quantile(x, 0.95)) if len(x) >= 5 else math.nan


def drag_sweep(readings: list[Readings], columns: dict) -> dict[str, dict[float, np.ndarray]]:
    """Which readings pass a gate on the drag at each of ``GATE_DRAGS`` (deg).

    Args:
        readings: the probes.
        columns: {name: (kind, largest edge_std in deg)} with kind as for ``pool``.

    Returns:
        {name: {drag bound in deg: (errors of the pool, pass mask)}}.
    """
    pools = {kind: pool(readings, kind) for kind in ("clean", "single", "mean")}
    out: dict[str, dict] = {name: {} for name in columns}
    for a in GATE_DRAGS:
        for name, (kind, s) in columns.items():
            p = pools[kind]
            out[name][a] = (p["errors"], passes(p, math.radians(a), math.radians(s)))
    return out


def bias_ratios(readings: list[Readings]) -> np.ndarray:
    """Noise-free error over the drag rule's bias, for the probes whose error exceeds 1 deg
    and that pass the friction share."""
    return np.array(
        [
            r.error / float(drag_bias(r.drag, r.tilt, GATE.drag_gain))
            for r in readings
            if r.observable
            and r.error > math.radians(1.0)
            and r.drag > 0
            and friction_free(r.deviation, r.tilt, GATE)
        ]
    )
