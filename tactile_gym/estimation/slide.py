"""The direction of a prismatic joint from touch: from the edge lines, and the "simple method"
analogue (docs/design.md 6.10; the paper's Table I, for a drawer).

World frame, metres, radians. :func:`fit_slide_direction` is the proposed method: the
prismatic model's direction (edge lines keep their direction and shift along the joint's),
whatever the contact does along the edge. :func:`fit_slide_simple` is the analogue of the
paper's perpendicular-bisector baseline (eq. 22-26): it assumes the contact stays at one
place on the link, so that the contact points' displacement is the joint's; a contact that
slides along an edge not parallel to the joint spoils it.

The edge lines give the direction only where they show it: a slide moves a line across
itself only, so each edge shows the joint's part normal to it. Edges that all lie in the
table plane show nothing of a direction in that plane unless two of them, not parallel, are
pressed at shared configurations (``configs``): then the ratio of their shifts gives it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation.axis import as_points, canonical_direction
from tactile_gym.estimation.joint_prior import JointTypePrior
from tactile_gym.estimation.joint_prismatic import PrismaticModel
from tactile_gym.estimation.joint_type import JointTypeEstimator, feed
from tactile_gym.estimation.metrics import direction_error

__all__ = ["SlideEstimate", "fit_slide_direction", "fit_slide_simple", "slide_error"]


@dataclass(frozen=True)
class SlideEstimate:
    """A prismatic joint's direction.

    Attributes:
        direction: (3,) unit direction, largest-magnitude component positive; NaN when
            ``degenerate``.
        covariance: (3, 3) covariance of the direction, rad^2 (singular along it); None
            when ``degenerate``.
        angle_std: RMS angle error the covariance predicts, rad (inf when degenerate).
        degenerate: True when the measurements do not determine the direction.
        method: ``"lines"`` or ``"simple"``.
    """

    direction: np.ndarray
    covariance: np.ndarray | None
    angle_std: float
    degenerate: bool
    method: str


def _degenerate(method: str) -> SlideEstimate:
    return SlideEstimate(np.full(3, np.nan), None, math.inf, True, method)


def fit_slide_direction(
    points: np.ndarray,
    edges: np.ndarray,
    point_std: np.ndarray | float,
    edge_std: np.ndarray | float,
    edge_cov: np.ndarray | None = None,
    *,
    lines: np.ndarray | None = None,
    configs: np.ndarray | None = None,
    planar: bool = False,
    prior: JointTypePrior | None = None,
) -> SlideEstimate:
    """The direction from the edge lines: the prismatic model's (the proposed method).

    Args:
        points: (N, 3) contact points, world frame, m.
        edges: (N, 3) physically oriented edge directions, world frame.
        point_std: contact-point std per axis, m: scalar or (N,).
        edge_std: total RMS edge angle error, rad: scalar or (N,).
        edge_cov: optional (N, 3, 3) edge covariances, rad^2.
        lines: (N,) edge-line labels (default: all one line).
        configs: (N,) configuration labels (default: each its own).
        planar: the direction lies in the table plane.
        prior: the priors (travel range, workspace).

    Returns:
        The estimate, ``method="lines"``; ``degenerate`` when the measurements do not set
        the direction (the prior gives more than a quarter of its information in some
        direction), or with fewer than two measurements.

    Raises:
        ValueError: on malformed input.
    """
    mode = "planar" if planar else "3d"
    est = JointTypeEstimator(mode, prior)
    feed(est, points, edges, point_std, edge_std, edge_cov, lines, configs)
    data = est.data
    if data.n < 2 or data.n_configs < 2:
        return _degenerate("lines")
    fit = PrismaticModel(mode, est.prior).fit(data)
    if not fit.identified:
        return _degenerate("lines")
    cov = fit.covariance
    return SlideEstimate(
        fit.parameters, cov, math.sqrt(max(float(np.trace(cov)), 0.0)), False, "lines"
    )


def fit_slide_simple(
    points: np.ndarray, *, lines: np.ndarray | None = None, planar: bool = False
) -> SlideEstimate:
    """The direction of the contact points' displacement (the "simple method" analogue).

    The contact points of each line, taken about their mean, are fitted by one direction
    (the principal axis of their pooled scatter): with the contact fixed on the link they
    move along the joint. The noise is estimated from the scatter normal to it, and the
    covariance is a line fit's, ``sigma^2 / lambda_1`` per normal direction.

    Args:
        points: (N, 3) contact points, world frame, m.
        lines: (N,) edge-line labels (each line's points are taken about their own mean).
        planar: the direction lies in the table plane (the points' z is ignored).

    Returns:
        The estimate, ``method="simple"``; ``degenerate`` with fewer than two points on a
        line, or points that did not move.

    Raises:
        ValueError: on malformed input.
    """
    x = as_points(points, "points", dims=(3,))
    n = x.shape[0]
    labels = np.zeros(n, dtype=int) if lines is None else np.asarray(lines)
    if labels.shape != (n,):
        raise ValueError(f"lines must have shape ({n},), got {labels.shape}")
    dims = 2 if planar else 3
    centred = np.zeros((n, dims))
    groups = np.unique(labels)
    for label in groups:
        idx = labels == label
        centred[idx] = x[idx, :dims] - x[idx, :dims].mean(axis=0)
    dof = (n - groups.size) * (dims - 1) - (dims - 1)
    if dof < 1:
        return _degenerate("simple")
    vals, vecs = np.linalg.eigh(centred.T @ centred)
    if not vals[-1] > 1e-12 or vals[-1] <= 4.0 * vals[-2]:
        return _degenerate("simple")
    v = np.zeros(3)
    v[:dims] = vecs[:, -1]
    var = float(vals[:-1].sum()) / dof
    cov = var / float(vals[-1]) * (np.eye(3) - np.outer(v, v))
    if planar:
        cov[2, :] = cov[:, 2] = 0.0
    direction, _ = canonical_direction(v)
    return SlideEstimate(direction, cov, math.sqrt(float(np.trace(cov))), False, "simple")


def slide_error(estimate: SlideEstimate, true_direction: np.ndarray) -> float:
    """Angle between an estimated and the true direction, either sign, rad in [0, pi/2];
    pi/2 for a degenerate estimate.

    Raises:
        ValueError: on a malformed true direction.
    """
    u = np.asarray(true_direction, dtype=float)
    norm = float(np.linalg.norm(u)) if u.shape == (3,) else 0.0
    if not (math.isfinite(norm) and norm > 0):
        raise ValueError(f"true_direction must be a finite non-zero (3,) vector, got {u!r}")
    if estimate.degenerate:
        return math.pi / 2
    return direction_error(estimate.direction, u)
