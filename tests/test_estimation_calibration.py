"""The calibrated covariance (``JointAxisEstimator(covariance="calibrated")``) against synthetic
truth: presses at a few spots of a link turning about a known axis, each spot pressed several
times. Every press's error is the spot's bias (a contact-point offset and an edge error that
all presses at the spot share) plus white edge noise, drawn here from the model the estimator
states (``tactile_gym.estimation.calibration``), so the truth is known and the NEES must come
out at its degrees of freedom; the independent covariance, which takes the repeated presses
for independent ones, must not.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from estimation_cases import PAPER_AXIS, rot

from tactile_gym.estimation import (
    AxisEstimate,
    AxisPrior,
    JointAxisEstimator,
    axis_error,
    axis_nees,
    fit_axis_planar,
)
from tactile_gym.estimation.calibration import CALIBRATED, spot_counts
from tactile_gym.estimation.fit3d import Fit3D, _total_cost
from tactile_gym.estimation.interface import Measurements
from tactile_gym.estimation.problem import Noise

EDGE_STD = math.radians(2.0)  # rad, the handed total RMS edge error (isotropic)
DISTANCE = 0.01  # m, edge line to axis
# Monte Carlo trials; the mean of a chi-square with k dof over TRIALS has the std
# sqrt(2 k / TRIALS): 0.1 for k = 2.
TRIALS = 400
# Allowed |mean NEES - k| for k = 2: 3.5 standard deviations of the mean.
NEES_BOUND = 0.35


def _normal_basis(e: np.ndarray) -> np.ndarray:
    """(2, 3) orthonormal rows normal to the unit e."""
    return np.linalg.svd(e[None, :])[2][1:]


def _spot_presses(rng, axis_point, axis_dir, edge0, angles, levers, repeats, point_std):
    """Points and edges of ``repeats`` presses at each spot: the spot's shared bias (point
    offset of ``point_scatter`` per axis, edge error of ``edge_model_std``) plus white edge
    noise (the handed isotropic noise and the model's excess), as the calibrated model
    says."""
    m = CALIBRATED
    shared_std = m.edge_model_std / math.sqrt(2.0)  # per normal direction
    white_std = math.sqrt(0.5 * EDGE_STD**2 + m.edge_excess_std**2)
    scatter = min(point_std, m.point_scatter)
    normal = np.cross(axis_dir, edge0)
    normal /= np.linalg.norm(normal)
    points, edges = [], []
    for angle, lever in zip(angles, levers, strict=True):
        r = rot(axis_dir, angle)
        e = r @ edge0
        x = axis_point + r @ (DISTANCE * normal + lever * edge0)
        b = _normal_basis(e)
        point = x + rng.normal(0.0, scatter, 3)
        bias = rng.normal(0.0, shared_std, 2) @ b
        for _ in range(repeats):
            points.append(point)
            noisy = e + bias + rng.normal(0.0, white_std, 2) @ b
            edges.append(noisy / np.linalg.norm(noisy))
    return np.array(points), np.array(edges)


def _estimate(mode, covariance, points, edges, point_std, loss="linear") -> AxisEstimate:
    est = JointAxisEstimator(mode=mode, loss=loss, covariance=covariance)
    for x, e in zip(points, edges, strict=True):
        est.add(x, e, point_std, EDGE_STD)
    return est.estimate()


def _planar_case(rng, repeats: int):
    angles = np.radians(np.linspace(0.0, 120.0, 5))
    levers = np.full(5, 0.03)
    return _spot_presses(
        rng,
        PAPER_AXIS,
        np.array([0.0, 0.0, 1.0]),
        np.array([1.0, 0.0, 0.0]),
        angles,
        levers,
        repeats,
        CALIBRATED.point_scatter,
    )


def test_planar_round_trip_nees_is_its_dof_and_independent_is_over_confident() -> None:
    """Eight presses at each of five spots: the calibrated position NEES is 2 within the
    Monte Carlo bound; the independent one, which takes each spot's bias as averaged away,
    is far beyond it."""
    rng = np.random.default_rng(3)
    nees = {"calibrated": [], "independent": []}
    for _ in range(TRIALS):
        points, edges = _planar_case(rng, repeats=8)
        for covariance, values in nees.items():
            est = _estimate("planar", covariance, points, edges, CALIBRATED.point_scatter)
            values.append(axis_nees(est, PAPER_AXIS, [0, 0, 1])[1])
    calibrated = float(np.mean(nees["calibrated"]))
    independent = float(np.mean(nees["independent"]))
    print(f"planar NEES (2 dof): calibrated {calibrated:.2f}, independent {independent:.2f}")
    assert abs(calibrated - 2.0) < NEES_BOUND
    assert independent > 2.0 + 5 * NEES_BOUND


def test_3d_round_trip_nees_and_stds_at_the_pin() -> None:
    """A tilted axis, four presses at each of six spots, a prior: position (at the pin) and
    direction NEES are 2 each within the bound, and so are the reported stds: mean squared
    error over mean squared std is 1 within the same relative bound."""
    rng = np.random.default_rng(5)
    u = np.array([0.3, -0.2, 1.0])
    u /= np.linalg.norm(u)
    pin = np.array([0.017, 0.105, 0.03])
    edge0 = np.cross(u, [0.3, 0.9, 0.1])
    edge0 /= np.linalg.norm(edge0)
    angles = np.radians(np.linspace(0.0, 120.0, 6))
    levers = 0.03 + 0.005 * np.arange(6)
    prior = AxisPrior(pin, np.diag([25e-6, 25e-6, 0.0]), u, math.radians(10.0))
    pos, ang, err2, std2 = [], [], [], []
    for _ in range(TRIALS):
        # The truth drawn from the prior, so that the prior is honest too.
        true_pin = pin + np.r_[rng.normal(0.0, 5e-3, 2), 0.0]
        tilt = rng.normal(0.0, prior.angle_std / math.sqrt(2.0), 2) @ prior.normal_basis
        true_u = (u + tilt) / np.linalg.norm(u + tilt)
        points, edges = _spot_presses(
            rng, true_pin, true_u, edge0, angles, levers, 4, CALIBRATED.point_scatter
        )
        est = JointAxisEstimator(mode="3d", loss="linear", prior=prior, covariance="calibrated")
        for x, e in zip(points, edges, strict=True):
            est.add(x, e, CALIBRATED.point_scatter, EDGE_STD)
        fit = est.estimate()
        _, p, d = axis_nees(fit, true_pin, true_u, reference_point=true_pin)
        pos.append(p)
        ang.append(d)
        position, angle = axis_error(fit, true_pin, true_u, true_pin)
        err2.append((position, angle))
        std2.append((fit.position_std, fit.angle_std))
    pos_nees, ang_nees = float(np.mean(pos)), float(np.mean(ang))
    ratios = np.mean(np.square(err2), axis=0) / np.mean(np.square(std2), axis=0)
    print(f"3D NEES: position {pos_nees:.2f}, direction {ang_nees:.2f}; std ratios {ratios}")
    assert abs(pos_nees - 2.0) < NEES_BOUND
    assert abs(ang_nees - 2.0) < NEES_BOUND
    assert np.all(np.abs(ratios - 1.0) < NEES_BOUND / 2.0)


@pytest.mark.parametrize("repeats", [1, 4, 16, 64])
def test_repeated_presses_follow_the_spot_mean_not_one_over_sqrt_n(repeats: int) -> None:
    """Exact presses, each spot pressed ``repeats`` times: the calibrated covariance is that
    of one press per spot with the variance of a spot's mean under the shared-bias model,
    ``(own - shared) / n + shared`` (eq. 16's residual: point plus lever times the edge's
    turn about z), fitted independently by ``fit_axis_planar``. The independent covariance
    shrinks as 1 / n."""
    angles = np.radians([0.0, 40.0, 80.0, 120.0])
    exact = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(4)])
    normal = np.column_stack([-np.sin(angles), np.cos(angles), np.zeros(4)])
    lever = np.array([0.03, 0.04, 0.05, 0.06])
    points = PAPER_AXIS + lever[:, None] * exact + DISTANCE * normal
    point_std = 1e-3  # handed; the calibrated model uses point_scatter below it
    many_points = np.repeat(points, repeats, axis=0)
    many_edges = np.repeat(exact, repeats, axis=0)
    m = CALIBRATED
    point_var = m.point_scatter**2
    shared_z = 0.5 * m.edge_model_std**2
    own_z = 0.5 * EDGE_STD**2 + shared_z + m.edge_excess_std**2
    spot_var = point_var + lever**2 * ((own_z - shared_z) / repeats + shared_z)
    expected = fit_axis_planar(points, exact, 1.0 / spot_var).covariance[:2, :2]
    calibrated = _estimate("planar", "calibrated", many_points, many_edges, point_std)
    np.testing.assert_allclose(calibrated.covariance[:2, :2], expected, rtol=1e-9, atol=0.0)
    single = _estimate("planar", "independent", points, exact, point_std)
    independent = _estimate("planar", "independent", many_points, many_edges, point_std)
    np.testing.assert_allclose(
        independent.covariance[:2, :2], single.covariance[:2, :2] / repeats, rtol=1e-9
    )
    if repeats == 64:
        alone = _estimate("planar", "calibrated", points, exact, point_std)
        # 1/8 under independence; the shared parts keep more than a third of it here.
        assert calibrated.position_std > 0.35 * alone.position_std


def test_spot_counts_count_presses_within_the_spot_radius() -> None:
    r = CALIBRATED.spot_radius
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [10 * r, 0.0, 0.0], [r, 0.0, 0.0]])
    counts = spot_counts(points, r)
    np.testing.assert_allclose(
        counts[:3], [2.0 + math.exp(-0.5), 2.0 + math.exp(-0.5), 1.0], atol=1e-12
    )
    assert counts[3] == pytest.approx(1.0 + 2.0 * math.exp(-0.5))


def test_presses_at_distinct_spots_are_unchanged_by_the_sharing() -> None:
    """One press per spot: the calibrated fit is the independent fit of the same presses
    with the model's point and edge noise handed to it directly."""
    rng = np.random.default_rng(9)
    points, edges = _planar_case(rng, repeats=1)
    calibrated = _estimate("planar", "calibrated", points, edges, 1e-3)
    m = CALIBRATED
    # The model's own noise of a press: the point's scatter, the handed isotropic edge
    # error plus the noise-free error and the excess in both normal directions.
    total = math.sqrt(EDGE_STD**2 + m.edge_model_std**2 + 2.0 * m.edge_excess_std**2)
    est = JointAxisEstimator(mode="planar", loss="linear")
    for x, e in zip(points, edges, strict=True):
        est.add(x, e, m.point_scatter, total)
    direct = est.estimate()
    np.testing.assert_allclose(calibrated.point, direct.point, atol=1e-12)
    np.testing.assert_allclose(calibrated.covariance, direct.covariance, rtol=1e-9, atol=1e-18)


def test_covariance_must_be_known() -> None:
    with pytest.raises(ValueError, match="covariance must be one of"):
        JointAxisEstimator(covariance="honest")


def test_nees_at_a_reference_point_carries_the_direction_error() -> None:
    """Closed form: an estimate exact at its point whose direction is off by delta about x;
    at a reference h along the axis the position errs h delta, with variance
    ``p^2 + h^2 a^2`` per axis (``p``: point std, ``a``: direction std per axis)."""
    p_std, a_std, delta, h = 1e-3, 0.01, 0.02, 0.1
    cov = np.zeros((7, 7))
    cov[0, 0] = cov[1, 1] = p_std**2
    cov[3, 3] = cov[4, 4] = a_std**2
    est = AxisEstimate(
        point=np.zeros(3),
        direction=np.array([0.0, 0.0, 1.0]),
        distance=0.01,
        covariance=cov,
        position_std=math.sqrt(2) * p_std,
        angle_std=math.sqrt(2) * a_std,
        residual_rms=0.0,
        n_used=8,
        degenerate=False,
        condition_number=1.0,
        method="3d",
    )
    true_u = np.array([0.0, math.sin(delta), math.cos(delta)])
    joint, position, direction = axis_nees(est, np.zeros(3), true_u)
    assert position == pytest.approx(0.0, abs=1e-20)
    ref = h * true_u
    joint_ref, position_ref, direction_ref = axis_nees(est, np.zeros(3), true_u, ref)
    along = h * math.cos(delta)  # the reference's plane normal to the estimate
    expected = (along * math.tan(delta)) ** 2 / (p_std**2 + along**2 * a_std**2)
    assert position_ref == pytest.approx(expected, rel=1e-9)
    assert direction_ref == pytest.approx(direction, rel=1e-12)
    # The joint NEES is the same anywhere, to first order in the errors.
    assert joint_ref == pytest.approx(joint, rel=1e-6)


def test_nees_of_a_planar_estimate_is_its_position_nees() -> None:
    rng = np.random.default_rng(1)
    points, edges = _planar_case(rng, repeats=1)
    est = fit_axis_planar(points, edges, point_std=1e-3, edge_std=EDGE_STD)
    joint, position, direction = axis_nees(est, PAPER_AXIS, [0, 0, 1], reference_point=PAPER_AXIS)
    err = est.point[:2] - PAPER_AXIS[:2]
    assert position == pytest.approx(float(err @ np.linalg.solve(est.covariance[:2, :2], err)))
    assert direction == 0.0
    assert joint == position


def _replay_recorded():
    """The recorded presses of ``tests/data/consensus_local_minimum.npz``, one by one,
    through the calibrated estimator and through a single-start 3D fit refitted on the same
    calibrated measurements (``Fit3D.refit``, as before the link angles): the two last
    estimates, the estimator, the single-start fit and the true (pin, direction)."""
    with np.load(Path(__file__).parent / "data" / "consensus_local_minimum.npz") as data:
        rec = dict(data)
    prior = AxisPrior(
        rec["prior_pin"], rec["prior_pin_cov"], rec["prior_direction"], rec["prior_angle_std"]
    )
    est = JointAxisEstimator(mode="3d", loss="soft_l1", prior=prior, covariance="calibrated")
    plain = Fit3D(est.loss, prior)
    for x, e, sx, se, cov in zip(
        rec["point"], rec["edge"], rec["point_std"], rec["edge_std"], rec["edge_cov"], strict=True
    ):
        est.add(x, e, sx, se, edge_cov=cov)
        fit = est.estimate()
        plain_fit = plain.refit(_calibrated_data(est))
    return fit, plain_fit, est, plain, (rec["axis_point"], rec["axis_direction"])


def _calibrated_data(est: JointAxisEstimator) -> Measurements:
    """The estimator's presses with the calibrated model's noise, as its fits take them."""
    n = est.n_measurements
    return est._calibrated(
        Measurements(est.points, est.edges, est._point_std[:n], est._edge_noise[:n])
    )


def test_a_full_fit_keeps_the_refined_last_solution_when_it_explains_more() -> None:
    """Eight presses recorded from the scripted policy (HingeProbe3DPrimitive-v2, seed
    200835): at the seventh and eighth a single-start full fit's consensus settles 15 mm
    off with a position std of 1.7 mm. The calibrated estimator refines every start (the
    closed form, the prior's axis, its last solution) and keeps the solution that explains
    the presses better: 1.2 mm off, within its predicted error."""
    guarded, plain, est, plain_fit, (pin, u) = _replay_recorded()
    position, _ = axis_error(guarded, pin, u, pin)
    assert position < 2.0 * guarded.position_std
    assert axis_error(plain, pin, u, pin)[0] > 5.0 * plain.position_std
    data = _calibrated_data(est)
    noise = Noise(data.point_std, data.edge_noise)
    guarded_cost, plain_cost = (
        _total_cost(data.points, data.edges, noise, "soft_l1", fit.state, est.prior)
        for fit in (est._fit, plain_fit)
    )
    assert guarded_cost < plain_cost
