"""Edge-line measurements for the joint-type models: labels, whitened residuals, evidence.

World frame, metres, radians (docs/design.md 6.10). A measurement is a contact point ``x``
(per-axis std ``point_std``, m) on an edge line of the link and the line's unit direction
``e``, physically oriented (``e = n x f``, docs/design.md 7.3), with its covariance
``edge_cov`` (rad^2, normal to ``e``). Two labels go with it: the edge line of the link it was
taken on (``line``) and the link configuration it was taken at (``config``; presses with the
same label were taken without the link moving in between).

A model predicts, for every measurement, its edge line at its configuration: a unit direction
``eps`` and a point ``a``. The residuals of one measurement are

* position, 3 entries and 2 degrees of freedom: ``(I - eps eps^T)(x - a) / point_std``, the
  contact's offset from the predicted line normal to it. Where the contact lies along the
  edge is free in every model (the contact slides along the edge between presses);
* direction, 3 entries and 2 degrees of freedom: the two components of ``eps`` in a basis
  normal to ``e``, whitened by ``edge_cov``, then a chord entry ``(eps . e - 1) / s`` (``s``
  the edge's RMS angle per normal direction). The chord entry is of second order near ``e``
  (it adds about ``angle^4 / 4 s^2``) but tells an edge from its reverse, which the
  projection alone does not.

So each measurement carries 4 degrees of freedom in every model, and the models' likelihoods
are densities of the same data.

:func:`laplace_evidence` turns residuals and their Jacobian at a fit into the Laplace
approximation of the evidence (docs/design.md 6.10).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation.axis import as_edge_covs, isotropic_edge_covs
from tactile_gym.estimation.problem import basis

__all__ = [
    "EDGE_STD_FLOOR",
    "POINT_STD_FLOOR",
    "Evidence",
    "LineData",
    "laplace_evidence",
    "line_data",
    "line_residuals",
    "line_rows",
]

# Floors on the noise the residuals are whitened by: exact data (a std of 0) would be an
# infinite weight. Far below any real noise, far above rounding.
POINT_STD_FLOOR = 1e-6  # m
EDGE_STD_FLOOR = 1e-5  # rad, per normal direction

DOF_PER_MEASUREMENT = 4


@dataclass(frozen=True, eq=False)
class LineData:
    """Validated measurements with their whitening and labels.

    Attributes:
        x: (N, 3) contact points, world frame, m.
        e: (N, 3) unit edge directions as measured (physically oriented), world frame.
        sx: (N,) contact-point std per axis, floored at ``POINT_STD_FLOOR``, m.
        wd: (N, 3, 3) direction whitening: ``wd[i] @ eps - wc[i]`` is the direction residual.
        wc: (N, 3) its constant part (``(0, 0, 1 / s_i)``).
        edge_std: (N,) RMS angle of each edge per normal direction, floored, rad.
        line: (N,) index of each measurement's edge line, 0 .. n_lines - 1 in order of
            first appearance.
        config: (N,) index of each measurement's configuration, 0 .. n_configs - 1 likewise.
        reference: (n_configs,) True for the first configuration of each connected group of
            lines and configurations: its motion is the zero of that group's motions.
        log_norm: the log of the Gaussian normalisation of the 4 degrees of freedom of every
            measurement, summed: the log-likelihood is ``log_norm - chi2 / 2``.
        point_std: (N,) the contact-point stds as given, m.
        edge_total_std: (N,) the edges' total RMS angle errors as given, rad.
        edge_cov: (N, 3, 3) the edge covariances, rad^2.
    """

    x: np.ndarray
    e: np.ndarray
    sx: np.ndarray
    wd: np.ndarray
    wc: np.ndarray
    edge_std: np.ndarray
    line: np.ndarray
    config: np.ndarray
    reference: np.ndarray
    log_norm: float
    point_std: np.ndarray
    edge_total_std: np.ndarray
    edge_cov: np.ndarray

    @property
    def n(self) -> int:
        """Number of measurements."""
        return self.x.shape[0]

    @property
    def n_lines(self) -> int:
        """Number of distinct edge lines."""
        return int(self.line.max()) + 1 if self.n else 0

    @property
    def n_configs(self) -> int:
        """Number of distinct configurations."""
        return self.reference.shape[0]

    @property
    def free_configs(self) -> np.ndarray:
        """Indices of the configurations whose motion is a free parameter."""
        return np.flatnonzero(~self.reference)


def _dense_labels(labels: np.ndarray) -> np.ndarray:
    """Labels renumbered 0, 1, ... in order of first appearance."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    return order[inverse]


def _references(line: np.ndarray, config: np.ndarray, n_configs: int) -> np.ndarray:
    """The first configuration of each connected group of lines and configurations (a
    measurement joins its line and its configuration): motions are relative to it, and
    groups that share no configuration share no motion."""
    n_lines = int(line.max()) + 1
    parent = list(range(n_lines + n_configs))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for j, k in zip(line.tolist(), config.tolist()):
        a, b = find(j), find(n_lines + k)
        if a != b:
            parent[max(a, b)] = min(a, b)
    reference = np.zeros(n_configs, dtype=bool)
    seen = set()
    for k in range(n_configs):
        root = find(n_lines + k)
        if root not in seen:
            seen.add(root)
            reference[k] = True
    return reference


def line_data(
    points: np.ndarray,
    edges: np.ndarray,
    point_std: np.ndarray,
    edge_std: np.ndarray,
    edge_cov: np.ndarray,
    lines: np.ndarray,
    configs: np.ndarray,
) -> LineData:
    """:class:`LineData` of already validated arrays.

    Args:
        points: (N, 3) contact points, m.
        edges: (N, 3) edge directions, any length > 0.
        point_std: (N,) contact-point stds, m, >= 0.
        edge_std: (N,) the edges' total RMS angle errors, rad, >= 0.
        edge_cov: (N, 3, 3) edge covariances, rad^2 (normal to the edges; see
            :func:`edge_covariances`).
        lines: (N,) integer line labels.
        configs: (N,) integer configuration labels.
    """
    x = np.asarray(points, dtype=float)
    e = np.asarray(edges, dtype=float)
    e = e / np.linalg.norm(e, axis=1)[:, None]
    n = x.shape[0]
    point_std = np.asarray(point_std, dtype=float)
    sx = np.maximum(point_std, POINT_STD_FLOOR)
    wd = np.zeros((n, 3, 3))
    wc = np.zeros((n, 3))
    per_normal = np.zeros(n)
    log_norm = 0.0
    floor = EDGE_STD_FLOOR**2
    for i in range(n):
        b = np.array(basis(e[i]))  # (2, 3) rows normal to e
        s2 = b @ edge_cov[i] @ b.T + floor * np.eye(2)
        chol = np.linalg.cholesky(0.5 * (s2 + s2.T))
        wd[i, :2] = np.linalg.solve(chol, b)
        s = math.sqrt(0.5 * (s2[0, 0] + s2[1, 1]))
        wd[i, 2] = e[i] / s
        wc[i, 2] = 1.0 / s
        per_normal[i] = s
        # The 2 position dofs (variance sx^2 each) and the 2 direction dofs (s2).
        log_norm -= math.log(2.0 * math.pi * sx[i] ** 2) + math.log(
            2.0 * math.pi * chol[0, 0] * chol[1, 1]
        )
    line = _dense_labels(np.asarray(lines))
    config = _dense_labels(np.asarray(configs))
    n_configs = int(config.max()) + 1 if n else 0
    reference = _references(line, config, n_configs) if n else np.zeros(0, dtype=bool)
    return LineData(
        x,
        e,
        sx,
        wd,
        wc,
        per_normal,
        line,
        config,
        reference,
        log_norm,
        point_std,
        np.asarray(edge_std, dtype=float),
        np.asarray(edge_cov, dtype=float),
    )


def edge_covariances(
    edges: np.ndarray, edge_std: np.ndarray, edge_cov: np.ndarray | None
) -> np.ndarray:
    """(N, 3, 3) edge covariances: ``edge_cov`` validated, or isotropic from ``edge_std``."""
    unit = edges / np.linalg.norm(edges, axis=1)[:, None]
    if edge_cov is None:
        return isotropic_edge_covs(unit, edge_std)
    return as_edge_covs(edge_cov, unit)


def line_residuals(data: LineData, eps: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(N, 6) whitened residuals of the predicted lines: position (3), direction (3).

    Args:
        data: the measurements.
        eps: (N, 3) predicted unit line direction at each measurement.
        a: (N, 3) a point of each predicted line, m.
    """
    w = data.x - a
    along = np.einsum("ij,ij->i", eps, w)
    out = np.empty((data.n, 6))
    out[:, :3] = (w - along[:, None] * eps) / data.sx[:, None]
    out[:, 3:] = np.einsum("ijk,ik->ij", data.wd, eps) - data.wc
    return out


def line_rows(
    data: LineData, eps: np.ndarray, a: np.ndarray, deps: np.ndarray, da: np.ndarray
) -> np.ndarray:
    """(N, 6, K) derivatives of :func:`line_residuals` for K perturbations of the lines.

    Args:
        data: the measurements.
        eps, a: (N, 3) the predicted lines.
        deps, da: (N, K, 3) the change of each predicted direction and point per unit of
            each of K parameters.
    """
    w = data.x - a
    along = np.einsum("ij,ij->i", eps, w)
    dal = np.einsum("ikj,ij->ik", deps, w)  # deps . w
    ead = np.einsum("ikj,ij->ik", da, eps)  # da . eps
    dpos = -(
        deps * along[:, None, None]
        + eps[:, None, :] * dal[:, :, None]
        + da
        - eps[:, None, :] * ead[:, :, None]
    )
    out = np.empty((data.n, 6, deps.shape[1]))
    out[:, :3] = np.transpose(dpos / data.sx[:, None, None], (0, 2, 1))
    out[:, 3:] = np.einsum("ijk,ilk->ijl", data.wd, deps)
    return out


@dataclass(frozen=True)
class Evidence:
    """The Laplace approximation at a fit (docs/design.md 6.10).

    Attributes:
        log_evidence: ``ln p(data | model)``.
        log_likelihood: ``ln p(data | model, parameters)`` at the quadratic model's maximum.
        chi2: the whitened residuals' sum of squares there (the measurements' only).
        covariance: (P, P) posterior covariance of the local parameters.
        step: (P,) the quadratic model's step from the fit to its maximum.
        effective_params: ``trace(H^-1 J^T J)``: how many parameters the measurements
            determine, each counted by the share of its information they give.
    """

    log_evidence: float
    log_likelihood: float
    chi2: float
    covariance: np.ndarray
    step: np.ndarray
    effective_params: float


def laplace_evidence(
    data: LineData,
    r: np.ndarray,
    jac: np.ndarray,
    prior_precision: np.ndarray,
    log_prior: float,
    prior_r: np.ndarray | None = None,
    prior_jac: np.ndarray | None = None,
) -> Evidence:
    """Laplace approximation of a model's evidence from its residuals at a fit.

    The log posterior is expanded to second order about the fit (Gauss-Newton Hessian
    ``H = J^T J + Jp^T Jp + diag(prior_precision)``) and integrated:
    ``ln Z = max(-chi2 / 2 - |rp|^2 / 2) + log_prior + (P / 2) ln 2 pi - ln det(H) / 2``
    plus the data's normalisation. The maximum is the quadratic model's, so a fit that is
    not quite at the model's optimum (the revolute axis comes from the axis fits, which use
    part of the information) is not charged for it.

    Args:
        data: the measurements (for the normalisation).
        r: (M,) whitened residuals of the measurements.
        jac: (M, P) their Jacobian in the local parameters.
        prior_precision: (P,) the curvature of the flat priors: a uniform prior of density
            ``q`` per dimension counts as the Gaussian of the same peak, precision
            ``2 pi q^2``; then a parameter the data do not determine integrates to 1.
        log_prior: the log prior density at the fit: the flat priors' log densities plus
            the Gaussian priors' normalisations (their quadratic part is ``prior_r``).
        prior_r: optional whitened residuals of Gaussian priors.
        prior_jac: their Jacobian.
    """
    p = jac.shape[1]
    h = jac.T @ jac
    info = h.copy()
    grad = jac.T @ r
    prior_sq = 0.0
    if prior_r is not None:
        info += prior_jac.T @ prior_jac
        grad += prior_jac.T @ prior_r
        prior_sq = float(prior_r @ prior_r)
    info[np.diag_indices(p)] += prior_precision
    # Cholesky of the diagonally scaled matrix: positions in m and angles in rad differ by
    # orders of magnitude in information.
    scale = np.sqrt(np.diag(info))
    chol = np.linalg.cholesky(info / scale[:, None] / scale[None, :])
    logdet = 2.0 * float(np.sum(np.log(np.diag(chol)))) + 2.0 * float(np.sum(np.log(scale)))
    inv_l = np.linalg.inv(chol)
    cov = (inv_l.T @ inv_l) / scale[:, None] / scale[None, :]
    step = -(cov @ grad)
    r_new = r + jac @ step
    chi2 = float(r_new @ r_new)
    gain = -0.5 * float(grad @ step)  # >= 0: the quadratic model's rise to its maximum
    log_post = -0.5 * float(r @ r) - 0.5 * prior_sq + gain
    log_evidence = (
        data.log_norm + log_post + log_prior + 0.5 * p * math.log(2.0 * math.pi) - 0.5 * logdet
    )
    effective = float(np.sum(cov * h))
    return Evidence(log_evidence, data.log_norm - 0.5 * chi2, chi2, cov, step, effective)
