"""The joint-type estimator on synthetic draws: confusion, false confidence, cost.

Run: ``python benchmarks/joint_type_synthetic.py`` (``--help`` for the options). The draws
are ``tests/joint_type_cases.py``'s: a link's face (60-120 mm by 20-40 mm) moved by a
rigid, revolute or prismatic joint (planar: on the table, a vertical axis or a slide in the
table plane; 3D: all at random angles), two edges pressed at each configuration (the long
edge and the end edge), the contact anywhere along the edge's middle, the env's noise
(contact point 1 mm per axis, edge 1-3 deg drawn per draw). ``--motion`` scales the joint's
sweep over the configurations: 1.0 is 90 deg or 60 mm. The estimator runs with its default
priors (docs/design.md 6.10) and the Laplace rule, and with BIC for comparison.

Prints, per mode:

1. by number of configurations and motion: the accuracy (the most probable outcome is the
   true type), the false-confidence rate (a wrong outcome with probability above 0.9), the
   same among the estimates that carry no flag, the share flagged, BIC's false-confidence
   rate, and the median time of one estimate from scratch;
2. the confusion matrix over all settings (rows: truth; columns: most probable outcome);
3. the false-confidence rate of the two rules on the same draws, and on slides along the
   only measured edge (which no rule can tell from a rigid link);
4. the cost of one estimate against ``JointAxisEstimator``'s on the same measurements, in
   the same run, and the models' solver against ``scipy.optimize.least_squares`` on the
   same problems from the same starts (docs/design.md 6.10 says why the own solver);

then the drawer reproduction (issue 28 item 5, the paper's Table I for a prismatic joint; a
300 x 200 mm top pulled along its sides, four displacements 10 mm apart, its front and a
side edge pressed at each): the direction's mean error from the edge lines and from the
contact points, with the contact sliding along the edges and not.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

# Measure the checkout this file is in, and use the tests' ground truth.
_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(_ROOT))
sys.path.insert(0, str(_ROOT / "tests"))

from joint_type_cases import JOINT_TYPES, Face, Joint, drawer, press, scenario  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from tactile_gym.estimation import (  # noqa: E402
    OUTCOMES,
    JointAxisEstimator,
    JointTypeEstimator,
    PrismaticModel,
    RevoluteModel,
    estimate_joint_type,
    fit_slide_direction,
    fit_slide_simple,
    slide_error,
)
from tactile_gym.estimation.joint_models import minimise  # noqa: E402

CONFIDENT = 0.9


def _estimate(p, mode: str, rule: str = "laplace"):
    return estimate_joint_type(*p.batch, **p.labels, mode=mode, rule=rule)


def _false(probs: np.ndarray, truth: int) -> bool:
    return bool(np.delete(probs, truth).max() > CONFIDENT)


def sweep(mode: str, configs: list[int], motions: list[float], draws: int, seed: int):
    """Per setting: (n_configs, motion, accuracy, false rate, false rate without flags,
    flagged share, BIC false rate, median ms); and the confusion matrix over all of them."""
    rng = np.random.default_rng(seed)
    rows = []
    confusion = np.zeros((3, len(OUTCOMES)), dtype=int)
    for n_configs in configs:
        for motion in motions:
            right = false = false_bic = false_clean = flagged = 0
            times = []
            for _ in range(draws):
                for i, kind in enumerate(JOINT_TYPES):
                    sigma_e = math.radians(float(rng.uniform(1.0, 3.0)))
                    _, _, p = scenario(rng, kind, mode == "planar", n_configs, motion, 2, sigma_e)
                    t = time.perf_counter()
                    est = _estimate(p, mode)
                    times.append(time.perf_counter() - t)
                    probs = est.probabilities
                    best = int(np.argmax(probs))
                    confusion[i, best] += 1
                    right += best == i
                    false += _false(probs, i)
                    flagged += bool(est.flags)
                    false_clean += _false(probs, i) and not est.flags
                    false_bic += _false(_estimate(p, mode, "bic").probabilities, i)
            n = 3 * draws
            rows.append(
                (
                    n_configs,
                    motion,
                    right / n,
                    false / n,
                    false_clean / n,
                    flagged / n,
                    false_bic / n,
                    1e3 * np.median(times),
                )
            )
    return rows, confusion


def slides_along_the_edge(mode: str, draws: int, seed: int) -> tuple[float, float]:
    """False-confidence rate of both rules on slides along the only measured edge (the
    long edge, 5 configurations, 50 mm): rigid above 0.9 is a wrong, confident answer."""
    rng = np.random.default_rng(seed)
    face = Face(np.array([0.0, 0.0, 0.05]), np.eye(3)[0], np.eye(3)[1], (0.05, 0.015))
    slide = Joint("prismatic", np.eye(3)[0])
    out = []
    for rule in ("laplace", "bic"):
        false = 0
        for _ in range(draws):
            p = press(rng, face, slide, np.linspace(0.0, 0.05, 5), [[0]] * 5)
            false += _false(_estimate(p, mode, rule).probabilities, 2)
        out.append(false / draws)
    return out[0], out[1]


def cost_ratio(mode: str, draws: int, seed: int) -> tuple[float, float, float, float]:
    """Median time of one estimate from scratch (12 presses), of JointAxisEstimator's on
    the primary line's 6 presses (what the revolute model feeds it), their ratio, and the
    median time of the online refit after each press from the fifth on."""
    rng = np.random.default_rng(seed)
    ours, axis, online = [], [], []
    for _ in range(draws):
        _, _, p = scenario(rng, "revolute", mode == "planar", 6, 1.0, 2)
        t = time.perf_counter()
        _estimate(p, mode)
        ours.append(time.perf_counter() - t)
        t = time.perf_counter()
        est = JointAxisEstimator(mode)
        for x, e in zip(p.points[p.lines == 0], p.edges[p.lines == 0]):
            est.add(x, e, p.point_std, p.edge_std)
        est.estimate()
        axis.append(time.perf_counter() - t)
        types = JointTypeEstimator(mode)
        for i, (x, e, line, config) in enumerate(zip(p.points, p.edges, p.lines, p.configs)):
            types.add(x, e, p.point_std, p.edge_std, line=int(line), config=int(config))
            t = time.perf_counter()
            types.estimate()
            if i >= 4:
                online.append(time.perf_counter() - t)
    a, b = float(np.median(ours)), float(np.median(axis))
    return 1e3 * a, 1e3 * b, a / b, 1e3 * float(np.median(online))


def solvers(mode: str, draws: int, seed: int) -> tuple[float, float, float, float]:
    """Median time of the models' solver and of least_squares (trust region, the same
    residuals with the priors' rows appended, same Jacobian and start) over the prismatic
    and revolute solves of revolute draws, the median of their ratio on each problem (the
    two run back to back, so that a change of the machine's load touches both), and the
    largest relative gap in their final costs."""
    rng = np.random.default_rng(seed)
    ours, scipy_times, gap = [], [], 0.0
    for _ in range(draws):
        _, _, p = scenario(rng, "revolute", mode == "planar", 6, 1.0, 2)
        est = JointTypeEstimator(mode)
        for x, e, line, config in zip(p.points, p.edges, p.lines, p.configs):
            est.add(x, e, p.point_std, p.edge_std, line=int(line), config=int(config))
        data = est.data
        revolute = RevoluteModel(mode)
        axis = revolute._axis(data)
        revolute._axis_prior = revolute._axis_fit.prior
        u = axis.direction if mode == "3d" else np.eye(3)[2]
        prismatic = PrismaticModel(mode)
        for model, start in (
            (prismatic, prismatic._cold(data)),
            (revolute, revolute._cold(data, u, axis.point)),
        ):
            fun, jac, precision, _ = model._problem(data, start)
            root = np.sqrt(precision)

            def fun_all(x, fun=fun, root=root):
                return np.concatenate([fun(x), root * x])

            def jac_all(x, jac=jac, root=root):
                return np.vstack([jac(x), np.diag(root)])

            t = time.perf_counter()
            x_own = minimise(fun, jac, precision)
            ours.append(time.perf_counter() - t)
            t = time.perf_counter()
            x_lsq = least_squares(fun_all, np.zeros(precision.size), jac=jac_all, x_scale="jac").x
            scipy_times.append(time.perf_counter() - t)
            c_own, c_lsq = (float(np.sum(fun_all(x) ** 2)) for x in (x_own, x_lsq))
            gap = max(gap, abs(c_own - c_lsq) / max(c_lsq, 1e-12))
    ratio = float(np.median(np.array(scipy_times) / np.array(ours)))
    return 1e3 * float(np.median(ours)), 1e3 * float(np.median(scipy_times)), ratio, gap


def drawer_errors(trials: int, seed: int) -> list[tuple[str, float, float]]:
    """The drawer's direction (``joint_type_cases.drawer``): mean error in degrees of the
    proposed and the simple method, per contact case."""
    rng = np.random.default_rng(seed)
    out = []
    for slide in (True, False):
        prop, simple = [], []
        for _ in range(trials):
            v, p = drawer(rng, slide)
            est = fit_slide_direction(*p.batch, **p.labels, planar=True)
            prop.append(math.degrees(slide_error(est, v)))
            simple_est = fit_slide_simple(p.points, lines=p.lines, planar=True)
            simple.append(math.degrees(slide_error(simple_est, v)))
        case = "contact slides" if slide else "contact fixed"
        out.append((case, float(np.mean(prop)), float(np.mean(simple))))
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--draws", type=int, default=30, help="draws per type and setting")
    parser.add_argument("--configs", type=int, nargs="+", default=[2, 4, 6])
    parser.add_argument("--motions", type=float, nargs="+", default=[0.1, 0.3, 1.0])
    parser.add_argument("--modes", nargs="+", default=["planar", "3d"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--drawer-trials", type=int, default=200)
    args = parser.parse_args(argv)
    for mode in args.modes:
        rows, confusion = sweep(mode, args.configs, args.motions, args.draws, args.seed)
        print(f"\n### {mode}: {args.draws} draws per type and setting\n")
        print(
            "| configurations | motion | accuracy | false > 0.9 | false > 0.9, no flag | "
            "flagged | BIC false > 0.9 | ms |"
        )
        print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for n_configs, motion, acc, false, clean, flagged, false_bic, ms in rows:
            print(
                f"| {n_configs} | {motion:g} | {100 * acc:.1f} % | {100 * false:.1f} % | "
                f"{100 * clean:.1f} % | {100 * flagged:.0f} % | {100 * false_bic:.1f} % | "
                f"{ms:.0f} |"
            )
        total = len(rows) * 3 * args.draws
        false_all = sum(r[3] for r in rows) * 3 * args.draws
        bic_all = sum(r[6] for r in rows) * 3 * args.draws
        print(f"\nconfusion (rows: truth; columns: {', '.join(OUTCOMES)}), all settings:\n")
        for kind, row in zip(JOINT_TYPES, confusion):
            print(f"    {kind:9s} " + " ".join(f"{v:5d}" for v in row))
        along = slides_along_the_edge(mode, args.draws, args.seed + 1)
        print(
            f"\nfalse > 0.9, all settings: Laplace {100 * false_all / total:.1f} %, "
            f"BIC {100 * bic_all / total:.1f} % of {total}; slides along the only edge: "
            f"Laplace {100 * along[0]:.0f} %, BIC {100 * along[1]:.0f} % of {args.draws}"
        )
        ours, axis, ratio, online = cost_ratio(mode, args.draws, args.seed + 2)
        print(
            f"one estimate from scratch (12 presses): {ours:.1f} ms; JointAxisEstimator on "
            f"its 6: {axis:.1f} ms; ratio {ratio:.1f}; online refit after a press "
            f"(5th-12th): {online:.1f} ms"
        )
        own, lsq, ratio, gap = solvers(mode, args.draws, args.seed + 4)
        print(
            f"one solve: own solver {own:.2f} ms, least_squares {lsq:.2f} ms (median ratio "
            f"{ratio:.1f}); largest relative gap in the final cost {gap:.1e}"
        )
    print(f"\n### drawer: {args.drawer_trials} trials per case, mean direction error\n")
    print("| contact | edge lines (proposed) | contact points (simple) |")
    print("| --- | ---: | ---: |")
    for case, prop, simple in drawer_errors(args.drawer_trials, args.seed + 3):
        print(f"| {case} | {prop:.2f} deg | {simple:.2f} deg |")


if __name__ == "__main__":
    main()
