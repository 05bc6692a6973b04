"""The joint-axis estimate returned by every fit, and the helpers the fits share.

Conventions (docs/design.md 2 and 6.7):

* World frame (z up, table top at z = 0), metres, radians.
* An axis is the line ``point + s * direction``. ``point`` is the point of the line closest to
  the world origin (``point . direction = 0``); ``direction`` is a unit vector whose
  largest-magnitude component is positive (for a vertical axis that is +z, for an axis along
  x it is +x). Ties (axes on a diagonal) go to the earlier component, x before y before z.
* Edge directions are unoriented lines on the object, but the fits need a consistent
  orientation: each is signed like the best-aligned of the few before it
  (:func:`tactile_gym.spatial.orient_edges`), which requires the link to turn by less than
  90 degrees between measurements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AxisEstimate", "COVARIANCE_LAYOUT"]

COVARIANCE_LAYOUT = (
    "point_x",
    "point_y",
    "point_z",
    "direction_x",
    "direction_y",
    "direction_z",
    "distance",
)
"""Order of the parameters in :attr:`AxisEstimate.covariance`."""

_EYE3 = np.eye(3)

# Relative singular-value floor below which a design matrix counts as rank deficient.
DEGENERATE_CONDITION = 1e8


@dataclass(frozen=True)
class AxisEstimate:
    """A joint axis fitted to tactile measurements (world frame, metres, radians).

    Attributes:
        point: (3,) point of the axis closest to the world origin (``point . direction == 0``),
            m. NaN when ``degenerate``.
        direction: (3,) unit direction of the axis, largest-magnitude component positive.
            The planar fits return (0, 0, 1) by assumption; NaN when a 3D fit is
            ``degenerate``.
        distance: distance between the edge lines and the axis, m (>= 0). For the simple
            method (no edges) it is the mean distance of the contact points from the axis.
            NaN when ``degenerate``.
        covariance: (7, 7) first-order covariance of the flattened vector
            ``(point_x, point_y, point_z, direction_x, direction_y, direction_z, distance)``
            (see ``COVARIANCE_LAYOUT``), in m^2, m, and dimensionless units. It is singular
            by construction: ``|direction| = 1`` and ``point . direction = 0`` remove two
            degrees of freedom, and the planar fits hold the direction and ``point_z``
            fixed (zero rows). None when it cannot be estimated (degenerate, or no residual
            degrees of freedom to estimate the noise from when no weights were given).
        position_std: root of the expected squared displacement of ``point`` perpendicular
            to the axis, m (sqrt of the trace of the perpendicular block). inf when unknown.
        angle_std: root of the expected squared angle between the estimated and true
            direction, rad. 0 for the planar fits (direction assumed), inf when unknown.
        residual_rms: RMS of the distance residuals (edge line to axis minus ``distance``;
            contact point to axis minus radius for the simple method), m.
        n_used: number of measurements that entered the fit.
        degenerate: True when the data do not determine the axis (too few measurements,
            identical or all-parallel edges, collinear points, rank deficiency). The
            numeric fields are then NaN or inf and must not be used.
        condition_number: condition number of the (column-scaled) design matrix or
            Jacobian; inf when rank deficient. Large values (> 1e4) mean that small
            measurement errors move the axis a lot.
        method: which fit produced it: ``"planar"``, ``"simple"``, ``"3d"`` or
            ``"3d-parallel"`` (edges parallel to the axis, paper eq. 9-10).
    """

    point: np.ndarray
    direction: np.ndarray
    distance: float
    covariance: np.ndarray | None
    position_std: float
    angle_std: float
    residual_rms: float
    n_used: int
    degenerate: bool
    condition_number: float
    method: str

    def distance_to(self, points: np.ndarray) -> np.ndarray | float:
        """Distance from world points (3,) or (N, 3) to the estimated axis line, m.

        Returns inf for a degenerate estimate.
        """
        q = np.asarray(points, dtype=float)
        if q.ndim not in (1, 2) or q.shape[-1] != 3:
            raise ValueError(f"points must have shape (3,) or (N, 3), got {q.shape}")
        if self.degenerate:
            out = np.full(q.shape[:-1], np.inf)
            return float(out) if q.ndim == 1 else out
        w = q - self.point
        perp = w - (w @ self.direction)[..., None] * self.direction
        dist = np.linalg.norm(perp, axis=-1)
        return float(dist) if q.ndim == 1 else dist


def canonical_direction(u: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit ``u`` with its largest-magnitude component made positive, and the sign applied."""
    i = int(np.argmax(np.abs(u)))
    sign = 1.0 if u[i] >= 0 else -1.0
    return u * sign, sign


def closest_point_to_origin(point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The point of the line ``point + s direction`` closest to the origin (unit direction)."""
    return point - (point @ direction) * direction


def degenerate_estimate(method: str, n_used: int, planar: bool) -> AxisEstimate:
    """A flagged estimate: NaN geometry, inf uncertainties, no covariance."""
    nan3 = np.full(3, np.nan)
    return AxisEstimate(
        point=nan3,
        direction=np.array([0.0, 0.0, 1.0]) if planar else nan3.copy(),
        distance=float("nan"),
        covariance=None,
        position_std=float("inf"),
        angle_std=0.0 if planar else float("inf"),
        residual_rms=float("nan"),
        n_used=int(n_used),
        degenerate=True,
        condition_number=float("inf"),
        method=method,
    )


def stds_from_covariance(
    cov: np.ndarray, direction: np.ndarray, lever: float = 0.0
) -> tuple[float, float]:
    """(position_std, angle_std) from a 7x7 covariance in ``COVARIANCE_LAYOUT`` order.

    The position's is taken ``lever`` (m) along the axis from its ``point``: there the axis
    moves by ``lever`` times each turn of the direction too.
    """
    perp = np.eye(3) - np.outer(direction, direction)
    block = cov[:3, :3]
    if lever:
        cross = cov[:3, 3:6]
        block = block + lever * (cross + cross.T) + lever * lever * cov[3:6, 3:6]
    cp = perp @ block @ perp
    pos = float(np.sqrt(max(np.trace(cp), 0.0)))
    ang = float(np.sqrt(max(np.trace(cov[3:6, 3:6]), 0.0)))
    return pos, ang


# ----------------------------------------------------------------------------- validation


def as_points(points: object, name: str = "points", dims: tuple[int, ...] = (2, 3)) -> np.ndarray:
    """Validate an (N, 2) or (N, 3) float array of finite values."""
    a = np.asarray(points, dtype=float)
    if a.ndim != 2 or a.shape[1] not in dims:
        allowed = " or ".join(f"(N, {d})" for d in dims)
        raise ValueError(f"{name} must have shape {allowed}, got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(
            f"{name} must be finite, got non-finite values in rows "
            f"{np.flatnonzero(~np.isfinite(a).all(axis=1)).tolist()}"
        )
    return a


def as_unit_edges(edges: object, n: int, dims: tuple[int, ...] = (2, 3)) -> np.ndarray:
    """Validate (N, 2|3) edges, non-zero and finite, and normalise them."""
    e = as_points(edges, "edges", dims)
    if e.shape[0] != n:
        raise ValueError(f"edges must have as many rows as points ({n}), got {e.shape[0]}")
    norm = np.sqrt(np.einsum("ij,ij->i", e, e))
    bad = norm < 1e-12
    if bad.any():
        rows = np.flatnonzero(bad).tolist()
        raise ValueError(f"edges must be non-zero direction vectors, got zero rows {rows}")
    return e / norm[:, None]


def as_stds(value: object, n: int, name: str, unit: str) -> np.ndarray:
    """Validate a scalar or (N,) array of finite standard deviations >= 0."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ValueError(f"{name} must be a scalar or shape ({n},), got {a.shape}")
    if not np.isfinite(a).all() or (a < 0).any():
        raise ValueError(f"{name} must be finite and >= 0 {unit}, got {a.tolist()}")
    return a


def as_noise(
    point_std: object, edge_std: object, edge_cov: object, edges: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """Validate a fit's noise model: ``point_std`` with ``edge_std`` or ``edge_cov``.

    Args:
        point_std: contact-point std per axis, m: None, a scalar or (N,).
        edge_std: total RMS edge angle error, rad: None, a scalar or (N,).
        edge_cov: None or (N, 3, 3) edge covariances, rad^2 (see :func:`as_edge_covs`).
        edges: (N, 3) or (N, 2) unit edges, world frame.

    Returns:
        ``(point_std (N,), edge_std (N,) or None, edge_cov (N, 3, 3) or None)``, exactly one
        of the last two set; ``(None, None, None)`` when no noise model is given.
    """
    if point_std is None and edge_std is None and edge_cov is None:
        return None, None, None
    if point_std is None or (edge_std is None) == (edge_cov is None):
        raise ValueError(
            "give point_std together with one of edge_std or edge_cov, got "
            f"point_std={_given(point_std)}, edge_std={_given(edge_std)}, "
            f"edge_cov={_given(edge_cov)}"
        )
    n = edges.shape[0]
    sx = as_stds(point_std, n, "point_std", "m")
    if edge_cov is None:
        return sx, as_stds(edge_std, n, "edge_std", "rad"), None
    return sx, None, as_edge_covs(edge_cov, edges)


def _given(value: object) -> str:
    return "None" if value is None else "given"


def isotropic_edge_covs(edges: np.ndarray, edge_std: np.ndarray) -> np.ndarray:
    """(N, 3, 3) covariances of isotropic edge noise, ``(edge_std^2 / 2) (I - e e^T)``, rad^2.

    Args:
        edges: (N, 3) unit edge directions, world frame.
        edge_std: total RMS angle error of each edge, rad; scalar or (N,).
    """
    proj = _EYE3 - edges[:, :, None] * edges[:, None, :]
    return proj * np.reshape(0.5 * np.square(edge_std), (-1, 1, 1))


def as_edge_covs(edge_cov: object, edges: np.ndarray) -> np.ndarray:
    """Validate (N, 3, 3) edge covariances, rad^2, and keep their part normal to the edges.

    Each must be finite, symmetric and positive semi-definite (to a relative 1e-9). The
    perturbation of a unit edge is normal to it, so the component along the edge (unit
    rows of ``edges``, (N, 3), or (N, 2) in the x-y plane) is projected out:
    ``(I - e e^T) C (I - e e^T)``.
    """
    n = edges.shape[0]
    if edges.shape[1] == 2:
        edges = np.column_stack([edges, np.zeros(n)])
    c = np.asarray(edge_cov, dtype=float)
    if c.shape != (n, 3, 3):
        raise ValueError(f"edge_cov must have shape ({n}, 3, 3), got {c.shape}")
    ct = c.transpose(0, 2, 1)
    with np.errstate(invalid="ignore"):
        scale = np.abs(c).max(axis=(1, 2), initial=0.0)
        bad = ~(np.abs(c - ct).max(axis=(1, 2), initial=0.0) <= 1e-9 * scale)
    if not bad.any():
        proj = _EYE3 - edges[:, :, None] * edges[:, None, :]
        c = proj @ (c + ct) @ proj
        c *= 0.5
        # The projected C has the eigenvalue 0 along e; the other two are >= 0 exactly when
        # their sum (the trace) and product ((tr^2 - |C|_F^2) / 2) are.
        tr = c[:, 0, 0] + c[:, 1, 1] + c[:, 2, 2]
        f2 = np.square(c).sum(axis=(1, 2))
        bad = (tr < -1e-9 * scale) | (tr * tr - f2 < -1e-9 * scale * scale)
    if bad.any():
        raise ValueError(
            "edge_cov must hold finite, symmetric, positive semi-definite matrices (rad^2), "
            f"got rows {np.flatnonzero(bad).tolist()} that are not"
        )
    return c


def as_weights(weights: object, n: int) -> np.ndarray:
    """Validate an (N,) array of finite weights >= 0."""
    w = np.asarray(weights, dtype=float)
    if w.shape != (n,):
        raise ValueError(f"weights must have shape ({n},), got {w.shape}")
    if not np.isfinite(w).all() or (w < 0).any():
        raise ValueError(f"weights must be finite and >= 0, got {w.tolist()}")
    return w
