"""One line per link angle: the calibrated estimator's grouping and fusion of presses
(docs/design.md 6.9).

Conventions: world frame, metres, radians; edges oriented consistently (as the online
estimator stores them); the planar mode's edges have z = 0 and its edge noise is the variance
of each edge's turn about z (rad^2), the 3D mode's a (3, 3) covariance normal to the edge.

Why. The fits take each press's edge line as taken at its own link angle: the model's
latent link angle is free per press. Presses taken at one link angle are one line measured
again and again: their scatter is noise, but a fit that gives each its own angle reads it as
small turns of the link. The lines of a press fan out about its contact point (the point is
known to a fraction of a millimetre, the edge to a degree or two), which is what a small turn
about an axis through the contact points would give. So the fit pulls the axis towards the
contacts, where the predicted residuals are smallest, and finds there an information that is
the noise's: on presses that never turned the link the 3D estimate left the prior by tens of
millimetres and degrees with a shrinking predicted error. One line says nothing about the
axis (its angle and distance to the axis are free), so presses at one link angle must count
as one line.

How. The estimator does not see the link angle; it groups presses whose lines are one line
within their noise (:class:`LinkAngles`), in the order they came, and each group is fused into
one line with its covariance (:func:`fuse`), which the fits then take as one measurement.
Grouping is a test of "one link angle" against "a turn", and its errors are not alike:
joining two link angles loses the information of a turn that the noise nearly hides, while
splitting one link angle fabricates a turn. So a press joins a group when either

* its edge's direction is the group's within the noise (the 99 % quantile of chi-square):
  at another link angle the edge turns (by the turn times the sine of its angle to the
  axis), so one direction is one link angle, and lines of one direction at different
  places (presses across a rounded edge, or on a parallel edge) are the model's error,
  which the fused line's scatter shows; or
* its contact point lies on the group's line up to a gross error (the 5-sigma gate): after
  a turn a press lies on the old line only near where the two lines cross, and a press whose
  edge came out wild (near the link's end) still lies on its line. A group of one press
  (or of presses at exactly one place) has no line but its edges': a press joins it by its
  point only at that place. Without that, single presses at link angles 150 deg apart, one
  at the crossing of the two lines, were joined (test seed 1000027 of the planar v3 id:
  16 mm off with a 0.8 mm std). A press of another link angle at the crossing of a longer
  group's line is still joined, and so is one at the crossing of the line of a spot
  pressed again, whose presses spread along it by their noise only: a gap left open.

For the parallel model (edges along the axis, paper eq. 9-10) every link angle has the same
direction: its groups are by the contact point alone (``by_direction=False``).

The tests use each press's own noise (the calibrated model's, without the part it shares
with its spot), so that the grouping depends on the presses in their order only. The fused
line uses the noise the fits use (the shared part counted once per press at its spot), and
where the members scatter beyond it (chi-square over its degrees of freedom above one) its
covariance is scaled up by that ratio: what the model leaves out shows in the scatter of one
line's presses, and a line that is not one line is worth less. Gross errors (beyond the
5-sigma gate under the group's robust line: a wild edge, a point off the line) are left out
of the fused line.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.interface import Measurements
from tactile_gym.estimation.robust import CHI2_99, OUTLIER_GATE, robust_weights

__all__ = ["Line", "LinkAngles", "fuse", "as_measurements"]

# Floor on a tilt variance, rad^2: keeps an edge covariance seen obliquely invertible.
_TILT_FLOOR = 1e-16
# Robust pre-fit of a group: soft_l1 at 2 standard deviations, as the fits' default.
_F_SCALE = 2.0
_ROBUST_ITER = 10


class Line:
    """A group's fused line.

    Attributes:
        point: (3,) a point of the line, where its position and direction errors are
            independent, m.
        direction: (3,) its unit direction.
        basis: (3, k) orthonormal columns normal to it (planar: k = 1, in the x-y plane).
        point_var: variance of the line's position at ``point``, per direction normal to
            it, m^2.
        tilt_cov: (k, k) covariance of its direction in ``basis``, rad^2.
        scale: chi-square of the members about it over its degrees of freedom, floored at
            one (1 for a single press).
        span: (first, last) of its presses' places along it from ``point``, m.
    """

    __slots__ = ("point", "direction", "basis", "point_var", "tilt_cov", "scale", "span")

    def edge_noise(self, planar: bool) -> np.ndarray | float:
        """The line's edge noise as the fits take it, scaled: the variance of its turn
        about z (planar), else its (3, 3) covariance."""
        if planar:
            return float(self.scale * self.tilt_cov[0, 0])
        return self.scale * (self.basis @ self.tilt_cov @ self.basis.T)


def as_measurements(lines: list[Line], planar: bool) -> Measurements:
    """The fused lines as the fits take measurements: each line's point, direction, position
    std and edge noise, scaled by its scatter."""
    noise = [line.edge_noise(planar) for line in lines]
    return Measurements(
        np.array([line.point for line in lines]).reshape(-1, 3),
        np.array([line.direction for line in lines]).reshape(-1, 3),
        np.sqrt([line.scale * line.point_var for line in lines]),
        np.array(noise).reshape((-1,) if planar else (-1, 3, 3)),
    )


def _basis(e: np.ndarray, planar: bool) -> np.ndarray:
    """(3, k) orthonormal columns normal to the unit e (planar: the in-plane normal)."""
    if planar:
        return np.array([[-e[1]], [e[0]], [0.0]])
    a = np.array([1.0, 0.0, 0.0]) if abs(e[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = a - (a @ e) * e
    b1 /= math.sqrt(float(b1 @ b1))
    return np.column_stack([b1, np.cross(e, b1)])


def fuse(
    points: np.ndarray,
    edges: np.ndarray,
    point_var: np.ndarray,
    edge_noise: np.ndarray,
    planar: bool,
) -> Line:
    """The line of presses taken at one link angle, and its covariance.

    Each press measures the line's position at its contact point and its direction:
    ``y_i = a + s_i w`` and ``t_i = w``, with ``a`` the line's offset normal to a reference
    direction at a reference point, ``w`` its tilt, ``s_i`` the press's distance along the
    line. A robust (soft_l1) fit finds the gross errors, which are left out; a weighted least
    squares fit of the rest gives the line, taken at the weighted mean of its points, where
    its position and tilt errors are independent.

    Args:
        points: (m, 3) contact points, m.
        edges: (m, 3) unit edges (any sign; each is signed like the first).
        point_var: (m,) contact-point variance per axis, m^2.
        edge_noise: (m,) turn variances about z (planar), rad^2, or (m, 3, 3) covariances.
        planar: the planar mode.

    Returns:
        The fused :class:`Line`.
    """
    e = edges * np.where(edges @ edges[0] < 0.0, -1.0, 1.0)[:, None]
    line = Line()
    if e.shape[0] == 1:
        basis = _basis(e[0], planar)
        line.point, line.direction, line.basis = points[0], e[0], basis
        line.point_var = float(point_var[0])
        line.tilt_cov = _tilt_covs(edge_noise, basis, planar)[0]
        line.scale = 1.0
        line.span = (0.0, 0.0)
        return line
    direction = e[0]
    rel = points - points[0]
    # Twice: the second time about the first result's direction, so that a wild first edge
    # does not set the frame of the small-tilt model.
    for _ in range(2):
        ref = direction
        basis = _basis(ref, planar)
        k = basis.shape[1]
        s = rel @ ref
        y = rel @ basis
        t = (e @ basis) / (e @ ref)[:, None]
        info = np.linalg.inv(_tilt_covs(edge_noise, basis, planar))
        ones = np.ones_like(s)
        a, w = _solve(s, y, t, point_var, info, ones, ones)
        for _ in range(_ROBUST_ITER):
            zp, zt = _norms(s, y, t, point_var, info, a, w)
            rp = robust_weights(np.sqrt(zp), "soft_l1", _F_SCALE)
            rt = robust_weights(np.sqrt(zt), "soft_l1", _F_SCALE)
            a, w = _solve(s, y, t, point_var, info, rp, rt)
        zp, zt = _norms(s, y, t, point_var, info, a, w)
        keep_p = zp < OUTLIER_GATE[k]
        keep_t = zt < OUTLIER_GATE[k]
        keep_p[int(np.argmin(zp))] = True
        if not keep_t.any() and np.ptp(s[keep_p]) == 0.0:
            keep_t[int(np.argmin(zt))] = True
        a, w = _solve(s, y, t, point_var, info, keep_p * 1.0, keep_t * 1.0)
        direction = ref + basis @ w
        direction /= math.sqrt(float(direction @ direction))
    zp, zt = _norms(s, y, t, point_var, info, a, w)
    p = keep_p / point_var
    mean_s = float(p @ s) / float(p.sum())
    tilt_info = float(p @ np.square(s - mean_s)) * np.eye(k) + np.einsum("i,ijk->jk", keep_t, info)
    line.point = points[0] + mean_s * ref + basis @ (a + mean_s * w)
    line.direction = direction
    line.basis = _basis(direction, planar)
    turn = line.basis.T @ basis
    line.tilt_cov = turn @ np.linalg.inv(tilt_info) @ turn.T
    line.point_var = 1.0 / float(p.sum())
    dof = k * (int(keep_p.sum()) + int(keep_t.sum()) - 2)
    chi2 = float(zp[keep_p].sum() + zt[keep_t].sum())
    line.scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    line.span = (float(s.min()) - mean_s, float(s.max()) - mean_s)
    return line


class LinkAngles:
    """Presses grouped into link angles in the order they came (module docstring).

    Args:
        planar: the planar mode (edges in the x-y plane, their noise a turn about z).
        by_direction: a press joins a group of its direction too (the general and planar
            models), not only one whose line its contact point lies on (the parallel model).
    """

    def __init__(self, planar: bool, by_direction: bool = True) -> None:
        self.planar = planar
        self.by_direction = by_direction
        #: Each group's presses, by their index in the order they came.
        self.groups: list[list[int]] = []
        self._lines: list[Line] = []
        self._points: list[np.ndarray] = []
        self._edges: list[np.ndarray] = []
        self._point_var: list[float] = []
        self._edge_noise: list = []

    def add(self, point: np.ndarray, edge: np.ndarray, point_var: float, edge_noise) -> None:
        """Group the next press, given with its own noise (not its spot's share).

        Args:
            point: (3,) contact point, m.
            edge: (3,) unit edge as oriented for the fits.
            point_var: its contact-point variance per axis, m^2.
            edge_noise: its turn variance about z (planar), rad^2, or (3, 3) covariance.
        """
        index = len(self._points)
        self._points.append(np.array(point, dtype=float))
        self._edges.append(np.array(edge, dtype=float))
        self._point_var.append(float(point_var))
        self._edge_noise.append(edge_noise)
        self.groups.append([index])
        self._lines.append(self._own_line([index]))
        # The new press joins the group it fits best; the grown group may then fit another.
        current = len(self.groups) - 1
        while True:
            scores = [
                self._score(line, self._lines[current]) if g != current else math.inf
                for g, line in enumerate(self._lines)
            ]
            best = int(np.argmin(scores))
            if not scores[best] < 1.0:
                return
            members = sorted(self.groups[best] + self.groups[current])
            keep, drop = min(best, current), max(best, current)
            del self.groups[drop], self._lines[drop]
            self.groups[keep] = members
            self._lines[keep] = self._own_line(members)
            current = keep

    def fused(
        self, points: np.ndarray, edges: np.ndarray, point_var: np.ndarray, edge_noise
    ) -> list[Line]:
        """Each group's line from the presses' noise as the fits take it (the spot's share
        counted), in the order of the groups' first presses."""
        return [
            fuse(points[g], edges[g], point_var[g], edge_noise[g], self.planar) for g in self.groups
        ]

    def _own_line(self, members: list[int]) -> Line:
        return fuse(
            np.array([self._points[i] for i in members]),
            np.array([self._edges[i] for i in members]),
            np.array([self._point_var[i] for i in members]),
            np.array([self._edge_noise[i] for i in members]),
            self.planar,
        )

    def _score(self, line: Line, other: Line) -> float:
        """How far ``other`` is from being at ``line``'s link angle, in units of the gate:
        below one, one link angle (module docstring)."""
        k = line.basis.shape[1]
        scores = []
        if self.by_direction:
            cos = float(line.direction @ other.direction)
            tilt = (other.direction @ line.basis) / cos
            seen = line.basis.T @ (other.basis @ other.tilt_cov @ other.basis.T) @ line.basis
            gap = float(tilt @ np.linalg.solve(line.tilt_cov + seen, tilt))
            scores.append(gap / CHI2_99[k])
        for a, b in ((line, other), (other, line)):
            rel = b.point - a.point
            if a.span[0] == a.span[1]:
                # Presses at one place: their line is their edges' direction only, and the
                # lines of two link angles cross; a press lies on it only at that place.
                dist2 = float(rel @ rel) / (a.point_var + b.point_var)
                scores.append(dist2 / OUTLIER_GATE[3])
                continue
            # Along the line only as far as its presses reach: beyond them its tilt's error
            # would be extrapolated.
            along = min(max(float(a.direction @ rel), a.span[0]), a.span[1])
            offset = rel @ a.basis
            var = (a.point_var + b.point_var) * np.eye(k) + along * along * a.tilt_cov
            scores.append(float(offset @ np.linalg.solve(var, offset)) / OUTLIER_GATE[k])
        return min(scores)


def _tilt_covs(edge_noise: np.ndarray, basis: np.ndarray, planar: bool) -> np.ndarray:
    """(m, k, k) tilt covariances of the edges in ``basis``, rad^2."""
    if planar:
        return np.asarray(edge_noise, dtype=float).reshape(-1, 1, 1) + _TILT_FLOOR
    cov = basis.T @ edge_noise @ basis
    return cov + _TILT_FLOOR * np.eye(basis.shape[1])


def _norms(s, y, t, point_var, info, a, w):
    """(m,) squared whitened norms of each press's point and tilt residuals."""
    rp = y - a - s[:, None] * w
    rt = t - w
    return np.einsum("ij,ij->i", rp, rp) / point_var, np.einsum("ij,ijk,ik->i", rt, info, rt)


def _solve(s, y, t, point_var, info, rp, rt):
    """Weighted least squares (a, w) with the points weighted by ``rp`` and the tilts by
    ``rt`` (each (m,), relative to their inverse variances)."""
    k = y.shape[1]
    p = rp / point_var
    eye = np.eye(k)
    h = np.empty((2 * k, 2 * k))
    h[:k, :k] = p.sum() * eye
    h[:k, k:] = h[k:, :k] = float(p @ s) * eye
    h[k:, k:] = float(p @ (s * s)) * eye + np.einsum("i,ijk->jk", rt, info)
    g = np.concatenate([p @ y, (p * s) @ y + np.einsum("i,ijk,ik->j", rt, info, t)])
    x = np.linalg.lstsq(h, g, rcond=None)[0]
    return x[:k], x[k:]
