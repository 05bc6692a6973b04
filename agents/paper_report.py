"""The Table I reproduction's report: the markdown table and the Fig. 12/13-style top views.

``agents.reproduce_paper`` runs the trials; this module turns its results into what it
writes (``results/paper/``). Errors in mm in the table, positions in mm on the plots.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import stats

from tactile_gym.plotting import add_legend, draw_estimate, draw_measurements

__all__ = ["PAPER_TABLE", "markdown_table", "mean_interval", "plot"]

#: Table I of the paper: mean joint-position error, mm.
PAPER_TABLE = {
    ("slides", "proposed"): 6.0,
    ("slides", "simple"): 27.7,
    ("fixed", "proposed"): 7.1,
    ("fixed", "simple"): 5.9,
}


def mean_interval(errors, level: float = 0.95) -> tuple[float, float, float]:
    """The mean of the finite ``errors`` and its ``level`` confidence interval (Student's t;
    the interval is the mean alone for fewer than two)."""
    e = np.asarray(errors, dtype=float)
    e = e[np.isfinite(e)]
    mean = float(e.mean()) if len(e) else math.nan
    if len(e) < 2:
        return mean, mean, mean
    half = float(stats.t.ppf(0.5 + level / 2, len(e) - 1) * e.std(ddof=1) / math.sqrt(len(e)))
    return mean, mean - half, mean + half


def _stats(errors: list[float]) -> str:
    e = np.asarray(errors, dtype=float)
    ok = e[np.isfinite(e)]
    if not len(ok):
        return "failed"
    mean, low, high = mean_interval(ok)
    text = f"{mean:.1f} ({low:.1f}-{high:.1f}) / {np.median(ok):.1f} / {np.percentile(ok, 90):.1f}"
    return text if len(ok) == len(e) else f"{text} ({len(e) - len(ok)} failed)"


def markdown_table(results: dict, trials: int, seeds: int, schemes: dict) -> str:
    """Table I in markdown: mean / median / P90 error per cell, mm, with the paper's means.

    Args:
        results: as ``reproduce_paper.reproduce`` returns.
        trials, seeds: trials per cell and seed, and seeds.
        schemes: {scheme: (measurements, turn between them in rad)}.
    """
    lines = [
        f"Joint-position error |(p, q)_est - (p, q)_true| in mm, {seeds} seed(s) x {trials} "
        "trials per cell (mean (95 % CI) / median / P90); paper = Table I mean; accepted: the"
        " share of the measurement presses the gate accepted.",
        "",
        "| condition | measurements | contact | proposed | paper | simple | paper |"
        " simple / proposed (means) | presses per measurement | accepted |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, cell in results.items():
        condition, scheme, case = key if len(key) == 3 else ("nominal", *key)
        n, step = schemes[scheme]
        prop, simp = np.array(cell["proposed_mm"]), np.array(cell["simple_mm"])
        paper = scheme == "paper" and condition == "nominal"
        presses = np.mean([t.presses.mean() for t in cell["trials"]])
        accepted = np.mean([len(t.points) / len(t.presses) for t in cell["trials"]])
        lines.append(
            f"| {condition} | {n} x {math.degrees(step):.0f} deg | {case} | {_stats(prop)} |"
            f" {PAPER_TABLE[(case, 'proposed')] if paper else '-'} | {_stats(simp)} |"
            f" {PAPER_TABLE[(case, 'simple')] if paper else '-'} |"
            f" {np.nanmean(simp) / np.nanmean(prop):.1f}x | {presses:.1f} | {accepted:.0%} |"
        )
    return "\n".join(lines)


def plot(results: dict, truth: np.ndarray, out: Path) -> list[Path]:
    """Fig. 12/13-style top views, one PNG per contact case of the paper scheme: every trial's
    measured contact points and edge directions (green), its estimate (red) and the true joint
    position (blue), overlaid, with their key below the axes.

    Args:
        results: as ``reproduce`` returns, with the nominal paper cells.
        truth: (2,) true (p, q), world, m.
        out: folder for the PNGs.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for case, title in (("slides", "contact points move"), ("fixed", "contact points fixed")):
        runs = results[("paper", case)]["trials"]
        fig, axes = plt.subplots(
            1, 2, figsize=(9, 5), sharex=True, sharey=True, layout="constrained"
        )
        for ax, method in zip(axes, ("proposed", "simple")):
            for t in runs:
                draw_measurements(ax, t.points, t.edges)
                draw_estimate(ax, np.r_[truth, 0.0], np.r_[getattr(t, method), 0.0])
            ax.set_title(f"{method} method")
            ax.set_xlabel("x [mm]")
            ax.set_aspect("equal")
        axes[0].set_ylabel("y [mm]")
        fig.suptitle(
            f"Estimated joint position, {title}: {len(runs)} trials overlaid"
            " (one red estimate per trial)"
        )
        add_legend(fig, axes)
        path = out / f"fig_{case}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
    return paths
