"""Robust losses, minimal-set consensus and edge-sign decisions shared by the fits.

Residuals here are whitened (divided by their predicted standard deviation) or, when no
noise model is given, in metres. The losses are those of scipy's ``least_squares``: the
cost of a residual z is ``0.5 f^2 rho((z / f)^2)`` with ``f = f_scale``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["LOSSES"]

LOSSES = ("linear", "soft_l1", "huber", "cauchy")
"""Loss functions accepted by the fits (those of scipy's least_squares)."""

# Chi-square 99 % quantiles: a squared whitened residual beyond them is an outlier.
CHI2_99 = {1: 6.63, 2: 9.21, 3: 11.34}

# Chi-square quantiles at the two-sided 5-sigma probability (5.7e-7): beyond them a
# squared whitened residual is a gross error, not noise.
OUTLIER_GATE = {1: 25.0, 2: 28.7, 3: 31.8}

# Normalised median absolute deviation: 1.4826 MAD estimates a Gaussian std.
MAD_TO_STD = 1.4826

_CONSENSUS_TRIALS = 24


def check_loss(loss: str, f_scale: float | None = None) -> None:
    """Raise ValueError unless ``loss`` is one of ``LOSSES`` and ``f_scale`` None or > 0."""
    if loss not in LOSSES:
        raise ValueError(f"loss must be one of {LOSSES}, got {loss!r}")
    if f_scale is not None and not (math.isfinite(f_scale) and f_scale > 0):
        raise ValueError(f"f_scale must be a finite number > 0, got {f_scale!r}")


def mad_f_scale(residuals: np.ndarray) -> float:
    """Default ``f_scale`` without a noise model: twice a MAD-based noise estimate."""
    return max(2.0 * MAD_TO_STD * float(np.median(np.abs(residuals))), 1e-9)


def loss_cost(z: np.ndarray, loss: str, f_scale: float) -> float:
    """scipy's least_squares cost ``0.5 f^2 sum rho((z / f)^2)`` of whitened residuals."""
    if loss == "linear":
        return 0.5 * float(z @ z)
    s = (z / f_scale) ** 2
    if loss == "soft_l1":
        rho = 2.0 * (np.sqrt(1.0 + s) - 1.0)
    elif loss == "huber":
        rho = np.where(s <= 1.0, s, 2.0 * np.sqrt(s) - 1.0)
    else:  # cauchy
        rho = np.log1p(s)
    return 0.5 * f_scale * f_scale * float(rho.sum())


def split_loss_cost(z: np.ndarray, m: int, loss: str, f_scale: float) -> float:
    """:func:`loss_cost` of the first m whitened residuals (the measurements') plus the
    least-squares cost of the rest (a prior's: robust losses never apply to them)."""
    tail = z[m:]
    return loss_cost(z[:m], loss, f_scale) + 0.5 * float(tail @ tail)


def split_loss(loss: str, m: int):
    """A callable ``loss`` for scipy's least_squares: ``loss`` on the first m residuals,
    least squares on the rest (see :func:`split_loss_cost`).

    scipy calls it with ``s = (f / f_scale)^2`` and takes ``(rho, rho', rho'')`` in s.
    """

    def rho(s: np.ndarray) -> np.ndarray:
        out = np.empty((3, s.size))
        out[0] = s
        out[1] = 1.0
        out[2] = 0.0
        head = s[:m]
        if loss == "soft_l1":
            t = 1.0 + head
            out[0, :m] = 2.0 * (np.sqrt(t) - 1.0)
            out[1, :m] = t**-0.5
            out[2, :m] = -0.5 * t**-1.5
        elif loss == "huber":
            far = head > 1.0
            root = np.sqrt(np.where(far, head, 1.0))
            out[0, :m] = np.where(far, 2.0 * root - 1.0, head)
            out[1, :m] = np.where(far, 1.0 / root, 1.0)
            out[2, :m] = np.where(far, -0.5 / (root * root * root), 0.0)
        elif loss == "cauchy":
            out[0, :m] = np.log1p(head)
            out[1, :m] = 1.0 / (1.0 + head)
            out[2, :m] = -(out[1, :m] ** 2)
        return out

    return rho


def robust_weights(r: np.ndarray, loss: str, f_scale: float, curvature: bool = False):
    """IRLS weights rho'(s), s = (r / f_scale)^2, of scipy's losses.

    With ``curvature`` also the weights of the Newton matrix, the second derivative of
    ``0.5 rho(s)`` in r: ``rho' + 2 s rho''``, clipped to at least ``0.05 rho'`` (Cauchy's
    is negative far out).
    """
    s = (r / f_scale) ** 2
    if loss == "soft_l1":
        w = 1.0 / np.sqrt(1.0 + s)
        return (w, w * w * w) if curvature else w
    if loss == "huber":
        out = s > 1.0
        w = np.where(out, 1.0 / np.sqrt(np.maximum(s, 1.0)), 1.0)
        return (w, np.where(out, 0.05 * w, 1.0)) if curvature else w
    if loss == "cauchy":
        w = 1.0 / (1.0 + s)
        return (w, np.maximum((1.0 - s) * w * w, 0.05 * w)) if curvature else w
    w = np.ones_like(r)
    return (w, w) if curvature else w


def sign_flips(keep: np.ndarray, flipped: np.ndarray, dof: int) -> np.ndarray:
    """Which edges to flip, from squared whitened norms with each edge as oriented and
    flipped: those that fit flipped at most a quarter as badly, and better by more than
    ``OUTLIER_GATE[dof]`` (5 sigma).

    A weaker rule lets noise pick the sign wherever both fit about alike (an edge line
    near the axis and normal to it, or a distance d that is small against the noise), and
    a valid edge flipped costs these badly conditioned fits dearly.
    """
    return (flipped < 0.25 * keep) & (keep - flipped > OUTLIER_GATE[dof])


def consensus(
    n: int,
    fit_triple: Callable[[np.ndarray], object | None],
    sq_norms: Callable[[object], np.ndarray],
    dof: int,
    whitened: bool = True,
    shares: np.ndarray | None = None,
) -> tuple[np.ndarray, object, float] | None:
    """The inlier mask and fit of the best minimal (3-measurement) fit, RANSAC-style.

    Candidate triples are spread over the sequence (deterministically, then from a
    fixed-seed generator), so results are reproducible; the number of trials adapts to a
    99 % chance of one all-inlier triple (at most 24). Whitened norms: the best candidate
    has the most inliers (``sq_norms(fit) < CHI2_99[dof]``), ties going to the lower
    truncated sum. Without a noise model a candidate's own residuals cannot tell its noise
    level (a wrong fit has large residuals everywhere, and all look alike), so the best
    candidate has the least median norm (Rousseeuw's least median of squares), and the
    noise variance comes from that median.

    ``shares`` count repeated measurements of one thing once: inliers are counted by their
    shares, and the triples are spread over the cumulative shares (random ones drawn in
    proportion to them). Many measurements of one edge line then neither crowd out the
    triples of distinct lines nor make any axis through that line win the count.

    Args:
        n: number of measurements (>= 3).
        fit_triple: the fit of the measurements at three indices, or None where they do
            not determine one.
        sq_norms: (n,) squared residual norms of all measurements under a fit, whitened or
            (``whitened=False``) not.
        dof: degrees of freedom of one measurement's residual.
        whitened: whether ``sq_norms`` are in units of their predicted variance.
        shares: optional (n,) shares > 0 of the measurements in the inlier count, e.g.
            ``1 / (number of measurements of the same line)``; default all 1.

    Returns:
        ``(inliers, fit, scale)``: ``scale`` is the noise variance that whitens the norms
        (1 when they are whitened). None when no triple gave a fit with 4 inliers or more.
    """
    threshold = CHI2_99[dof]
    share = np.ones(n) if shares is None else shares
    total = float(share.sum())
    best = best_key = best_fit = None
    needed = _CONSENSUS_TRIALS
    for trial, tri in enumerate(_triples(n, shares)):
        if trial >= needed:
            break
        if len(set(tri)) < 3:
            continue
        fit = fit_triple(np.array(tri))
        if fit is None:
            continue
        z = sq_norms(fit)
        scale = 1.0 if whitened else _lmeds_variance(z, dof)
        inl = z < threshold * scale
        count = float(share @ inl)
        if whitened:
            key = (count, -float(np.minimum(z, threshold).sum()))
        else:
            key = (-scale,)
        if best_key is None or key > best_key:
            best, best_key, best_fit, best_scale = inl, key, fit, scale
            # Trials for a 99 % chance of one all-inlier triple; as many as allowed when the
            # best triple so far explains (almost) nothing, where the formula's log is 0.
            good = min(count / total, 1.0 - 1e-9) ** 3
            needed = _CONSENSUS_TRIALS
            if good > 1e-12:
                needed = min(needed, int(math.ceil(math.log(0.01) / math.log1p(-good))))
    if best is None or best.sum() < 4:
        return None
    return best, best_fit, best_scale


# Medians of chi-square variables by degrees of freedom.
_CHI2_MEDIAN = {1: 0.455, 2: 1.386}


def _lmeds_variance(sq_norms: np.ndarray, dof: int) -> float:
    """Noise variance from the median squared norm of a minimal (3-measurement) fit, with
    Rousseeuw's small-sample factor ``(1 + 5 / (n - 3))^2``."""
    n = sq_norms.size
    factor = (1.0 + 5.0 / max(n - 3, 1)) ** 2
    return max(factor * float(np.median(sq_norms)) / _CHI2_MEDIAN[dof], 1e-300)


def _triples(n: int, shares: np.ndarray | None = None):
    """Up to ``_CONSENSUS_TRIALS`` index triples: spread over the sequence (over the
    cumulative ``shares`` when given), then random from a fixed-seed generator (drawn in
    proportion to the shares, and only when needed: most fits stop after a few)."""
    if shares is None:
        third = max(n // 3, 1)
        for i in range(min(n, _CONSENSUS_TRIALS)):
            yield (i, (i + third) % n, (i + 2 * third) % n)
        prob = None
    else:
        # Measurement i covers [end_i - shares_i, end_i) of the cumulative shares.
        end = np.cumsum(shares)
        total = float(end[-1])
        m = min(n, _CONSENSUS_TRIALS)
        start = (np.arange(m) + 0.5) * total / m
        at = (start[:, None] + total * np.array([0.0, 1.0, 2.0]) / 3.0) % total
        idx = np.searchsorted(end, at, side="right").clip(max=n - 1)
        yield from map(tuple, idx.tolist())
        prob = shares / total
    gen = np.random.default_rng(0)
    for _ in range(_CONSENSUS_TRIALS - n):
        yield tuple(gen.choice(n, size=3, replace=False, p=prob).tolist())
