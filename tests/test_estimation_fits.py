"""Joint-axis fits: exact recovery, the paper's Monte Carlo and calibrated covariances.

The ground truth comes from ``estimation_cases``: an edge line of a link rotating about a
known axis, with the contact point sliding along the edge between measurements.
"""

from __future__ import annotations

import dataclasses
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
    nees_3d,
    planar_nees,
    position_error,
    tilted_case,
)

from tactile_gym.estimation import (
    AxisEstimate,
    JointAxisEstimator,
    axis_error,
    fit_axis_3d,
    fit_axis_planar,
    fit_axis_simple,
)


def test_planar_exact_recovery() -> None:
    pts, eds = make_planar(np.random.default_rng(0), n=5, sigma_x=0.0, sigma_e=0.0)
    est = fit_axis_planar(pts, eds)
    assert not est.degenerate
    np.testing.assert_allclose(est.point, PAPER_AXIS, atol=1e-9)
    assert est.distance == pytest.approx(0.01, abs=1e-9)
    np.testing.assert_array_equal(est.direction, [0.0, 0.0, 1.0])


def _assert_same_estimate(a: AxisEstimate, b: AxisEstimate, rtol: float = 1e-9) -> None:
    """Every field of two estimates agrees (arrays and floats to rtol, the rest exactly)."""
    for field in dataclasses.fields(AxisEstimate):
        va, vb = getattr(a, field.name), getattr(b, field.name)
        if isinstance(va, (str, bool, int)) or va is None:
            assert va == vb, field.name
        else:
            scale = np.max(np.abs(vb)) if np.size(vb) else 0.0
            np.testing.assert_allclose(va, vb, rtol=rtol, atol=1e-12 * scale, err_msg=field.name)


@pytest.mark.parametrize("weighted", [False, True])
def test_planar_numpy_and_loop_paths_agree(weighted: bool, monkeypatch) -> None:
    from tactile_gym.estimation import planar

    pts, eds = make_planar(np.random.default_rng(1), n=20)
    w = np.random.default_rng(2).uniform(0.5, 2.0, 20) if weighted else None
    fast = planar.planar_fit(pts, eds, w)
    monkeypatch.setattr(planar, "NUMPY_MIN_N", 10_000)
    loop = planar.planar_fit(pts, eds, w)
    _assert_same_estimate(loop, fast)


@pytest.mark.parametrize("n", [5, 20])
def test_planar_residual_rms_matches_an_independent_residual(n: int) -> None:
    """residual_rms and the unweighted covariance from residuals computed here (eq. 16)."""
    pts, eds = make_planar(np.random.default_rng(3), n=n)
    est = fit_axis_planar(pts, eds)
    p, q = est.point[:2]
    # Signed distance from the axis to each (consistently oriented) edge line minus d.
    signed = eds[:, 1] * (pts[:, 0] - p) - eds[:, 0] * (pts[:, 1] - q)
    res = signed - math.copysign(est.distance, np.mean(signed))
    assert est.residual_rms == pytest.approx(np.sqrt(np.mean(res**2)), rel=1e-9)
    a = np.column_stack([eds[:, 1], -eds[:, 0], -np.ones(n)])
    cov = np.linalg.inv(a.T @ a) * (res @ res) / (n - 3)
    np.testing.assert_allclose(est.covariance[:2, :2], cov[:2, :2], rtol=1e-9)
    assert est.position_std == pytest.approx(math.sqrt(cov[0, 0] + cov[1, 1]), rel=1e-9)


def test_planar_edge_sign_is_resolved_by_continuity() -> None:
    pts, eds = make_planar(np.random.default_rng(0), n=5, sigma_x=0.0, sigma_e=0.0)
    flipped = eds * np.array([1, -1, 1, -1, -1])[:, None]
    est = fit_axis_planar(pts, flipped)
    np.testing.assert_allclose(est.point, PAPER_AXIS, atol=1e-9)


@pytest.mark.parametrize(
    "axis_dir",
    [[0, 0, 1], [0.3, -0.2, 1.0], [1.0, 0.5, 0.2], [0, 1, 0], [-1, 1, 1]],
)
@pytest.mark.parametrize("edge_tilt", [0.0, 0.5])
def test_3d_exact_recovery_tilted_axes(axis_dir: list[float], edge_tilt: float) -> None:
    u = np.array(axis_dir, float)
    u /= np.linalg.norm(u)
    p = np.array([0.017, 0.105, 0.03])
    e0 = np.cross(u, [0.3, 0.9, 0.1])
    e0 = e0 / np.linalg.norm(e0) + edge_tilt * u  # not perpendicular when tilted
    pts, eds = make_edges_3d(np.random.default_rng(0), p, u, e0, 0.02)
    est = fit_axis_3d(pts, eds)
    assert est.method == "3d" and not est.degenerate
    pos, ang = axis_error(est, p, u)
    assert pos < 1e-9 and ang < 1e-9
    assert est.distance == pytest.approx(0.02, abs=1e-9)
    assert abs(est.point @ est.direction) < 1e-12
    assert est.direction[np.argmax(np.abs(est.direction))] > 0


def test_3d_exact_recovery_edges_through_the_axis() -> None:
    u = np.array([0.0, 0.0, 1.0])
    p = np.array([0.2, -0.1, 0.0])
    pts, eds = make_edges_3d(np.random.default_rng(0), p, u, np.array([1.0, 0.0, 0]), 0.0)
    est = fit_axis_3d(pts, eds)
    pos, ang = axis_error(est, p, u)
    assert pos < 1e-9 and ang < 1e-9 and est.distance < 1e-9


def test_3d_parallel_case_exact() -> None:
    """A door: the free edge is parallel to the vertical hinge."""
    u = np.array([0.0, 0.0, 1.0])
    p = np.array([0.1, 0.2, 0.0])
    pts, eds = make_edges_3d(np.random.default_rng(0), p, u, u, 0.03, slide=0.005)
    est = fit_axis_3d(pts, eds)
    assert est.method == "3d-parallel"
    pos, ang = axis_error(est, p, u)
    assert pos < 1e-9 and ang < 1e-9
    assert est.distance == pytest.approx(0.03, abs=1e-9)


def test_3d_parallel_case_noisy() -> None:
    rng = np.random.default_rng(3)
    u = np.array([0.0, 0.0, 1.0])
    p = np.array([0.1, 0.2, 0.0])
    pts, eds = make_edges_3d(rng, p, u, u, 0.3, n=10, slide=0.01, sigma_x=SIGMA_X, sigma_e=SIGMA_E)
    est = fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E)
    assert est.method == "3d-parallel"
    pos, ang = axis_error(est, p, u)
    assert pos < 5 * est.position_std + 1e-3 and ang < math.radians(2)


def test_paper_monte_carlo_sliding_contact() -> None:
    """Table I: with sliding the proposed method stays accurate, the simple one does not."""
    rng = np.random.default_rng(2010)
    prop, simple = [], []
    for _ in range(500):
        pts, eds = make_planar(rng)
        prop.append(position_error(fit_axis_planar(pts, eds)))
        simple.append(position_error(fit_axis_simple(pts)))
    assert np.median(prop) <= 5e-3
    assert np.median(simple) >= 15e-3


def test_paper_monte_carlo_no_sliding_simple_is_good() -> None:
    rng = np.random.default_rng(7)
    errs = [
        position_error(fit_axis_simple(make_planar(rng, slide=0.0, start=0.06)[0]))
        for _ in range(500)
    ]
    assert np.median(errs) <= 5e-3


def test_planar_nees_is_calibrated() -> None:
    """Position NEES (p, q: 2 dof) of the weighted fit averages 2 within 30 %."""
    rng = np.random.default_rng(11)
    nees = []
    for _ in range(1000):
        pts, eds = make_planar(rng)
        est = fit_axis_planar(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E)
        err = est.point[:2] - PAPER_AXIS[:2]
        nees.append(err @ np.linalg.solve(est.covariance[:2, :2], err))
    assert abs(np.mean(nees) - 2.0) <= 0.3 * 2.0


def test_online_planar_matches_paper_bound_and_nees() -> None:
    rng = np.random.default_rng(5)
    errs, nees = [], []
    for _ in range(300):
        pts, eds = make_planar(rng)
        est = JointAxisEstimator("planar")
        for x, e in zip(pts, eds, strict=True):
            est.add(x, e, SIGMA_X, SIGMA_E)
        result = est.estimate()
        errs.append(position_error(result))
        err = result.point[:2] - PAPER_AXIS[:2]
        nees.append(err @ np.linalg.solve(result.covariance[:2, :2], err))
    assert np.median(errs) <= 5e-3
    assert abs(np.mean(nees) - 2.0) <= 0.3 * 2.0


def test_3d_nees_is_calibrated() -> None:
    """NEES of (point perpendicular to the axis, direction): 4 dof, mean within 30 %."""
    rng = np.random.default_rng(12)
    nees = []
    for _ in range(200):
        p, u, pts, eds = tilted_case(rng)
        nees.append(nees_3d(fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_std=SIGMA_E), p, u))
    np.testing.assert_allclose(np.mean(nees, axis=0), [4.0, 2.0, 2.0], rtol=0.3)


def make_plate(
    rng: np.random.Generator,
    geometry: str,
    face: str,
    sigma_in: float,
    sigma_out: float,
    n: int = 12,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """An edge of a plate that turns 90 degrees about an axis in (or beside) its plane.

    ``geometry``: ``"door"`` (vertical axis, horizontal edge) or ``"tilted"`` (tilted axis,
    edge oblique to it). ``face``: the probed face, ``"side"`` (the plate's broad face, normal
    u x e) or ``"top"`` (the narrow face along the edge, normal e x (u x e): a door's top).
    The edge turns by ``sigma_in`` (rad, RMS) about the face's normal n, within the face, and
    by ``sigma_out`` out of it; ``edge_cov = sigma_in^2 g g^T + sigma_out^2 n n^T`` with
    ``g = n x e``, as the sensing builds it.

    Returns:
        ``(axis_point, axis_dir, points (N, 3), edges (N, 3), edge_cov (N, 3, 3))``.
    """
    if geometry == "door":
        p, u, e0 = np.array([0.4, 0.1, 0.0]), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0, 0])
    else:
        p = np.array([0.017, 0.105, 0.03])
        u = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
        e0 = np.cross(u, [0.3, 0.9, 0.1])
        e0 = e0 / np.linalg.norm(e0) + 0.3 * u
    pts, eds = make_edges_3d(rng, p, u, e0, 0.02, n=n, slide=0.01, sigma_x=SIGMA_X)
    normal = np.cross(u, eds)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    if face == "top":
        normal = np.cross(eds, normal)
    g = np.cross(normal, eds)
    noisy = eds + rng.normal(0, sigma_in, (n, 1)) * g + rng.normal(0, sigma_out, (n, 1)) * normal
    noisy /= np.linalg.norm(noisy, axis=1)[:, None]
    cov = sigma_in**2 * g[:, :, None] * g[:, None, :]
    cov += sigma_out**2 * normal[:, :, None] * normal[:, None, :]
    return p, u, pts, noisy, cov


def _edge_std_of(cov: np.ndarray) -> np.ndarray:
    """The total RMS edge angle error of each covariance, rad."""
    return np.sqrt(np.trace(cov, axis1=1, axis2=2))


@pytest.mark.parametrize(
    "geometry, face, sigma_in_deg, sigma_out_deg",
    [("door", "top", 2.0, 0.2), ("tilted", "side", 1.0, 0.1)],
)
def test_3d_nees_with_anisotropic_edge_noise(
    geometry: str, face: str, sigma_in_deg: float, sigma_out_deg: float
) -> None:
    """With edge_cov the mean NEES (4 dof; position and direction 2 dof each) is within
    30 %; the isotropic model of the same total error fails that check."""
    rng = np.random.default_rng(31)
    aniso, iso = [], []
    for _ in range(100):
        p, u, pts, eds, cov = make_plate(
            rng, geometry, face, math.radians(sigma_in_deg), math.radians(sigma_out_deg)
        )
        aniso.append(nees_3d(fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_cov=cov), p, u))
        est = fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_std=_edge_std_of(cov))
        iso.append(nees_3d(est, p, u))
    aniso, iso = np.mean(aniso, axis=0), np.mean(iso, axis=0)
    assert calibrated(aniso, [4.0, 2.0, 2.0]), aniso
    assert not calibrated(iso, [4.0, 2.0, 2.0]), iso


@pytest.mark.parametrize("face", ["top", "side"])
def test_planar_nees_with_anisotropic_edge_noise(face: str) -> None:
    """Door-like plate, vertical axis: only the edge's rotation about z matters to the
    planar fit, all of the in-face noise for the top face, little for the side face."""
    rng = np.random.default_rng(32)
    aniso, iso = [], []
    for _ in range(200):
        p, u, pts, eds, cov = make_plate(rng, "door", face, math.radians(2), math.radians(0.2))
        for out, kw in ((aniso, {"edge_cov": cov}), (iso, {"edge_std": _edge_std_of(cov)})):
            out.append(planar_nees(fit_axis_planar(pts, eds, point_std=SIGMA_X, **kw), p))
    assert calibrated(np.mean(aniso), [2.0]), np.mean(aniso)
    assert not calibrated(np.mean(iso), [2.0]), np.mean(iso)


def test_online_estimators_use_edge_cov() -> None:
    """Both modes of JointAxisEstimator with edge_cov: calibrated position NEES."""
    rng = np.random.default_rng(33)
    nees = {"planar": [], "3d": []}
    for trial in range(60):
        p, u, pts, eds, cov = make_plate(rng, "door", "top", math.radians(2), math.radians(0.2))
        for mode, out in nees.items():
            if mode == "3d" and trial >= 20:
                continue
            online = JointAxisEstimator(mode, loss="linear")
            for x, e, c in zip(pts, eds, cov, strict=True):
                online.add(x, e, SIGMA_X, math.sqrt(np.trace(c)), edge_cov=c)
            est = online.estimate()
            out.append(planar_nees(est, p) if mode == "planar" else nees_3d(est, p, u)[1])
    assert calibrated(np.mean(nees["planar"]), [2.0]), np.mean(nees["planar"])
    # 20 streams only (3d fits are slow): a looser bound.
    assert 1.0 < np.mean(nees["3d"]) < 3.5, np.mean(nees["3d"])


@pytest.mark.parametrize("fit", [fit_axis_3d, fit_axis_planar])
def test_isotropic_edge_cov_is_edge_std(fit) -> None:
    """edge_std means edge_cov = (edge_std^2 / 2) (I - e e^T), for either edge sign."""
    rng = np.random.default_rng(34)
    p, u, pts, eds, _ = make_plate(rng, "door", "top", math.radians(2), math.radians(0.2))
    std = rng.uniform(0.5, 2.0, len(eds)) * math.radians(1.0)
    cov = 0.5 * std[:, None, None] ** 2 * (np.eye(3) - eds[:, :, None] * eds[:, None, :])
    by_std = fit(pts, eds, point_std=SIGMA_X, edge_std=std)
    signs = rng.choice([-1.0, 1.0], size=(len(eds), 1))
    by_cov = fit(pts, eds * signs, point_std=SIGMA_X, edge_cov=cov)
    _assert_same_estimate(by_cov, by_std, rtol=1e-7)


def test_3d_keeps_edge_signs_where_either_sign_fits() -> None:
    """Edges normal to the axis whose lines pass through it fit either sign alike (c = k = 0).

    Noise must not pick their signs: a flipped edge shrinks the position covariance far
    below what the data support. The 3D fit's covariance stays the planar fit's.
    """
    rng = np.random.default_rng(6)
    sigma_e = math.radians(1.0)
    ratios = []
    for _ in range(40):
        pts, eds = make_edges_3d(
            rng,
            PAPER_AXIS,
            np.array([0.0, 0, 1]),
            np.array([1.0, 0, 0]),
            0.0,
            n=12,
            slide=0.01,
            sigma_x=SIGMA_X,
            sigma_e=sigma_e,
        )
        full = fit_axis_3d(pts, eds, point_std=SIGMA_X, edge_std=sigma_e)
        planar = fit_axis_planar(pts, eds, point_std=SIGMA_X, edge_std=sigma_e)
        ratios.append(np.trace(full.covariance[:2, :2]) / np.trace(planar.covariance[:2, :2]))
    assert 0.8 < min(ratios) and max(ratios) < 1.25
