"""Replay a probing log through the perception pipeline: presses in, the joint axis out.

    python -m tactile_gym.replay LOG [--mode planar|3d] [--plot top_view.png]

``LOG`` is a log of a real robot or of the simulator (``tactile_gym.perception.log``: NPZ or
CSV). The command prints the presses the gate found, accepted and refused (each refusal with
the rule that refused it), the tares (flagging one whose offset jumped further than the drift
allows: a tare taken while something touched), and the axis estimate with its 1-sigma and
95 % bounds; with ``--plot`` it draws a top view in the style of the paper's Fig. 12. A
simulated log's truth sidecar (``<log>.truth.json``), when present, adds the true errors.

A log that cannot be read right, or has no press, ends in one line on stderr naming the
problem, with exit status 2 (``--debug`` shows the traceback). No simulator, no Gymnasium.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

from tactile_gym.estimation import AxisEstimate, axis_error
from tactile_gym.perception.log import LogError, load_log, replay, truth_path

__all__ = ["axis_bounds", "main", "report"]

#: Draws behind the 95 % radii (a fixed seed: the same bounds every run).
BOUND_DRAWS = 200_000


def axis_bounds(estimate: AxisEstimate, level: float = 0.95) -> tuple[float, float]:
    """The radii within which the estimate's position and direction errors lie with
    probability ``level``, by its covariance: the position error is the 2-D offset of the
    axis normal to its direction (m), the angle error that of the direction (rad). Each is a
    weighted sum of two chi-square terms, whose quantile is drawn (``BOUND_DRAWS``)."""
    cov = estimate.covariance
    if estimate.degenerate or cov is None:
        return math.inf, math.inf
    basis = np.linalg.svd(estimate.direction[None, :])[2][1:].T  # (3, 2), normal to the axis
    rng = np.random.default_rng(0)
    z = rng.standard_normal((BOUND_DRAWS, 2)) ** 2
    radii = []
    for block in (cov[:3, :3], cov[3:6, 3:6]):
        weights = np.clip(np.linalg.eigvalsh(basis.T @ block @ basis), 0.0, None)
        radii.append(float(np.sqrt(np.quantile(z @ weights, level))))
    return radii[0], radii[1]


def report(path: str | Path, mode: str | None = None, plot: str | Path | None = None) -> str:
    """The replay's report of a log (module docstring); draws the top view to ``plot``.

    Raises:
        LogError: the log cannot be read right, or has no press.
    """
    log = load_log(path)
    if mode is not None:
        estimator = {**log.header.estimator, "mode": mode}
        log = dataclasses.replace(log, header=dataclasses.replace(log.header, estimator=estimator))
    pipeline = replay(log)
    presses = pipeline.presses
    if not presses:
        raise LogError(
            f"{path}: no press in the log: no touch held still in the gate's force band"
            f" {log.header.gate_config().force_band} N for {log.header.gate_config().dwell}"
            " readings"
        )
    accepted = sum(p.accepted for p in presses)
    lines = [
        f"{path}: {len(log)} samples over {log.time[-1] - log.time[0]:.1f} s"
        + (f" ({log.header.source})" if log.header.source else ""),
        f"presses: {len(presses)} found, {accepted} accepted, {len(presses) - accepted} refused",
    ]
    for rule, count in Counter(p.rule for p in presses if not p.accepted).most_common():
        example = next(p for p in presses if p.rule == rule)
        lines.append(
            f"  refused by {rule}: {count} (e.g. at {example.time:.2f} s: {example.reason})"
        )
    flagged = [t for t in pipeline.tares if t.flagged]
    lines.append(f"tares: {len(pipeline.tares)}, {len(flagged)} flagged")
    for tare in flagged:
        lines.append(
            f"  tare at {tare.time:.2f} s: its offset moved {tare.jump:.3f} N from the last"
            f" tare's, the drift allows {tare.allowed:.3f} N (taken while touching?)"
        )
    estimate = pipeline.estimate
    mode = log.header.estimator["mode"]
    if estimate is None or estimate.degenerate:
        lines.append(f"axis ({mode}): not identified by these measurements")
    else:
        position, angle = axis_bounds(estimate)
        point, direction = estimate.point * 1e3, estimate.direction
        lines += [
            f"axis ({mode}, {estimate.method}): point {np.array2string(point, precision=2)} mm,"
            f" direction {np.array2string(direction, precision=4)}",
            f"  position: 1-sigma {estimate.position_std * 1e3:.2f} mm,"
            f" 95 % within {position * 1e3:.2f} mm",
        ]
        if mode == "3d":
            lines.append(
                f"  direction: 1-sigma {math.degrees(estimate.angle_std):.2f} deg,"
                f" 95 % within {math.degrees(angle):.2f} deg"
            )
    truth = truth_path(path)
    if truth.is_file():
        known = json.loads(truth.read_text())
        point = np.asarray(known["axis_point"])
        errors = axis_error(estimate, point, np.asarray(known["axis_direction"]), point)
        lines.append(
            f"truth ({truth.name}): position error {errors[0] * 1e3:.2f} mm,"
            f" angle error {math.degrees(errors[1]):.2f} deg"
        )
    if plot is not None:
        _plot(pipeline, truth, Path(plot), Path(path).name)
        lines.append(f"top view: {plot}")
    return "\n".join(lines)


def _plot(pipeline, truth: Path, out: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tactile_gym.plotting import draw_top_view

    true_point = None
    if truth.is_file():
        true_point = np.asarray(json.loads(truth.read_text())["axis_point"])
    fig, ax = plt.subplots(figsize=(6, 5), layout="constrained")
    draw_top_view(ax, pipeline.measurements, pipeline.estimate, true_point, title)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tactile_gym.replay",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("log", help="the log: NPZ or CSV (tactile_gym.perception.log)")
    parser.add_argument(
        "--mode", choices=("planar", "3d"), default=None, help="the estimator (default: the log's)"
    )
    parser.add_argument("--plot", default=None, help="write a top view (PNG) here")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    args = parser.parse_args(argv)
    try:
        print(report(args.log, args.mode, args.plot))
    except (LogError, ValueError, OSError) as error:
        if args.debug:
            raise
        print(f"tactile_gym.replay: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
