"""The fit interface (fit, update, state) and the one robust-loss function.

The ground truth is generated here: a link edge turning about a known axis, the contact
sliding along it, with noise drawn at the stds the fits are told.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tactile_gym.estimation import LOSSES, AxisPrior, JointAxisEstimator, axis_error
from tactile_gym.estimation.fit3d import Fit3D
from tactile_gym.estimation.fits import PlanarFit
from tactile_gym.estimation.interface import FULL_REFIT_GROWTH, AxisFit, Measurements
from tactile_gym.estimation.robust import loss_cost, robust_loss, robust_weights
from tactile_gym.spatial import orient_edges

SIGMA_X = 1e-3  # m
SIGMA_E = math.radians(1.0)  # rad
PIN = np.array([0.02, 0.1, 0.03])  # m


def _rot(u: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _stream(rng: np.random.Generator, axis: np.ndarray, n: int):
    """(points, edges) of an edge 20 mm from the axis, turning 150 deg, contact sliding."""
    u = axis / np.linalg.norm(axis)
    e0 = np.cross(u, [0.3, 0.9, 0.1]) if abs(u[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    e0 = e0 - (e0 @ u) * u if abs(u[2]) > 0.99 else e0
    e0 /= np.linalg.norm(e0)
    foot = PIN + 0.02 * np.cross(u, e0)
    pts, eds = [], []
    for i, a in enumerate(np.linspace(0.0, math.radians(150), n)):
        r = _rot(u, a)
        pts.append(PIN + r @ (foot - PIN + (0.03 + 0.004 * i) * e0) + rng.normal(0, SIGMA_X, 3))
        e = r @ e0
        # Isotropic edge noise of total RMS angle SIGMA_E.
        b = np.linalg.svd(e[None])[2][1:]
        e = e + rng.normal(0, SIGMA_E / math.sqrt(2.0), 2) @ b
        eds.append(e / np.linalg.norm(e))
    return np.array(pts), orient_edges(np.array(eds))


def _measurements(fit: AxisFit, pts: np.ndarray, eds: np.ndarray, planar: bool) -> Measurements:
    """The measurements as the fit sees them (planar: z parts of the edges dropped)."""
    noise = [fit.edge_noise(e, 3, SIGMA_E, None) for e in eds]
    if planar:
        eds = eds * [1.0, 1.0, 0.0]
        eds = eds / np.linalg.norm(eds, axis=1)[:, None]
    return Measurements(pts, eds, np.full(len(pts), SIGMA_X), np.array(noise))


CASES = [
    (PlanarFit, np.array([0.0, 0.0, 1.0]), True),
    (Fit3D, np.array([0.3, -0.2, 1.0]), False),
]


@pytest.mark.parametrize("fit_cls, axis, planar", CASES)
@pytest.mark.parametrize("loss", ["linear", "soft_l1"])
def test_fit_recovers_the_axis_it_was_generated_from(fit_cls, axis, planar, loss) -> None:
    """Round trip: measurements of a known axis are fitted back, within 4 stated stds."""
    u = axis / np.linalg.norm(axis)
    errors = []
    for seed in range(5):
        pts, eds = _stream(np.random.default_rng(seed), axis, 12)
        fit = fit_cls(loss)
        assert isinstance(fit, AxisFit) and fit.state is None
        est = fit.fit(_measurements(fit, pts, eds, planar))
        assert not est.degenerate and fit.state is not None
        pos, ang = axis_error(est, PIN, u)
        errors.append((pos, ang))
        assert pos < 4.0 * est.position_std + 1e-4
        assert ang <= 4.0 * est.angle_std + 1e-9
    assert np.median([p for p, _ in errors]) < 3e-3


@pytest.mark.parametrize("fit_cls, axis, planar", CASES)
@pytest.mark.parametrize("loss", ["linear", "soft_l1"])
def test_update_continues_the_fit_as_measurements_are_appended(fit_cls, axis, planar, loss):
    """An update needs a state; with one it reaches the full fit's minimum."""
    pts, eds = _stream(np.random.default_rng(7), axis, 14)
    fit = fit_cls(loss)
    first = _measurements(fit, pts[:10], eds[:10], planar)
    assert fit.update(first) is None  # no state yet
    fit.fit(first)
    data = _measurements(fit, pts[:11], eds[:11], planar)
    assert 11 < 10 * FULL_REFIT_GROWTH <= 14
    warm = fit.update(data)
    assert warm is not None
    full = fit_cls(loss).fit(data)
    # Same data, same minimum: far within the estimate's own std.
    assert np.linalg.norm(warm.point - full.point) < 0.05 * full.position_std
    np.testing.assert_allclose(warm.direction, full.direction, atol=0.05 * full.angle_std + 1e-12)
    # Grown past FULL_REFIT_GROWTH: robust fits ask for a full fit (consensus again).
    grown = _measurements(fit, pts, eds, planar)
    if loss != "linear":
        assert fit.update(grown) is None
    assert not fit.refit(grown).degenerate


@pytest.mark.parametrize("fit_cls, planar", [(PlanarFit, True), (Fit3D, False)])
def test_fit_of_no_measurement_with_a_prior_is_the_prior(fit_cls, planar) -> None:
    prior = AxisPrior(PIN, 1e-4 * np.eye(3), [0.0, 0.0, 1.0], math.radians(10.0))
    fit = fit_cls("soft_l1", prior)
    empty = Measurements(np.empty((0, 3)), np.empty((0, 3)), np.empty(0), np.empty((0, 3, 3)))
    est = fit.fit(empty)
    assert est.method == "prior"
    np.testing.assert_allclose(est.point, prior.estimate(planar=planar).point)


def test_the_estimator_is_its_fit_of_what_it_was_given() -> None:
    """JointAxisEstimator's estimate is Fit3D's fit of its points and oriented edges."""
    pts, eds = _stream(np.random.default_rng(3), np.array([0.3, -0.2, 1.0]), 10)
    online = JointAxisEstimator("3d")
    for x, e in zip(pts, eds, strict=True):
        online.add(x, e, SIGMA_X, SIGMA_E)
    est = online.estimate()
    fit = Fit3D("soft_l1")
    batch = fit.fit(_measurements(fit, online.points, online.edges, False))
    assert np.linalg.norm(est.point - batch.point) < 0.05 * batch.position_std


# ------------------------------------------------------------------------- robust loss

S = np.array([0.0, 1e-3, 0.3, 0.9, 1.5, 4.0, 30.0, 500.0])


@pytest.mark.parametrize("loss", LOSSES)
def test_robust_loss_derivatives_are_those_of_rho(loss: str) -> None:
    """rho' and rho'' match central differences of rho (away from Huber's kink at s = 1)."""
    s = S[S > 0]
    h = 1e-6 * np.maximum(s, 1e-3)
    rho, d1, d2 = robust_loss(s, loss)
    up, down = robust_loss(s + h, loss), robust_loss(s - h, loss)
    np.testing.assert_allclose(d1, (up[0] - down[0]) / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(d2, (up[1] - down[1]) / (2 * h), rtol=1e-5, atol=1e-9)
    # rho(0) = 0 and rho'(0) = 1: every loss is least squares near zero.
    zero = robust_loss(np.zeros(1), loss)
    assert zero[0][0] == 0.0 and zero[1][0] == 1.0


@pytest.mark.parametrize("loss", LOSSES)
@pytest.mark.parametrize("f_scale", [0.5, 2.0])
def test_weights_are_the_cost_gradient_over_the_residual(loss: str, f_scale: float) -> None:
    """IRLS weight w(z) = (d cost / dz) / z = rho'(s); the Newton weight is d2 cost / dz2
    where it is positive (soft_l1 everywhere), floored at 0.05 rho' for Huber and Cauchy."""
    z = f_scale * np.sqrt(S[S > 0]) * np.where(np.arange((S > 0).sum()) % 2, -1.0, 1.0)
    w, newton = robust_weights(z, loss, f_scale, curvature=True)
    h = 1e-6 * np.abs(z)
    grad = np.array(
        [
            (
                loss_cost(np.array([zi + hi]), loss, f_scale)
                - loss_cost(np.array([zi - hi]), loss, f_scale)
            )
            / (2 * hi)
            for zi, hi in zip(z, h, strict=True)
        ]
    )
    np.testing.assert_allclose(w, grad / z, rtol=1e-6)
    # Second differences need a wider step than first ones to stay above rounding.
    h2 = 1e-4 * np.abs(z)
    curv = np.array(
        [
            (
                loss_cost(np.array([zi + hi]), loss, f_scale)
                - 2 * loss_cost(np.array([zi]), loss, f_scale)
                + loss_cost(np.array([zi - hi]), loss, f_scale)
            )
            / hi**2
            for zi, hi in zip(z, h2, strict=True)
        ]
    )
    s = (z / f_scale) ** 2
    exact = loss == "soft_l1" or loss == "linear"
    check = np.ones_like(s, bool) if exact else (curv > 0.05 * w * 1.01) & (np.abs(s - 1) > 1e-3)
    np.testing.assert_allclose(newton[check], curv[check], rtol=1e-4)
    if not exact:
        assert (newton >= 0.05 * w * (1 - 1e-12)).all()
