"""Online joint-axis estimation: add one tactile measurement at a time.

Conventions: world frame, metres, radians. Points are contact points on the link's edge,
edges its direction there (any sign; each new edge is oriented like the best-aligned of
the previous few, see :func:`tactile_gym.spatial.orient_edges`; ``covariance="calibrated"``
keeps the sign as handed), ``point_std`` the
contact-point std per axis (m), ``edge_std`` the edge's total RMS angle error (rad) and
``edge_cov`` optionally its full covariance (rad^2), as for
:func:`~tactile_gym.estimation.fit3d.fit_axis_3d`.

The estimator validates and stores the measurements, tracks whether they identify the axis,
and refits through one :class:`~tactile_gym.estimation.interface.AxisFit`
(:class:`~tactile_gym.estimation.fits.PlanarFit` or
:class:`~tactile_gym.estimation.fit3d.Fit3D`), warm-started from its last solution where it
can (docs/design.md 6.8). Each measurement is weighted by the inverse of its predicted
residual variance (docs/design.md 6.3: the fit is badly conditioned over small rotations).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tactile_gym.estimation.axis import AxisEstimate, as_edge_covs, stds_from_covariance
from tactile_gym.estimation.calibration import CALIBRATED, press_noise, spot_counts
from tactile_gym.estimation.fit3d import Fit3D
from tactile_gym.estimation.fits import PlanarFit
from tactile_gym.estimation.interface import Measurements
from tactile_gym.estimation.link_angles import LinkAngles, as_measurements
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.robust import check_loss
from tactile_gym.spatial import SIGN_LOOKBACK, orient_like

__all__ = ["JointAxisEstimator"]

MODES = ("planar", "3d")
COVARIANCES = ("independent", "calibrated")

# Edge directions closer than this (or 3 edge stds) count as the same direction when
# checking identifiability, rad.
_DISTINCT_TOL = math.radians(0.5)


class JointAxisEstimator:
    """Incremental joint-axis estimate from tactile measurements.

    Without a prior, ``estimate()`` returns None until the axis is identifiable:

    * ``"planar"`` (axis along world z, paper eq. 16-21): at least ``min_measurements``
      (default 3) measurements with at least three distinct edge directions in the x-y plane;
    * ``"3d"`` (any axis, see :func:`~tactile_gym.estimation.fit3d.fit_axis_3d`): at least
      ``min_measurements`` (default 4) measurements with at least three distinct edge
      directions, or a fit that chose the parallel model (the axis parallel to the edges,
      eq. 9-10; a noisy edge may count as a second direction);

    and the fit is not degenerate. Directions are distinct when more than
    ``max(0.5 deg, 3 edge_std)`` apart.

    With a ``prior`` (an :class:`~tactile_gym.estimation.prior.AxisPrior`, e.g. from the
    reset distribution) the fits are maximum a posteriori (see the fits' ``prior``) and
    ``estimate()`` always returns an estimate: the prior's own (``method="prior"``) before
    any measurement, then the fit of the measurements and the prior, which moves smoothly
    away from the prior as information accrues; its covariance includes the prior.
    ``min_measurements`` and the distinct directions do not apply. The planar mode uses
    the prior's pin (x-y) only: its axis is vertical by assumption.

    ``covariance`` says what the handed noise means. ``"independent"`` (the default, the v2
    ids' estimator): each measurement's ``point_std`` and edge noise are its whole error,
    independent of the others'. ``"calibrated"``: they are the sensing's bounds, and the fits
    use the error model of :mod:`~tactile_gym.estimation.calibration` (docs/design.md 6.9):
    the contact point's variation between presses in place of its bound, the press's
    noise-free edge error and the edge's error out of the face that the reading noise leaves
    out, and each spot's bias counted once per press at that spot, so that repeated presses
    at one spot do not average it away. With a prior its ``position_std`` is taken at the
    axis point nearest the prior's pin, where the task measures the position error
    (docs/design.md 6.7). Its fits take one line per link angle: presses whose lines are one
    line within their noise are grouped and fused (:mod:`~tactile_gym.estimation.link_angles`),
    so that presses that never turned the link count as one line, which says nothing about
    the axis: until a second link angle the estimate stays the prior's (``method="prior"``).
    Its 3D fit keeps the best of several refined starts and the parallel model only where
    the prior admits it (``Fit3D.fit_lines``), so that a local minimum does not make a
    confident wrong estimate. It takes each edge's sign as handed, so its edges must be signed
    consistently with the link (the gate signs them physically, docs/design.md 7.3): re-signed
    like the last few, an edge after a turn of more than 90 deg flips.

    Both modes use ``loss``; how each fit uses it and warm-starts is told by
    :class:`~tactile_gym.estimation.fits.PlanarFit` and
    :class:`~tactile_gym.estimation.fit3d.Fit3D`. Results are cached; ``estimate()``
    refits only after ``add``.

    Args:
        mode: ``"planar"`` or ``"3d"``.
        loss: loss of the fit, one of ``LOSSES`` (``"linear"``: least squares); it never
            applies to the prior.
        min_measurements: measurements needed before a first estimate without a prior
            (>= 3).
        prior: optional :class:`~tactile_gym.estimation.prior.AxisPrior`, kept across
            ``reset``.
        covariance: ``"independent"`` or ``"calibrated"`` (``COVARIANCES``), above.
    """

    def __init__(
        self,
        mode: str = "planar",
        loss: str = "soft_l1",
        min_measurements: int | None = None,
        prior: AxisPrior | None = None,
        covariance: str = "independent",
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        check_loss(loss)
        # The stds of every measurement make the noise absolute.
        check_prior(prior, absolute_noise=True)
        default_min = 3 if mode == "planar" else 4
        if min_measurements is None:
            min_measurements = default_min
        # float() first: inf and NaN must fail here like any non-integer, not in int().
        if not (float(min_measurements).is_integer() and min_measurements >= 3):
            raise ValueError(f"min_measurements must be an integer >= 3, got {min_measurements!r}")
        if covariance not in COVARIANCES:
            raise ValueError(f"covariance must be one of {COVARIANCES}, got {covariance!r}")
        self.covariance = covariance
        self.mode = mode
        self.loss = loss
        self.prior = prior
        self.min_measurements = int(min_measurements)
        self._dim = 2 if mode == "planar" else 3
        self.reset()

    def reset(self) -> None:
        """Forget every measurement and the cached estimate."""
        cap = 16
        self._n = 0
        self._points = np.empty((cap, 3))
        self._edges = np.empty((cap, 3))
        self._point_std = np.empty(cap)
        # The edge noise as the fit uses it (AxisFit.edge_noise).
        self._edge_noise = np.empty((cap,) if self.mode == "planar" else (cap, 3, 3))
        # covariance="calibrated": the parts each press shares with its spot (calibration.py).
        self._edge_shared = np.empty_like(self._edge_noise)
        self._point_shared = np.empty(cap)
        self._dirs: list[np.ndarray] = []  # representatives of distinct edge directions
        # covariance="calibrated": the presses grouped by link angle (link_angles.py), for the
        # general and planar models and, by their lines alone, for the parallel model.
        planar = self.mode == "planar"
        self._angles = LinkAngles(planar)
        self._parallel_angles = None if planar else LinkAngles(planar, by_direction=False)
        self._cached: AxisEstimate | None = None
        self._stale = True
        if self.mode == "planar":
            self._fit = PlanarFit(self.loss, self.prior)
        else:
            self._fit = Fit3D(self.loss, self.prior)

    @property
    def n_measurements(self) -> int:
        """Number of measurements added since the last reset."""
        return self._n

    def _view(self, a: np.ndarray) -> np.ndarray:
        v = a[: self._n]
        v.flags.writeable = False
        return v

    @property
    def points(self) -> np.ndarray:
        """(N, 3) contact points added, world frame, m (read-only)."""
        return self._view(self._points)

    @property
    def edges(self) -> np.ndarray:
        """(N, 3) unit edge directions as oriented for the fit (read-only; planar: z = 0)."""
        return self._view(self._edges)

    def add(
        self,
        point: np.ndarray,
        edge: np.ndarray,
        point_std: float,
        edge_std: float,
        edge_cov: np.ndarray | None = None,
    ) -> None:
        """Add one measurement.

        Args:
            point: (3,) contact point, world frame, m ((2,) allowed in planar mode).
            edge: (3,) edge direction, world frame, any length > 0 and any sign ((2,)
                allowed in planar mode; ``covariance="calibrated"``: signed physically, its
                sign is kept). In planar mode its z part is dropped after
                ``edge_std`` or ``edge_cov`` has given the variance of its rotation about z.
            point_std: contact-point std per axis, m, >= 0.
            edge_std: total RMS angle error of the edge, rad, >= 0. Without ``edge_cov``
                the noise is isotropic about the edge (for a (2,) edge: all of it about z).
            edge_cov: optional (3, 3) covariance of the perturbation of the unit edge,
                world frame, rad^2 (see :func:`~tactile_gym.estimation.fit3d.fit_axis_3d`).
                When given it replaces the isotropic model; ``edge_std`` then only sets the
                tolerance of distinct directions.

        Raises:
            ValueError: on a malformed point or edge, a zero edge (planar: no x-y part),
                a negative or non-finite std, or an edge_cov that is not a finite symmetric
                positive semi-definite (3, 3) matrix.
        """
        x = np.asarray(point, dtype=float)
        e = np.asarray(edge, dtype=float)
        allowed = (2, 3) if self.mode == "planar" else (3,)
        if x.ndim != 1 or x.shape[0] not in allowed:
            raise ValueError(
                f"point must have shape {' or '.join(f'({a},)' for a in allowed)}, got {x.shape}"
            )
        if e.ndim != 1 or e.shape[0] not in allowed:
            raise ValueError(
                f"edge must have shape {' or '.join(f'({a},)' for a in allowed)}, got {e.shape}"
            )
        xl = x.tolist()
        el = e.tolist()
        if not all(math.isfinite(v) for v in xl + el):
            raise ValueError(f"point and edge must be finite, got {xl} and {el}")
        sx = float(point_std)
        se = float(edge_std)
        if not (math.isfinite(sx) and sx >= 0):
            raise ValueError(f"point_std must be finite and >= 0 m, got {point_std!r}")
        if not (math.isfinite(se) and se >= 0):
            raise ValueError(f"edge_std must be finite and >= 0 rad, got {edge_std!r}")
        if len(el) == 2:
            el.append(0.0)
        length = math.sqrt(el[0] * el[0] + el[1] * el[1] + el[2] * el[2])
        norm = math.hypot(el[0], el[1]) if self.mode == "planar" else length
        if norm <= 1e-12:
            what = "an x-y part" if self.mode == "planar" else "a non-zero length"
            raise ValueError(f"edge must have {what}, got {e.tolist()}")
        cov = None
        if edge_cov is not None:
            cov = np.asarray(edge_cov, dtype=float)[None]
            if cov.shape != (1, 3, 3):
                raise ValueError(f"edge_cov must have shape (3, 3), got {cov.shape[1:]}")
            cov = as_edge_covs(cov, np.array(el)[None] / length)
        # From the edge as given, before its z part goes (planar) and it is normalised.
        given = np.array(el)
        cov = None if cov is None else cov[0]
        if self.covariance == "calibrated":
            own, shared, point_var, point_shared = press_noise(
                given / length, e.shape[0], se, cov, sx, CALIBRATED
            )
            noise = self._fit.edge_noise(given, e.shape[0], se, own)
            edge_shared = self._fit.edge_noise(given, e.shape[0], se, shared)
            sx = math.sqrt(point_var)
        else:
            noise = self._fit.edge_noise(given, e.shape[0], se, cov)
        if self.mode == "planar":
            el[2] = 0.0
        el = [v / norm for v in el]
        if len(xl) == 2:
            xl.append(0.0)
        n = self._n
        if n == self._points.shape[0]:
            self._grow()
        self._points[n] = xl
        if self.covariance == "calibrated" or not n:
            # Calibrated: the sign as handed. The gate signs every edge physically (docs/design.md
            # 7.3); signed like the last few instead, an edge after a turn of more than 90 deg
            # between presses flipped, and the planar fit put the axis on the wrong bisector of
            # the two lines with a confident std (docs/design.md 6.9).
            self._edges[n] = el
        else:
            # Later edges follow the best-aligned of the last few.
            self._edges[n] = orient_like(el, self._edges[max(0, n - SIGN_LOOKBACK) : n])
        self._point_std[n] = sx
        self._edge_noise[n] = noise
        if self.covariance == "calibrated":
            self._edge_shared[n] = edge_shared
            self._point_shared[n] = point_shared
            for angles in (self._angles, self._parallel_angles):
                if angles is not None:
                    angles.add(self._points[n], self._edges[n], sx * sx, noise)
        self._n = n + 1
        if len(self._dirs) < 3:
            tol = math.cos(max(_DISTINCT_TOL, 3.0 * se))
            ev = self._edges[n]
            if all(abs(float(ev @ d)) < tol for d in self._dirs):
                self._dirs.append(ev.copy())
        self._stale = True

    def _calibrated(self, data: Measurements) -> Measurements:
        """The measurements with each press's shared noise counted once per press at its
        spot (``calibration.py``)."""
        n = data.n
        extra = spot_counts(data.points, CALIBRATED.spot_radius) - 1.0
        shared = self._edge_shared[:n]
        return Measurements(
            data.points,
            data.edges,
            np.sqrt(np.square(data.point_std) + extra * self._point_shared[:n]),
            data.edge_noise + extra.reshape((n,) + (1,) * (shared.ndim - 1)) * shared,
        )

    def _fit_link_angles(self, data: Measurements) -> AxisEstimate:
        """The calibrated fit: of one line per link angle (``link_angles.py``), each fused
        from its presses' noise with their spot's share counted (``data``)."""
        if data.n == 0:
            return self._fit.fit(data)
        planar = self.mode == "planar"
        lines = as_measurements(self._angles.fused(*_arrays(data)), planar)
        if planar:
            if self.prior is not None and lines.n < 2:
                # One link angle says nothing about the axis (Fit3D.fit_lines).
                return self.prior.estimate(planar=True)
            return self._fit.fit(lines)

        def parallel_lines() -> Measurements:
            return as_measurements(self._parallel_angles.fused(*_arrays(data)), planar)

        return self._fit.fit_lines(lines, parallel_lines)

    def _at_pin(self, est: AxisEstimate) -> AxisEstimate:
        """The estimate with its ``position_std`` taken at the axis point nearest the
        prior's pin, where the task measures the position error (docs/design.md 6.7)."""
        if est.covariance is None:
            return est
        lever = float((self.prior.pin - est.point) @ est.direction)
        position_std, _ = stds_from_covariance(est.covariance, est.direction, lever)
        return dataclasses.replace(est, position_std=position_std)

    def _grow(self) -> None:
        for name in (
            "_points",
            "_edges",
            "_point_std",
            "_edge_noise",
            "_edge_shared",
            "_point_shared",
        ):
            old = getattr(self, name)
            new = np.empty((2 * old.shape[0],) + old.shape[1:])
            new[: self._n] = old[: self._n]
            setattr(self, name, new)

    def estimate(self) -> AxisEstimate | None:
        """The current axis estimate; without a prior, None while the axis is not
        identifiable."""
        if not self._stale:
            return self._cached
        self._stale = False
        self._cached = self._refit()
        return self._cached

    def _refit(self) -> AxisEstimate | None:
        n = self._n
        prior = self.prior
        if prior is None and (
            n < self.min_measurements or (self.mode == "planar" and len(self._dirs) < 3)
        ):
            return None
        data = Measurements(
            self._points[:n], self._edges[:n], self._point_std[:n], self._edge_noise[:n]
        )
        if self.covariance == "calibrated":
            est = self._fit_link_angles(self._calibrated(data))
            if prior is not None:
                est = self._at_pin(est)
        else:
            est = self._fit.refit(data)
        if prior is not None:
            # Flagged if degenerate (the prior keeps the system regular; only overflowing
            # input could), never None.
            return est
        if est.degenerate:
            return None
        if self.mode == "3d" and len(self._dirs) < 3 and est.method != "3d-parallel":
            return None
        return est


def _arrays(data: Measurements) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A fit's measurements as :meth:`LinkAngles.fused` takes them: points, edges, point
    variances, edge noise."""
    return data.points, data.edges, np.square(data.point_std), data.edge_noise
