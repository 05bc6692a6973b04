"""Joint-axis fits with robust losses: wild measurements, edge signs and the 3D model choice.

The ground truth comes from ``estimation_cases``: an edge line of a link rotating about a
known axis, with the contact point sliding along the edge between measurements.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from estimation_cases import (
    PAPER_AXIS,
    SIGMA_E,
    SIGMA_X,
    calibrated,
    make_edges_3d,
    make_planar,
    perturb_edge,
    planar_nees,
    position_error,
    rot,
    tilted_case,
)

from tactile_gym.estimation import (
    AxisPrior,
    JointAxisEstimator,
    axis_error,
    fit_axis_3d,
    fit_axis_planar,
)


@pytest.mark.parametrize("with_stds", [True, False])
def test_robust_3d_fit_survives_wild_edges(with_stds: bool) -> None:
    """With stds, and without (the consensus then ranks by least median of squares)."""
    rng = np.random.default_rng(21)
    robust_pos, linear_pos = [], []
    for _ in range(30):
        p, u, pts, eds = tilted_case(rng, n=16)
        wild = rng.choice(16, size=4, replace=False)
        eds[wild] = rng.normal(size=(4, 3))
        kw = dict(point_std=SIGMA_X, edge_std=SIGMA_E) if with_stds else {}
        robust_pos.append(axis_error(fit_axis_3d(pts, eds, loss="soft_l1", **kw), p, u)[0])
        linear_pos.append(axis_error(fit_axis_3d(pts, eds, loss="linear", **kw), p, u)[0])
    assert np.median(robust_pos) <= 5e-3
    assert np.median(robust_pos) < 0.5 * np.median(linear_pos)


def _spoil(
    rng: np.random.Generator, pts: np.ndarray, eds: np.ndarray, k: int, kind: str
) -> tuple[np.ndarray, np.ndarray]:
    """Copies with k wild measurements: random edges, points displaced by 2 cm (std per
    axis), or (``"both"``) alternately one and the other."""
    pts, eds = pts.copy(), eds.copy()
    for j, i in enumerate(rng.choice(len(pts), size=k, replace=False)):
        if kind == "edges" or (kind == "both" and j % 2 == 0):
            angle = rng.uniform(0.0, 2.0 * math.pi)
            eds[i] = [math.cos(angle), math.sin(angle)]
        else:
            pts[i] += rng.normal(0.0, 0.02, 2)
    return pts, eds


@pytest.mark.parametrize(
    "kind, with_stds", [("edges", True), ("points", True), ("both", True), ("both", False)]
)
def test_robust_planar_fit_survives_wild_measurements(kind: str, with_stds: bool) -> None:
    """25 % wild measurements in the paper's setting (16 over 90 degrees). Without stds
    the fit cannot tell the lever-dependent noise of each measurement and does worse."""
    rng = np.random.default_rng(41)
    kw = {"point_std": SIGMA_X, "edge_std": SIGMA_E} if with_stds else {}
    robust, linear = [], []
    for _ in range(60):
        pts, eds = _spoil(rng, *make_planar(rng, n=16, slide=0.005), 4, kind)
        robust.append(position_error(fit_axis_planar(pts, eds, loss="soft_l1", **kw)))
        linear.append(position_error(fit_axis_planar(pts, eds, **kw)))
    assert np.median(robust) <= (6e-3 if with_stds else 10e-3)
    assert np.median(linear) >= 2.0 * np.median(robust)


def test_robust_planar_fit_is_the_linear_fit_on_clean_data() -> None:
    """Same answer within noise (a fraction of the std), and a calibrated covariance."""
    rng = np.random.default_rng(42)
    shift, nees, used = [], [], []
    for _ in range(100):
        pts, eds = make_planar(rng, n=16, slide=0.005)
        linear = fit_axis_planar(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E)
        robust = fit_axis_planar(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E, loss="soft_l1")
        shift.append(np.linalg.norm(robust.point - linear.point) / linear.position_std)
        nees.append(planar_nees(robust, PAPER_AXIS))
        used.append(robust.n_used)
    # The consensus drops a valid measurement now and then (the 99 % quantile).
    assert np.mean(used) >= 15.5
    assert np.median(shift) <= 0.2 and np.percentile(shift, 95) <= 1.0
    assert calibrated(np.mean(nees), [2.0]), np.mean(nees)


def test_online_planar_uses_the_robust_loss() -> None:
    """JointAxisEstimator("planar", loss=...) with 25 % wild measurements."""
    rng = np.random.default_rng(43)
    errors = {"linear": [], "soft_l1": []}
    for _ in range(30):
        pts, eds = _spoil(rng, *make_planar(rng, n=16, slide=0.005), 4, "both")
        for loss, out in errors.items():
            online = JointAxisEstimator("planar", loss=loss)
            for x, e in zip(pts, eds, strict=True):
                online.add(x, e, SIGMA_X, SIGMA_E)
            out.append(position_error(online.estimate()))
    assert np.median(errors["soft_l1"]) <= 7e-3
    assert np.median(errors["linear"]) >= 2.0 * np.median(errors["soft_l1"])


def _clustered_case(rng: np.random.Generator, at_deg: float = 120.0, n_at: int = 25):
    """10 measurements of a tilted axis spread over 120 degrees, then ``n_at`` more at one
    link angle (a probe held at a joint limit): most edges parallel to each other, none
    to the axis."""
    p, u, pts, eds = tilted_case(rng, n=10)
    e0 = np.cross(u, [0.3, 0.9, 0.1])
    e0 /= np.linalg.norm(e0)
    foot = p + 0.02 * np.cross(u, e0) / np.linalg.norm(np.cross(u, e0))
    r = rot(u, math.radians(at_deg))
    more = [p + r @ (foot - p + (0.04 + 0.001 * i) * e0) for i in range(n_at)]
    more = np.array(more) + rng.normal(0, SIGMA_X, (n_at, 3))
    more_e = np.array([perturb_edge(rng, r @ e0, SIGMA_E) for _ in range(n_at)])
    return p, u, np.vstack([pts, more]), np.vstack([eds, more_e])


def _door_free_edge(rng: np.random.Generator, n: int = 12):
    """A door's free vertical edge, 12 cm from a vertical hinge, turning 90 degrees: every
    edge parallel to the axis (eq. 9-10)."""
    p, u = np.array([0.0, 0.1, 0.05]), np.array([0.0, 0.0, 1.0])
    pts, eds = make_edges_3d(
        rng, p, u, u, 0.12, n=n, start=-0.03, slide=0.004, sigma_x=SIGMA_X, sigma_e=SIGMA_E
    )
    return p, u, pts, eds


def _median_3d_errors(make_case, seed: int, wild: int, loss: str, method: str):
    """Median (position, angle) errors of fit_axis_3d over 8 cases, each with ``wild``
    random edges, asserting the model the fit chose."""
    rng = np.random.default_rng(seed)
    errors = []
    for _ in range(8):
        p, u, pts, eds = make_case(rng)
        if wild:
            idx = rng.choice(len(pts), size=wild, replace=False)
            eds[idx] = rng.normal(size=(wild, 3))
        est = fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E, loss=loss)
        assert est.method == method
        errors.append(axis_error(est, p, u))
    return np.median(errors, axis=0)


@pytest.mark.parametrize("wild", [0, 3])
def test_3d_clustered_measurements_keep_the_general_model(wild: int) -> None:
    """25 of 35 edges parallel to each other (two thirds, the parallel model's trigger)
    but not to the axis: the general model is kept, and the estimate is as good as the
    spread measurements allow (measured: median 1.2 mm, 0.5 deg; with 3 wild edges 1.4 mm,
    0.8 deg). Before the models were compared, and the consensus counted the measurements
    of one edge line once, the parallel model was chosen (median 1.5 m, 90 deg) or, with
    wild edges, a consensus of the cluster and two others (54 mm, 61 deg)."""
    pos, ang = _median_3d_errors(_clustered_case, 51, wild, "soft_l1", "3d")
    assert pos < 3e-3 and ang < math.radians(2), (pos, np.degrees(ang))


def test_online_3d_keeps_the_general_model_through_a_cluster() -> None:
    rng = np.random.default_rng(52)
    p, u, pts, eds = _clustered_case(rng)
    online = JointAxisEstimator("3d")
    for x, e in zip(pts, eds, strict=True):
        online.add(x, e, SIGMA_X, SIGMA_E)
        assert online.estimate() is None or online.estimate().method == "3d"
    pos, ang = axis_error(online.estimate(), p, u)
    assert pos < 3e-3 and ang < math.radians(2)


@pytest.mark.parametrize("loss, wild", [("linear", 0), ("soft_l1", 0), ("soft_l1", 3)])
def test_3d_parallel_edges_choose_the_parallel_model(loss: str, wild: int) -> None:
    """Genuinely parallel edges (a door's free edge), also with 3 wild edges in 12."""
    pos, ang = _median_3d_errors(_door_free_edge, 53, wild, loss, "3d-parallel")
    assert pos < 4e-3 and ang < math.radians(1), (pos, np.degrees(ang))


def test_online_3d_parallel_edges() -> None:
    """A noisy edge more than 3 edge stds from the first no longer blocks the estimate."""
    rng = np.random.default_rng(54)
    for _ in range(4):
        p, u, pts, eds = _door_free_edge(rng)
        online = JointAxisEstimator("3d")
        for x, e in zip(pts, eds, strict=True):
            online.add(x, e, SIGMA_X, SIGMA_E)
        est = online.estimate()
        assert est is not None and est.method == "3d-parallel"
        assert axis_error(est, p, u)[0] < 4.0 * est.position_std


def test_robust_planar_fit_survives_a_first_triple_that_explains_nothing() -> None:
    """Measurements a learning policy made (captured from a training run): six presses near
    one edge and one of the link's end (the fifth). The consensus's first triple explained none
    of them, and its trial count divided by log(1 - 0)."""
    points = np.array(
        [[0.06278, 0.09212, 0.00777], [0.08075, 0.11786, 0.00761], [0.09032, 0.12026, 0.00733],
         [0.09938, 0.12347, 0.00744], [0.10183, 0.1252, 0.00709], [0.1, 0.1232, 0.00707],
         [0.09854, 0.12199, 0.00664]]
    )  # fmt: skip
    edges = np.array(
        [[0.97915, -0.20312, 0.0], [0.96414, 0.2654, 0.0], [0.94998, 0.31232, 0.0],
         [0.90543, 0.42449, 0.0], [0.34337, 0.9392, 0.0], [0.89357, 0.44892, 0.0],
         [0.95637, 0.29215, 0.0]]
    )  # fmt: skip
    edge_std = np.sqrt(2.0) * np.radians([1.69, 1.147, 0.841, 1.342, 0.838, 0.809, 0.787])
    prior = AxisPrior(
        pin=np.array([0.01681, 0.10512, 0.004]),
        pin_cov=np.diag([5.93e-3**2, 5.80e-3**2, 1e-10]),
        direction=np.array([0.0, 0.0, 1.0]),
        angle_std=0.0,
    )
    est = fit_axis_planar(
        points, edges, point_std=0.001, edge_std=edge_std, loss="soft_l1", prior=prior
    )
    assert est.degenerate or np.all(np.isfinite(est.point))
