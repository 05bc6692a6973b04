"""A Gaussian prior on the joint axis, known before any touch (e.g. from a reset distribution).

World frame, metres, radians (docs/design.md 6.6). The prior says where the hinge pin is (a
mean point and its covariance) and which way the axis points (a mean direction and the RMS
angle of the true direction from it). The fits fuse it with the measurements as a Gaussian
prior (maximum a posteriori):

* planar fits: a prior on the axis position (p, q) from the pin's x-y mean and covariance,
  added to the normal equations; the distance d keeps a flat prior;
* 3D fit: two residuals on the direction (its error in a basis normal to the prior
  direction, either sign of the axis, whitened by ``angle_std / sqrt(2)`` each) and two on
  the position (the offset of the prior pin from the axis line, normal to the axis,
  whitened by the pin covariance projected on that plane). The second matches the error
  metric, the distance from the true pin to the estimated axis line.

Robust losses apply to the measurements only, never to the prior's residuals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from tactile_gym.estimation.axis import (
    AxisEstimate,
    canonical_direction,
    closest_point_to_origin,
    stds_from_covariance,
)

__all__ = ["AxisPrior", "check_prior"]

# Floors on the prior's spread, used by the fits: a zero spread (a reset distribution that
# never moves the pin along some direction, or never tilts the axis) would be an infinite
# weight. Far below any real uncertainty, far above rounding.
PIN_STD_FLOOR = 1e-5  # m
ANGLE_STD_FLOOR = 1e-5  # rad


@dataclass(frozen=True, eq=False)
class AxisPrior:
    """A Gaussian prior on the joint axis (world frame, metres, radians).

    Attributes:
        pin: (3,) mean hinge-pin centre, m. Any point of the mean axis serves, but the
            position prior is on the axis' distance from this point, so it should be the
            point whose spread ``pin_cov`` describes.
        pin_cov: (3, 3) covariance of the pin centre, m^2; symmetric positive semi-definite.
            Only its part normal to the axis matters.
        direction: (3,) mean axis direction; normalised and signed canonically (largest
            component positive) on construction.
        angle_std: RMS angle between the true axis direction and ``direction``, rad, in
            [0, pi/2]: tiny for a known direction (a planar family), 15-60 degrees for mixed
            3D families.

    The fits floor the spread at ``PIN_STD_FLOOR`` per direction and ``ANGLE_STD_FLOOR``.

    Raises:
        ValueError: on a malformed field.
    """

    pin: np.ndarray
    pin_cov: np.ndarray
    direction: np.ndarray
    angle_std: float

    def __post_init__(self) -> None:
        pin = _finite(self.pin, (3,), "pin", " (m)")
        cov = _finite(self.pin_cov, (3, 3), "pin_cov", " (m^2)")
        scale = float(np.abs(cov).max())
        if not np.allclose(cov, cov.T, rtol=0.0, atol=1e-9 * scale):
            raise ValueError(f"pin_cov must be symmetric, got {cov.tolist()}")
        cov = 0.5 * (cov + cov.T)
        if np.linalg.eigvalsh(cov)[0] < -1e-9 * scale:
            raise ValueError(f"pin_cov must be positive semi-definite (m^2), got {cov.tolist()}")
        u = _finite(self.direction, (3,), "direction", "")
        norm = float(np.linalg.norm(u))
        if not norm > 1e-12:
            raise ValueError(f"direction must be a non-zero vector, got {u.tolist()}")
        u, _ = canonical_direction(u / norm)
        angle = float(self.angle_std)
        if not 0.0 <= angle <= math.pi / 2:
            raise ValueError(f"angle_std must be in [0, pi/2] rad, got {self.angle_std!r}")
        for name, value in (("pin", pin), ("pin_cov", cov), ("direction", u)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "angle_std", angle)

    @classmethod
    def from_samples(cls, pins: np.ndarray, directions: np.ndarray) -> AxisPrior:
        """The prior of sampled axes, e.g. drawn from an env's reset distribution.

        Args:
            pins: (N, 3) hinge-pin centres, m.
            directions: (N, 3) axis directions, any length > 0, any sign.

        Returns:
            The mean pin and its sample covariance (zero for one sample); the principal
            direction, and the RMS angle of the directions from it.

        Raises:
            ValueError: on malformed input.
        """
        x = np.asarray(pins, dtype=float)
        d = np.asarray(directions, dtype=float)
        if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < 1 or d.shape != x.shape:
            raise ValueError(
                f"pins and directions must have the same shape (N, 3), N >= 1, got "
                f"{x.shape} and {d.shape}"
            )
        norm = np.linalg.norm(d, axis=1)
        if not (np.isfinite(d).all() and (norm > 1e-12).all()):
            raise ValueError("directions must be finite non-zero vectors")
        d = d / norm[:, None]
        # Directions are lines: the principal one, then the angles to it sign-free.
        mean = np.linalg.eigh(d.T @ d)[1][:, 2]
        angle = np.arccos(np.minimum(np.abs(d @ mean), 1.0))
        cov = np.cov(x.T) if x.shape[0] > 1 else np.zeros((3, 3))
        return cls(x.mean(axis=0), cov, mean, float(np.sqrt(np.mean(angle * angle))))

    @cached_property
    def planar_information(self) -> tuple[float, float, float, float, float]:
        """The prior on the axis position (p, q) of a vertical axis in information form:
        the upper triangle ``(l00, l01, l11)`` of the inverse of the pin's x-y covariance,
        1/m^2, and ``(h0, h1)``, that matrix times the pin's x-y, 1/m."""
        cov = self.pin_cov[:2, :2] + PIN_STD_FLOOR**2 * np.eye(2)
        info = np.linalg.inv(cov)
        h = info @ self.pin[:2]
        return float(info[0, 0]), float(info[0, 1]), float(info[1, 1]), float(h[0]), float(h[1])

    def estimate(self, planar: bool = False) -> AxisEstimate:
        """The prior as an axis estimate (before any measurement), ``method="prior"``.

        Args:
            planar: as the planar fits see it: the vertical axis through the pin's x-y,
                ``direction = (0, 0, 1)``, ``angle_std = 0`` and the covariance of (p, q)
                from the pin's x-y covariance.

        Returns:
            The mean axis, ``n_used = 0``. ``distance`` (edge to axis) is unknown: NaN, with
            an infinite variance in ``covariance``; ``residual_rms`` is NaN. The
            covariance of the point and direction follows the spread (floored as in the
            fits), and ``position_std`` and ``angle_std`` come from it as for any estimate.
        """
        cov = np.zeros((7, 7))
        cov[6, 6] = math.inf
        if planar:
            point = np.array([self.pin[0], self.pin[1], 0.0])
            direction = np.array([0.0, 0.0, 1.0])
            cov[:2, :2] = self.pin_cov[:2, :2] + PIN_STD_FLOOR**2 * np.eye(2)
        else:
            direction = self.direction
            point = closest_point_to_origin(self.pin, direction)
            b = self.normal_basis
            # Local parameters: the direction turned by (alpha, beta) about the pin, the
            # pin moved by (s1, s2) normal to the axis; the point closest to the origin
            # follows both.
            g = np.zeros((6, 4))
            for i in range(2):
                g[0:3, i] = -(self.pin @ b[i]) * direction - (self.pin @ direction) * b[i]
                g[0:3, 2 + i] = b[i]
                g[3:6, i] = b[i]
            local = np.zeros((4, 4))
            local[0, 0] = local[1, 1] = 0.5 * self.effective_angle_std**2
            local[2:, 2:] = self.projected_pin_cov(b)
            cov[:6, :6] = g @ local @ g.T
        pos, ang = stds_from_covariance(cov, direction)
        return AxisEstimate(
            point=point,
            direction=direction.copy(),
            distance=math.nan,
            covariance=cov,
            position_std=pos,
            angle_std=0.0 if planar else ang,
            residual_rms=math.nan,
            n_used=0,
            degenerate=False,
            condition_number=1.0,
            method="prior",
        )

    def direction_z2(self, direction: np.ndarray) -> float:
        """The squared whitened residual of the prior's direction term (two degrees of
        freedom, as the fits weigh it) at an axis along ``direction`` (any length, either
        sign): ``2 theta^2 / angle_std^2``, theta the angle between the two axes."""
        u = np.asarray(direction, dtype=float)
        cos = abs(float(u @ self.direction)) / math.sqrt(float(u @ u))
        theta = math.acos(min(cos, 1.0))
        return 2.0 * theta * theta / self.effective_angle_std**2

    @property
    def effective_angle_std(self) -> float:
        """``angle_std`` floored at ``ANGLE_STD_FLOOR``, rad."""
        return max(self.angle_std, ANGLE_STD_FLOOR)

    @cached_property
    def normal_basis(self) -> np.ndarray:
        """(2, 3) orthonormal rows spanning the plane normal to ``direction``."""
        return np.linalg.svd(self.direction[None, :])[2][1:]

    def projected_pin_cov(self, basis: np.ndarray) -> np.ndarray:
        """(2, 2) covariance of the pin in the plane spanned by the orthonormal rows of
        ``basis`` (2, 3), e.g. the plane normal to an axis, floored, m^2."""
        return basis @ self.pin_cov @ basis.T + PIN_STD_FLOOR**2 * np.eye(2)


def check_prior(prior: object, absolute_noise: bool) -> None:
    """Raise ValueError unless ``prior`` is None or an :class:`AxisPrior` given with an
    absolute measurement noise model (a fit must weigh the prior against the measurements
    in the same units)."""
    if prior is None:
        return
    if not isinstance(prior, AxisPrior):
        raise ValueError(f"prior must be an AxisPrior or None, got {type(prior).__name__}")
    if not absolute_noise:
        raise ValueError(
            "a prior needs the measurement noise in absolute terms: give point_std with "
            "edge_std or edge_cov (or, for the planar fit, weights)"
        )


def _finite(value: object, shape: tuple[int, ...], name: str, unit: str) -> np.ndarray:
    a = np.array(value, dtype=float)
    if a.shape != shape or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite {shape} array{unit}, got {value!r}")
    return a
