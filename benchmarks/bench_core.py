"""Speed of the core numpy/scipy paths: contact sensing, axis fits, online update.

Run: ``python benchmarks/bench_core.py``. Prints a markdown table of microseconds per call
(median over repeats, each repeat averaging several calls via timeit) with the targets, then
a second table: the 3D fit's own Levenberg-Marquardt against ``scipy.optimize.least_squares``
on the same whitened residuals, from the same starts, timed in the same run (the reason the
own solver is kept, docs/design.md 6.2).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
import timeit
from pathlib import Path

import numpy as np

# Measure the checkout this file is in, not whichever one the environment has installed
# (git worktrees share one virtual environment).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scipy.optimize import least_squares  # noqa: E402

from tactile_gym.estimation import (  # noqa: E402
    AxisPrior,
    JointAxisEstimator,
    fit_axis_3d,
    fit_axis_planar,
)
from tactile_gym.estimation.axis import isotropic_edge_covs  # noqa: E402
from tactile_gym.estimation.general import (  # noqa: E402
    linear_init,
    linearise,
    refine_general,
    solve_general,
    whiten,
    whitening_scale_only,
)
from tactile_gym.estimation.problem import Noise, Problem  # noqa: E402
from tactile_gym.estimation.robust import split_loss  # noqa: E402
from tactile_gym.spatial import orient_edges  # noqa: E402

SIGMA_X = 1e-3  # m
SIGMA_E = math.radians(1.0)  # rad, total RMS angle error of an edge
REPEATS = 15
# Priors like an env's reset distribution: the pin within ~1 cm, the direction known
# (planar) or within 15 deg (3d).
PLANAR_PRIOR = AxisPrior([0.017, 0.105, 0.0], np.diag([1e-4, 1e-4, 0.0]), [0, 0, 1], 0.0)
TILTED_PRIOR = AxisPrior([0.017, 0.105, 0.03], 1e-4 * np.eye(3), [0.3, -0.2, 1], math.radians(15))


def _rot(u: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _measurements(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A link edge turning 120 degrees about a tilted axis, contact sliding along it."""
    u = np.array([0.3, -0.2, 1.0])
    u /= np.linalg.norm(u)
    p = np.array([0.017, 0.105, 0.03])
    e0 = np.cross(u, [0.3, 0.9, 0.1])
    e0 /= np.linalg.norm(e0)
    foot = p + 0.02 * np.cross(u, e0)
    pts, eds = [], []
    for i, a in enumerate(np.linspace(0, math.radians(120), n)):
        r = _rot(u, a)
        pts.append(p + r @ (foot - p + (0.03 + 0.005 * i) * e0) + rng.normal(0, SIGMA_X, 3))
        # The part along the edge vanishes in the normalisation: SIGMA_E in all.
        e = r @ e0 + rng.normal(0, SIGMA_E / math.sqrt(2.0), 3)
        eds.append(e / np.linalg.norm(e))
    return np.array(pts), np.array(eds)


def _planar(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The paper's setting: axis (17, 105) mm, 90 degrees, contact sliding 20 mm a step.

    2D points and edges: the edge error is all in the plane.
    """
    phi = np.linspace(0, math.pi / 2, n)
    t = 0.03 + 0.02 * np.arange(n) * 4 / n
    x = 0.017 + t * np.cos(phi) - 0.01 * np.sin(phi) + rng.normal(0, SIGMA_X, n)
    y = 0.105 + t * np.sin(phi) + 0.01 * np.cos(phi) + rng.normal(0, SIGMA_X, n)
    a = phi + rng.normal(0, SIGMA_E, n)
    return np.column_stack([x, y]), np.column_stack([np.cos(a), np.sin(a)])


def _per_call_us(fn, number: int) -> float:
    times = timeit.repeat(fn, number=number, repeat=REPEATS)
    return statistics.median(times) / number * 1e6


def _online_us(
    mode: str,
    pts: np.ndarray,
    eds: np.ndarray,
    prefill: int,
    loss: str = "soft_l1",
    edge_cov: bool = False,
    prior: AxisPrior | None = None,
) -> float:
    """Median time of one add + estimate on an estimator already holding ``prefill``.

    ``edge_cov``: pass each edge's isotropic covariance explicitly (the validation cost).
    ``prior``: the estimator's prior.
    """
    covs = [
        0.5 * SIGMA_E**2 * (np.eye(3) - np.outer(e, e)) / float(e @ e)
        for e in np.pad(eds, ((0, 0), (0, 3 - eds.shape[1])))
    ]
    samples = []
    for r in range(REPEATS * 20):
        est = JointAxisEstimator(mode, loss=loss, prior=prior)
        for x, e in zip(pts[:prefill], eds[:prefill], strict=True):
            est.add(x, e, SIGMA_X, SIGMA_E)
        est.estimate()
        i = prefill + r % (len(pts) - prefill)
        kw = {"edge_cov": covs[i]} if edge_cov else {}
        t0 = time.perf_counter()
        est.add(pts[i], eds[i], SIGMA_X, SIGMA_E, **kw)
        est.estimate()
        samples.append(time.perf_counter() - t0)
    return statistics.median(samples) * 1e6


def _stream_us(pts: np.ndarray, eds: np.ndarray, first: int) -> tuple[float, float]:
    """(mean, worst) time of one 3d add + estimate over a stream, from ``first`` on.

    The 3d estimator warm-starts most updates from its previous solution and redoes the
    full consensus fit now and then (growth by 25 %, an outlier), so its cost per update is
    reported amortised over the stream; the worst single update is reported alongside.
    Median over repeats of the stream.
    """
    means, worst = [], []
    for _ in range(REPEATS // 3):
        est = JointAxisEstimator("3d")
        times = []
        for i, (x, e) in enumerate(zip(pts, eds, strict=True)):
            t0 = time.perf_counter()
            est.add(x, e, SIGMA_X, SIGMA_E)
            est.estimate()
            if i >= first:
                times.append(time.perf_counter() - t0)
        means.append(statistics.fmean(times))
        worst.append(max(times))
    return statistics.median(means) * 1e6, statistics.median(worst) * 1e6


def _problem(pts: np.ndarray, eds: np.ndarray, loss: str) -> Problem:
    """The 3D fit's problem of measurements with the benchmark's stds, edges oriented."""
    e = orient_edges(eds)
    noise = Noise(np.full(len(pts), SIGMA_X), isotropic_edge_covs(e, np.full(len(e), SIGMA_E)))
    return Problem(pts, e, np.ones(len(pts)), noise, loss, None)


def _solve_scipy(prob: Problem, wh: np.ndarray, u, p, k, c, f_scale: float):
    """The general model solved by scipy's least_squares on the residuals and Jacobian of
    ``linearise``, over fixed-basis parameters about the start: u turned by (a, b) in the
    start's normal basis, the line's point moved by (s1, s2) in it, (k, c) shifted."""
    b1, b2 = linearise(prob, wh, u, p, k, c, jacobian=False)[2:]
    q0 = p - (p @ u) * u

    def unpack(t):
        v = u + t[0] * b1 + t[1] * b2
        nv = math.sqrt(float(v @ v))
        return v / nv, nv, q0 + t[2] * b1 + t[3] * b2, k + t[4], c + t[5]

    def fun(t):
        un, _, q, kn, cn = unpack(t)
        return linearise(prob, wh, un, q, kn, cn, jacobian=False)[0]

    def jac(t):
        un, nv, q, kn, cn = unpack(t)
        _, jm, c1, c2 = linearise(prob, wh, un, q, kn, cn)
        # The local angles and offsets of linearise are in the basis (c1, c2) of un.
        proj = (np.eye(3) - np.outer(un, un)) / nv
        chain = np.zeros((6, 6))
        for j, b in enumerate((b1, b2)):
            du = proj @ b
            chain[0, j], chain[1, j] = c1 @ du, c2 @ du
            chain[2, 2 + j], chain[3, 2 + j] = c1 @ b, c2 @ b
        chain[4, 4] = chain[5, 5] = 1.0
        return jm @ chain

    t0 = np.zeros(6)
    if prob.loss == "linear":
        res = least_squares(fun, t0, jac=jac, method="lm", x_scale="jac", xtol=1e-10, ftol=1e-10)
    else:
        res = least_squares(
            fun,
            t0,
            jac=jac,
            method="trf",
            # A prior's residuals (after the 2N of the measurements) count by least squares.
            loss=prob.loss if prob.prior is None else split_loss(prob.loss, 2 * prob.n),
            f_scale=f_scale,
            x_scale="jac",
            xtol=1e-10,
            ftol=1e-10,
        )
    un, _, q, kn, cn = unpack(res.x)
    return un, q - (q @ un) * un, kn, cn, res.nfev


def _axis_gap(a, b) -> tuple[float, float]:
    """(distance of b's line from a's point, m; angle between the directions, rad)."""
    (ua, pa), (ub, pb) = a[:2], b[:2]
    w = pa - pb
    off = np.linalg.norm(w - (w @ ub) * ub)
    return float(off), math.atan2(float(np.linalg.norm(np.cross(ua, ub))), abs(float(ua @ ub)))


def solver_rows(
    rng: np.random.Generator, n: int = 16
) -> list[tuple[str, float, float, float, float]]:
    """(case, own us, scipy us, position gap m, angle gap rad) of the general model's solver.

    Cases: a cold solve (the closed-form start, as after a consensus) and a warm one (the
    previous solution on N - 1 measurements as the start, as in an online update).
    """
    pts, eds = _measurements(rng, n)
    out = []
    for loss in ("linear", "soft_l1"):
        f_scale = 2.0
        prev = _problem(pts[:-1], eds[:-1], loss)
        init = linear_init(prev, whitening_scale_only(prev))
        u, p, k, c, _ = refine_general(prev, *init, whiten(prev, *init[:2]))
        prob = _problem(pts, eds, loss)
        cold = linear_init(prob, whitening_scale_only(prob))
        shift = prev.centre - prob.centre
        p_warm = p + shift - ((p + shift) @ u) * u
        for case, start in (("cold", cold), ("warm", (u, p_warm, k, c))):
            wh = whiten(prob, *start[:2])
            own = solve_general(prob, wh, *start, f_scale)
            sci = _solve_scipy(prob, wh, *start, f_scale)
            args = (prob, wh, *start, f_scale)
            own_us = _per_call_us(lambda a=args: solve_general(*a), 20)
            sci_us = _per_call_us(lambda a=args: _solve_scipy(*a), 20)
            pos, ang = _axis_gap(own, sci)
            out.append(
                (f"N={n} loss={loss} {case} (scipy nfev {sci[4]})", own_us, sci_us, pos, ang)
            )
    return out


def main() -> None:
    rng = np.random.default_rng(0)
    rows: list[tuple[str, float | None, float, str]] = []

    try:
        from tactile_gym.sensing import estimate_contact
    except ImportError:
        estimate_contact = None
    if estimate_contact is None:
        rows.append(("estimate_contact (soft)", None, 30.0, "not available yet"))
    else:
        # 5 N pressed into the hemisphere, tilted across an edge; moment about the sensor.
        f = np.array([0.8, 0.3, -5.0])
        r = np.array([0.004, 0.002, 0.020 + 0.0155])
        m = np.cross(r, f)
        rows.append(
            ("estimate_contact (soft)", _per_call_us(lambda: estimate_contact(f, m), 500), 30.0, "")
        )

    for n in (4, 32):
        pts, eds = _planar(rng, n)
        rows.append(
            (
                f"fit_axis_planar N={n}",
                _per_call_us(lambda p=pts, e=eds: fit_axis_planar(p, e), 2000),
                30.0,
                "",
            )
        )
    for n in (8, 32):
        pts, eds = _planar(rng, n)
        for loss in ("linear", "soft_l1"):
            us = _per_call_us(
                lambda p=pts, e=eds, lo=loss: fit_axis_planar(
                    p, e, point_std=SIGMA_X, edge_std=SIGMA_E, loss=lo
                ),
                200,
            )
            rows.append((f"fit_axis_planar N={n} loss={loss} (with stds)", us, math.nan, ""))
    for n in (8, 32):
        pts, eds = _measurements(rng, n)
        for loss in ("linear", "soft_l1"):
            target = 2000.0 if n == 32 else math.nan
            us = _per_call_us(
                lambda p=pts, e=eds, lo=loss: fit_axis_3d(
                    p, e, point_std=SIGMA_X, edge_std=SIGMA_E, loss=lo
                ),
                20,
            )
            rows.append((f"fit_axis_3d N={n} loss={loss} (with stds)", us, target, ""))

    planar_online = [
        # (what, measurements held after the add, loss, explicit edge_cov, prior, target us)
        ("loss=linear add+estimate", 8, "linear", False, None, 100.0),
        ("loss=linear add(edge_cov)+estimate", 8, "linear", True, None, 100.0),
        ("loss=linear add+estimate, prior", 8, "linear", False, PLANAR_PRIOR, 100.0),
        ("loss=soft_l1 add+estimate", 8, "soft_l1", False, None, math.nan),
        ("loss=soft_l1 add+estimate, prior", 4, "soft_l1", False, PLANAR_PRIOR, math.nan),
        ("loss=soft_l1 add+estimate, prior", 8, "soft_l1", False, PLANAR_PRIOR, math.nan),
        ("loss=soft_l1 add+estimate", 32, "soft_l1", False, None, math.nan),
    ]
    for what, n, loss, edge_cov, prior, target in planar_online:
        pts, eds = _planar(rng, n + 8)
        us = _online_us("planar", pts, eds, n - 1, loss=loss, edge_cov=edge_cov, prior=prior)
        rows.append((f"JointAxisEstimator planar {what} (N={n})", us, target, ""))
    pts, eds = _measurements(rng, 16)
    for what, prior in (("", None), (", prior", TILTED_PRIOR)):
        us = _online_us("3d", pts, eds, 7, prior=prior)
        rows.append((f"JointAxisEstimator 3d add+estimate{what} (N=8)", us, math.nan, ""))

    pts, eds = _measurements(rng, 64)
    mean_us, worst_us = _stream_us(pts, eds, 8)
    rows.append(("JointAxisEstimator 3d add+estimate, amortised over N=8..64", mean_us, 100.0, ""))
    rows.append(
        ("JointAxisEstimator 3d add+estimate, worst single update N=8..64", worst_us, math.nan, "")
    )

    print("| call | us per call (median) | target us | result |")
    print("| --- | ---: | ---: | --- |")
    for name, us, target, note in rows:
        if us is None:
            print(f"| {name} | - | {target:.0f} | {note} |")
            continue
        if math.isnan(target):
            verdict, tgt = "(no target)", "-"
        else:
            verdict, tgt = ("pass" if us <= target else "miss"), f"{target:.0f}"
        print(f"| {name} | {us:.1f} | {tgt} | {verdict} |")

    print()
    print("| general-model solve | own LM us | scipy us | scipy / own | gap mm | gap deg |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for case, own_us, sci_us, pos, ang in solver_rows(rng):
        print(
            f"| {case} | {own_us:.0f} | {sci_us:.0f} | {sci_us / own_us:.1f} | "
            f"{pos * 1e3:.2e} | {math.degrees(ang):.2e} |"
        )


if __name__ == "__main__":
    main()
