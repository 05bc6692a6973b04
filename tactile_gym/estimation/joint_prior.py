"""The priors of the joint-type models: what is known before touching (docs/design.md 6.10).

World frame, metres, radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation.prior import AxisPrior

__all__ = ["EZ", "JointTypePrior"]

#: The world's up direction, the planar modes' joint axis.
EZ = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class JointTypePrior:
    """What is known before touching: the priors of the joint-type models (docs/design.md 6.10).

    Attributes:
        type_probabilities: prior probabilities of rigid, revolute and prismatic (> 0; they
            are normalised with ``none_probability``).
        none_probability: prior probability that no model holds (every measurement its own
            line: inconsistent data), in (0, 1).
        axis: Gaussian prior of a revolute axis, e.g. the reset distribution's
            (:meth:`AxisPrior.from_samples`); None: a broad one centred on the first contact
            (pin std ``workspace / sqrt(2 pi)`` per axis; ``"3d"``: direction z with an RMS
            angle of sqrt(2) rad, the tangent-plane Gaussian whose peak is the uniform
            density on the hemisphere).
        workspace: side of the region the edge lines lie in, m: an edge line's position has a
            uniform prior over ``workspace^2`` normal to it.
        turn_range: range of a revolute joint's angle, rad: a configuration's turn has a
            uniform prior of density ``1 / turn_range``.
        travel_range: range of a prismatic joint's travel, m: likewise for its shift.
        stuck_probability: chance that a change of configuration left the link where it
            was (held by its friction, or not pushed), in [0, 1), each independently: a
            jointed link that never moved over k changes (probability ``stuck^k``) looks
            rigid; otherwise its motions are uniform over their range.
        along_edge_probability: chance that a prismatic joint slides along one of the
            measured edge lines (drawers slide along their sides), in [0, 1); otherwise its
            direction is uniform (hemisphere; ``"planar"``: half circle).

    Raises:
        ValueError: on a value out of its range.
    """

    type_probabilities: tuple[float, float, float] = (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    none_probability: float = 0.01
    axis: AxisPrior | None = None
    workspace: float = 1.0
    turn_range: float = math.pi
    travel_range: float = 0.2
    stuck_probability: float = 0.5
    along_edge_probability: float = 0.5

    def __post_init__(self) -> None:
        probs = tuple(float(p) for p in self.type_probabilities)
        if len(probs) != 3 or not all(math.isfinite(p) and p > 0 for p in probs):
            raise ValueError(
                "type_probabilities must be three finite numbers > 0 (rigid, revolute, "
                f"prismatic), got {self.type_probabilities!r}"
            )
        object.__setattr__(self, "type_probabilities", probs)
        _check_range("none_probability", self.none_probability, 0.0, 1.0, open_low=True)
        for name in ("workspace", "turn_range", "travel_range"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                unit = "rad" if name == "turn_range" else "m"
                raise ValueError(f"{name} must be a finite number > 0 {unit}, got {value!r}")
        _check_range("stuck_probability", self.stuck_probability, 0.0, 1.0)
        _check_range("along_edge_probability", self.along_edge_probability, 0.0, 1.0)
        if self.axis is not None and not isinstance(self.axis, AxisPrior):
            raise ValueError(f"axis must be an AxisPrior or None, got {type(self.axis).__name__}")

    @property
    def log_outcome_priors(self) -> np.ndarray:
        """(4,) log prior probabilities of rigid, revolute, prismatic and none."""
        p = np.array(self.type_probabilities)
        p = p / p.sum() * (1.0 - self.none_probability)
        return np.log(np.append(p, self.none_probability))

    def axis_prior(self, mode: str, first_point: np.ndarray) -> AxisPrior:
        """The revolute axis prior: ``axis``, or the broad default about ``first_point``."""
        if self.axis is not None:
            return self.axis
        var = self.workspace**2 / (2.0 * math.pi)
        if mode == "planar":
            return AxisPrior(first_point, np.diag([var, var, 0.0]), EZ, 0.0)
        return AxisPrior(first_point, var * np.eye(3), EZ, math.sqrt(2.0))


def _check_range(name: str, value: float, low: float, high: float, open_low=False) -> None:
    v = float(value)
    ok = (v > low if open_low else v >= low) and v < high
    if not (math.isfinite(v) and ok):
        bracket = "(" if open_low else "["
        raise ValueError(f"{name} must be in {bracket}{low}, {high}), got {value!r}")
