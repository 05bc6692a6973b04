"""The data of a 3D joint-axis fit and what both of its models share (docs/design.md 6.2).

Conventions: world frame, metres, radians. Edge line i passes through contact point ``x_i``
with unit direction ``e_i``; the axis passes through ``p`` with unit direction ``u``. The
data are centred on the mean contact point. Both models (:mod:`.general`, :mod:`.parallel`)
work in a minimal local parameterisation: u moved by two small angles in a basis (b1, b2)
normal to it (:func:`basis`), p by two offsets in that plane (the point along the axis is a
gauge, fixed by ``p . u = 0``), then the model's own parameters.

Weights (docs/design.md 6.3, 6.5). With ``point_std`` (m) and ``edge_std`` or ``edge_cov``
(rad, rad^2) each model predicts the covariance of a measurement's residuals at the current
axis (isotropic point noise; the edge noise ``edge_cov``, isotropic about the edge when only
``edge_std`` is given) and whitens the residuals by it; the covariance of the result is then
absolute. Without stds a residual in radians is scaled by the RMS spread of the contact
points (a length) and one common noise level is estimated from the residuals. A prior
(docs/design.md 6.6) adds four whitened residuals (:class:`PriorTerm`).
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import (
    DEGENERATE_CONDITION,
    AxisEstimate,
    canonical_direction,
    stds_from_covariance,
)
from tactile_gym.estimation.robust import (
    robust_weights,
)
from tactile_gym.vec3 import cross_array, cross_rows

__all__ = [
    "VAR_FLOOR",
    "assemble",
    "axis_jacobian",
    "basis",
    "covariance_local",
    "inverse_cholesky",
    "Noise",
    "PriorTerm",
    "Problem",
]

VAR_FLOOR = 1e-24


class Noise:
    """Predicted noise of each measurement (all sign-invariant in the edge).

    ``sx``: (N,) contact-point std per axis, m; ``cov``: (N, 3, 3) edge covariance, rad^2,
    normal to the edge; ``mean_var``: (N,) its mean variance per normal direction
    (``trace / 2``); ``sq_norm``: (N,) its squared Frobenius norm, rad^4.
    """

    __slots__ = ("sx", "cov", "mean_var", "sq_norm")

    def __init__(self, sx: np.ndarray, cov: np.ndarray):
        self.sx = sx
        self.cov = cov
        self.mean_var = 0.5 * (cov[:, 0, 0] + cov[:, 1, 1] + cov[:, 2, 2])
        self.sq_norm = np.square(cov).sum(axis=(1, 2))

    def take(self, idx) -> Noise:
        return Noise(self.sx[idx], self.cov[idx])

    def worst_edge_std(self) -> np.ndarray:
        """(N,) edge std in the worst direction, rad (the root of cov's largest eigenvalue)."""
        # Eigenvalues 0, a, b with a + b = 2 mean_var and a^2 + b^2 = sq_norm.
        spread = np.sqrt(np.maximum(0.5 * self.sq_norm - self.mean_var**2, 0.0))
        return np.sqrt(self.mean_var + spread)


class PriorTerm:
    """The prior's four whitened residuals (:mod:`~tactile_gym.estimation.prior`), in the
    centred frame of a :class:`Problem`.

    Direction: the angle theta between the axis and u0 (either sign of the axis) along the
    direction of the deviation, in a basis A (2, 3) of the plane normal to the prior
    direction u0: ``(theta / sin(theta)) s A u / sigma_d``, ``s = sign(u . u0)``,
    ``sigma_d = angle_std / sqrt(2)`` (the logarithm map of the sphere at u0: the prior is
    Gaussian in the tangent plane, with ``angle_std`` the RMS of theta). Position:
    ``W B^T (I - u u^T)(pin - p)``, the offset of the prior pin from the axis line, with B
    (3, 2) a basis of the plane normal to the axis and W the inverse Cholesky factor of the
    pin covariance projected on it. B and W are those of the axis of the last
    :meth:`set_axis`: held fixed during a solve, like the measurements' whitening.
    """

    def __init__(self, prior, centre: np.ndarray):
        self.prior = prior
        self.pin = prior.pin - centre
        self.u0 = prior.direction
        self.basis = prior.normal_basis
        self.inv_sigma = math.sqrt(2.0) / prior.effective_angle_std
        self.wb = None

    def set_axis(self, u: np.ndarray) -> None:
        """Whiten the position residual for the axis direction u."""
        b = np.array(basis(u))
        chol = np.linalg.cholesky(self.prior.projected_pin_cov(b))
        self.wb = np.linalg.solve(chol, b)

    def residuals(self, u: np.ndarray, p: np.ndarray):
        """(4,) whitened residuals at the axis (u, p) and their (4, 3) Jacobians in u (for
        a perturbation normal to the unit u) and in p."""
        w = self.pin - p
        uw = float(u @ w)
        cos = float(u @ self.u0)
        sign = 1.0 if cos >= 0.0 else -1.0
        tangent = self.basis @ u
        sin = math.sqrt(float(tangent @ tangent))
        theta = math.atan2(sin, abs(cos))
        # theta / sin(theta) and its derivative in theta over sin(theta),
        # (sin - theta cos) / sin^3 -> 1/3 at theta = 0.
        if sin > 1e-4:
            ratio = theta / sin
            slope = (sin - theta * abs(cos)) / sin**3
        else:
            ratio, slope = 1.0, 1.0 / 3.0
        z = np.empty(4)
        z[0:2] = (self.inv_sigma * sign * ratio) * tangent
        z[2:4] = self.wb @ (w - uw * u)
        ju = np.empty((4, 3))
        # d theta = -s u0 . du / sin(theta).
        ju[0:2] = self.inv_sigma * (sign * ratio * self.basis - slope * np.outer(tangent, self.u0))
        # d/du of (I - u u^T) w applied to du: -(u . w) du - u (w . du).
        ju[2:4] = -uw * self.wb - np.outer(self.wb @ u, w)
        jp = np.zeros((4, 3))
        jp[2:4] = -(self.wb - np.outer(self.wb @ u, u))
        return z, ju, jp


class Problem:
    """Centred, validated data plus what the residual functions need.

    ``noise`` is a :class:`Noise`, or None when no stds were given; ``prior`` an
    :class:`~tactile_gym.estimation.prior.AxisPrior` or None (it needs ``noise``), kept as a
    :class:`PriorTerm`; its four residuals follow the measurements' in the fits.
    """

    def __init__(self, x, e, w, noise, loss, f_scale, prior=None):
        self.centre = x.mean(axis=0)
        self.prior = None if prior is None else PriorTerm(prior, self.centre)
        self.x = x - self.centre
        self.e = e
        self.sqrt_w = np.sqrt(w)
        self.noise = noise
        self.loss = loss
        spread = float(np.sqrt(np.mean(np.einsum("ij,ij->i", self.x, self.x))))
        self.length = max(spread, 1e-3)
        self.f_scale = f_scale
        self.n = x.shape[0]
        self.solution = None  # (u, p, k, c) of a successful general-case fit

    @property
    def e(self) -> np.ndarray:
        return self._e

    @e.setter
    def e(self, value: np.ndarray) -> None:
        # The design rows (x_i x e_i, e_i) follow the edges' orientation.
        self._e = value
        self.xe = _design(self.x, value)


def _design(x: np.ndarray, e: np.ndarray) -> np.ndarray:
    """(N, 6) rows ``(x_i x e_i, e_i)``: ``r1_i = row_i . (u, m_a) - k`` (Pluecker form)."""
    out = np.empty((x.shape[0], 6))
    out[:, 0:3] = cross_rows(x, e)
    out[:, 3:6] = e
    return out


def basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing u to a right-handed orthonormal basis (b1, b2, u)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = a - (a @ u) * u
    b1 /= np.linalg.norm(b1)
    return b1, cross_array(u, b1)


def inverse_cholesky(s11: np.ndarray, s12: np.ndarray, s22: np.ndarray) -> np.ndarray:
    """(N, 3) entries (w00, w10, w11) of the inverse of the lower Cholesky factor of each
    2x2 covariance ``[[s11, s12], [s12, s22]]``: ``(w00 r1, w10 r1 + w11 r2)`` is white."""
    l11 = np.sqrt(s11)
    l21 = s12 / l11
    l22 = np.sqrt(np.maximum(s22 - l21 * l21, VAR_FLOOR))
    out = np.empty((s11.shape[0], 3))
    out[:, 0] = 1.0 / l11
    out[:, 1] = -l21 / (l11 * l22)
    out[:, 2] = 1.0 / l22
    return out


def covariance_local(prob, r, jm, n_params, f_scale, m):
    """(cov, cond) of the local parameters from the residuals and Jacobian at the solution;
    the loss weights the first m (the measurements'), not the prior's."""
    rho = robust_weights(r, prob.loss, f_scale)
    rho[m:] = 1.0
    jw = jm * np.sqrt(rho)[:, None]
    col = np.linalg.norm(jw, axis=0)
    if not (col > 0).all():
        return None, math.inf
    s = np.linalg.svd(jw / col, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if not cond < DEGENERATE_CONDITION:
        return None, math.inf
    info = jw.T @ jw
    cov = np.linalg.inv(info)
    if prob.noise is None:
        dof = r.size - n_params
        if dof <= 0:
            return "nodof", cond
        cov = cov * float(np.sum(rho * r * r)) / dof
    return cov, cond


def axis_jacobian(q, u, b1, b2, n_params: int) -> np.ndarray:
    """Jacobian of (point, direction, distance) w.r.t. the local parameters, whose first four
    are the direction angles (alpha, beta) and the point offsets (s1, s2); the distance row
    is left for the caller."""
    g = np.zeros((7, n_params))
    g[0:3, 0] = -(q @ b1) * u - (q @ u) * b1
    g[0:3, 1] = -(q @ b2) * u - (q @ u) * b2
    g[0:3, 2] = b1
    g[0:3, 3] = b2
    g[3:6, 0] = b1
    g[3:6, 1] = b2
    return g


def assemble(prob, u, q, d, cov_local, g, cond, rms, method) -> AxisEstimate:
    direction, sign = canonical_direction(u)
    point = q - (q @ u) * u
    if isinstance(cov_local, str):
        cov = None
        pos_std = ang_std = math.inf
    else:
        g = g.copy()
        g[3:6] *= sign
        cov = g @ cov_local @ g.T
        cov = 0.5 * (cov + cov.T)
        pos_std, ang_std = stds_from_covariance(cov, direction)
    return AxisEstimate(
        point=point,
        direction=direction,
        distance=float(d),
        covariance=cov,
        position_std=pos_std,
        angle_std=ang_std,
        residual_rms=rms,
        n_used=prob.n,
        degenerate=False,
        condition_number=cond,
        method=method,
    )
