"""The interface of an incremental axis fit: fit, update with appended measurements, state.

The online estimator (:class:`~tactile_gym.estimation.online.JointAxisEstimator`) holds one
:class:`AxisFit` and knows nothing of how it fits: the planar fit
(:class:`~tactile_gym.estimation.fits.PlanarFit`, docs/design.md 6.1) and the 3D fit
(:class:`~tactile_gym.estimation.fit3d.Fit3D`, docs/design.md 6.2) both implement it. An
update starts from the solution of the previous call (the fit's ``state``), which is what
keeps the estimator cheap enough to run at every step of an env; a fit starts afresh
(consensus included, docs/design.md 6.4, 6.8).

Conventions: world frame, metres, radians; the measurement noise is absolute (a std for
each contact point and a noise for each edge), so a prior (docs/design.md 6.6) can be fused.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation.axis import AxisEstimate
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.robust import check_loss

__all__ = ["AxisFit", "Measurements"]

# With a robust loss an update refuses (and a full fit, consensus included, follows) once
# the number of measurements has grown by this factor since the last full fit.
FULL_REFIT_GROWTH = 1.25


@dataclass(frozen=True)
class Measurements:
    """The measurements a fit sees, in the order they were taken.

    Attributes:
        points: (N, 3) contact points, world frame, m.
        edges: (N, 3) unit edge directions, oriented consistently (each like the best-aligned
            of the few before it, :func:`tactile_gym.spatial.orient_like`); the planar fit's
            have z = 0.
        point_std: (N,) contact-point std per axis, m.
        edge_noise: the edges' noise as the fit uses it, one row per edge from
            :meth:`AxisFit.edge_noise`: (N,) or (N, 3, 3).
    """

    points: np.ndarray
    edges: np.ndarray
    point_std: np.ndarray
    edge_noise: np.ndarray

    @property
    def n(self) -> int:
        """Number of measurements."""
        return self.points.shape[0]


class AxisFit(ABC):
    """A joint-axis fit that can be refitted cheaply as measurements are appended.

    Args:
        loss: loss of the fit, one of ``LOSSES`` (``"linear"``: least squares); it never
            applies to the prior.
        prior: optional :class:`~tactile_gym.estimation.prior.AxisPrior`, fused with the
            measurements (maximum a posteriori); then the fit of no measurement is the
            prior's estimate.
    """

    def __init__(self, loss: str = "soft_l1", prior: AxisPrior | None = None) -> None:
        check_loss(loss)
        check_prior(prior, absolute_noise=True)
        self.loss = loss
        self.prior = prior
        self._state = None
        self._n_full = 0  # measurements at the last full fit

    @property
    def state(self) -> object | None:
        """The solution the next :meth:`update` starts from; None before a fit or after a
        degenerate one."""
        return self._state

    @abstractmethod
    def edge_noise(
        self, edge: np.ndarray, dims: int, edge_std: float, edge_cov: np.ndarray | None
    ) -> np.ndarray | float:
        """One edge's noise as this fit uses it (a row of ``Measurements.edge_noise``).

        Args:
            edge: (3,) the edge as measured, any length > 0, world frame.
            dims: 2 when the edge was given in the x-y plane (all its error turns it about
                z), else 3.
            edge_std: its total RMS angle error, rad (isotropic about the edge).
            edge_cov: None, or its validated (3, 3) covariance, rad^2, which then replaces
                ``edge_std``.
        """

    @abstractmethod
    def fit(self, data: Measurements) -> AxisEstimate:
        """Fit afresh; the result becomes :attr:`state`."""

    @abstractmethod
    def update(self, data: Measurements) -> AxisEstimate | None:
        """Refit from :attr:`state` after measurements were appended to those it was fitted
        to (``data`` holds them all, old first).

        Returns:
            The estimate, or None (``state`` unchanged) when a full :meth:`fit` is called
            for: no state yet, or as the subclass decides (e.g. the measurements grew by
            ``FULL_REFIT_GROWTH`` since the last full fit, or a new one is an outlier).
        """

    def refit(self, data: Measurements) -> AxisEstimate:
        """:meth:`update` where it can, else :meth:`fit`."""
        est = self.update(data)
        return self.fit(data) if est is None else est

    def _grown(self, n: int) -> bool:
        """Whether n measurements call for a full fit under the growth rule."""
        return not n < self._n_full * FULL_REFIT_GROWTH
