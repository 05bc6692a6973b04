"""The measurement gate: which contact estimates reach the joint-axis estimator.

Everything here is in the world frame, in metres, newtons and radians. The gate sees the
contact estimate of each control step and accepts it as a measurement only when it carries
information about the axis. There are two sources of edge directions:

* ``"wrench"``: the edge direction from the wrench (DESIGN.md 2.1), accepted when

  1. the contact estimate is valid;
  2. the force magnitude lies in ``force_band`` (around the paper's 5 N press);
  3. the predicted edge std is at most ``max_edge_std`` (the force is tilted enough);
  4. the contact is fresh: its point has travelled at most ``max_contact_travel`` since
     the skin touched down (force above ``touch_force``). The skin's stick-slip springs
     remember how the contact slid: after a slide along the edge, or while a push turns the
     link (the contact then slides along the edge with it), the tangential force lies along
     the edge and the wrench gives a confidently wrong edge (60-90 deg at a predicted 1-2
     deg, DESIGN.md 2.2). A probing shear of 0.3-1 mm stays within the limit;
  5. the contact point moved at least ``min_spacing`` since the last accepted measurement,
     or the edge turned by at least ``min_edge_change`` (so a finger resting still does not
     flood the estimator with copies of one measurement).

* ``"trace"``: a line fit through the contact points of one uninterrupted contact
  (``edge_from_trace``, the slide-along-the-edge probe, DESIGN.md 2.2). The trace restarts
  when the contact is lost or the force leaves the band. Once its ends are ``trace_length``
  apart it is fitted; the fit is accepted when its std is at most ``max_edge_std`` and the
  mean force component along the trace is at most ``trace_max_force_ratio`` of the force.
  That last check separates a slide along a still edge (only friction acts along the
  motion) from a push that turns the link (the force acts along the motion, and the trace
  runs across the edge, not along it).

Edges are signed by continuity: each accepted edge is flipped to agree with the previous one,
which the 3D fit's constant-angle invariant needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing import edge_from_trace
from tactile_gym.spatial import orient_like

__all__ = ["GateConfig", "Measurement", "MeasurementGate"]


@dataclass(frozen=True)
class GateConfig:
    """Thresholds of the measurement gate.

    Attributes:
        force_band: accepted (min, max) contact force magnitude, N.
        max_edge_std: largest accepted predicted edge std, rad.
        min_spacing: least contact-point motion between accepted measurements, m.
        min_edge_change: least edge rotation that also justifies a new measurement, rad.
        max_contact_travel: longest contact-point path since touchdown of an accepted
            wrench measurement, m.
        touch_force: force below which the contact counts as lifted off, N.
        point_std: 1-sigma error of a contact point handed to the estimator, m.
        trace_length: end-to-end trace length that triggers a line fit, m; 0 disables traces.
        trace_point_std: jitter of successive contact points along one trace, m; far below
            ``point_std``, whose bias is common to the whole trace and does not turn the line.
        trace_max_force_ratio: largest mean |f . trace direction| / |f| of an accepted trace.
            Sliding friction bounds it by mu / sqrt(1 + mu^2) (0.45 at mu = 0.5); the scripted
            policy's slides measured 0.24-0.57 and its pushes 0.67-0.82.
    """

    force_band: tuple[float, float] = (4.0, 7.5)
    max_edge_std: float = float(np.deg2rad(5.0))
    min_spacing: float = 0.001
    min_edge_change: float = float(np.deg2rad(2.0))
    max_contact_travel: float = 0.0015
    touch_force: float = 0.5
    point_std: float = 0.001
    trace_length: float = 0.004
    trace_point_std: float = 0.0002
    trace_max_force_ratio: float = 0.62

    def __post_init__(self) -> None:
        lo, hi = self.force_band
        if not (0.0 <= lo < hi):
            raise ValueError(f"force_band must satisfy 0 <= min < max N, got {self.force_band}")
        positive = (
            "max_edge_std",
            "min_spacing",
            "min_edge_change",
            "max_contact_travel",
            "touch_force",
            "point_std",
            "trace_point_std",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if not self.trace_length >= 0:
            raise ValueError(f"trace_length must be >= 0 m, got {self.trace_length!r}")
        if not 0 < self.trace_max_force_ratio <= 1:
            raise ValueError(
                f"trace_max_force_ratio must be in (0, 1], got {self.trace_max_force_ratio!r}"
            )


@dataclass(frozen=True)
class Measurement:
    """One accepted measurement, world frame.

    Attributes:
        point: contact point on the edge, m.
        edge: unit edge direction, signed by continuity.
        point_std: 1-sigma point error, m.
        edge_std: 1-sigma edge angle error, rad.
        source: ``"wrench"`` or ``"trace"``.
    """

    point: np.ndarray
    edge: np.ndarray
    point_std: float
    edge_std: float
    source: str


class MeasurementGate:
    """Decides, step by step, which contact estimates become measurements."""

    def __init__(self, config: GateConfig) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget accepted measurements and the current trace."""
        self._last_point: np.ndarray | None = None
        self._last_edge: np.ndarray | None = None
        self._trace_points: list[np.ndarray] = []
        self._trace_forces: list[np.ndarray] = []
        self._previous_point: np.ndarray | None = None
        self._travel = 0.0

    def offer(
        self,
        valid: bool,
        force: np.ndarray,
        point: np.ndarray,
        edge: np.ndarray,
        edge_std: float,
    ) -> list[Measurement]:
        """Offer one step's contact estimate; return the measurements it yields (0 to 2).

        Args:
            valid: whether the contact estimate is valid.
            force: contact force on the fingertip, world frame, N.
            point: contact point, world frame, m (ignored when not valid).
            edge: edge direction from the wrench, world frame (NaN when unobservable).
            edge_std: its predicted 1-sigma angle error, rad.
        """
        cfg = self.config
        magnitude = float(np.linalg.norm(force))
        in_band = valid and cfg.force_band[0] <= magnitude <= cfg.force_band[1]
        if not (valid and magnitude > cfg.touch_force):
            self._previous_point, self._travel = None, 0.0
        else:
            if self._previous_point is not None:
                self._travel += float(np.linalg.norm(point - self._previous_point))
            self._previous_point = np.array(point, dtype=float)
        if not in_band:
            self._trace_points.clear()
            self._trace_forces.clear()
            return []
        fresh = self._travel <= cfg.max_contact_travel

        accepted = []
        if fresh and np.all(np.isfinite(edge)) and edge_std <= cfg.max_edge_std:
            if self._is_new(point, edge):
                accepted.append(self._accept(point, edge, edge_std, "wrench"))

        if cfg.trace_length > 0:
            self._trace_points.append(np.array(point, dtype=float))
            self._trace_forces.append(np.array(force, dtype=float))
            span = np.linalg.norm(self._trace_points[-1] - self._trace_points[0])
            if span >= cfg.trace_length:
                measurement = self._fit_trace()
                if measurement is not None:
                    accepted.append(measurement)
                self._trace_points = self._trace_points[-1:]
                self._trace_forces = self._trace_forces[-1:]
        return accepted

    def _is_new(self, point: np.ndarray, edge: np.ndarray) -> bool:
        if self._last_point is None:
            return True
        moved = np.linalg.norm(point - self._last_point) >= self.config.min_spacing
        cos_turn = abs(float(np.dot(edge, self._last_edge)))
        turned = np.arccos(min(cos_turn, 1.0)) >= self.config.min_edge_change
        return bool(moved or turned)

    def _fit_trace(self) -> Measurement | None:
        points = np.asarray(self._trace_points)
        direction, std = edge_from_trace(points, point_std=self.config.trace_point_std)
        if not np.all(np.isfinite(direction)) or std > self.config.max_edge_std:
            return None
        forces = np.asarray(self._trace_forces)
        along = np.abs(forces @ direction).mean()
        if along > self.config.trace_max_force_ratio * np.linalg.norm(forces, axis=1).mean():
            return None
        return self._accept(points.mean(axis=0), direction, std, "trace")

    def _accept(self, point: np.ndarray, edge: np.ndarray, edge_std: float, source: str):
        edge = orient_like(edge, [] if self._last_edge is None else [self._last_edge])
        self._last_point = np.array(point, dtype=float)
        self._last_edge = edge
        return Measurement(
            point=self._last_point,
            edge=edge,
            point_std=self.config.point_std,
            edge_std=float(edge_std),
            source=source,
        )
