"""Aggregate a sweep's runs: tables across seeds and learning curves.

    python -m agents.aggregate runs/sweeps/smoke      # re-aggregate a sweep folder

For each env, one row per algorithm over its seeds: the mean +- std (sample std, ddof = 1)
and a 95 % bootstrap confidence interval of the mean of each run's held-out evaluation
figures: the final position error (mm), the success rate, and the mean step at which the
error first fell below 5 mm (over the runs in which some episode reached it). The learning
curve of each env plots the periodic evaluations' mean return (``eval/evaluations.npz``)
against training steps (primitives or control steps, as the id counts), mean +- std across
seeds.

A run is a folder with ``job.json`` (env id, algo, seed) and ``evaluation/evaluation.json``,
as ``agents.sweep`` writes them.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .cli import json_safe, make_parser, run_main
from .paired import bootstrap_ci

__all__ = [
    "aggregate",
    "describe",
    "load_runs",
    "markdown",
    "plot_learning_curves",
    "write_results",
]

#: (key in the run's evaluation summary, column title, scale, format)
METRICS = (
    ("position_mean_mm", "final position error (mm)", 1.0, ".1f"),
    ("success_rate", "success rate (%)", 100.0, ".0f"),
    ("steps_to_5mm_mean", "steps to 5 mm", 1.0, ".0f"),
)
#: The joint ids' metrics (``agents.episodes.joint_figures``), shown for the envs that have them.
JOINT_METRICS = (
    ("type_accuracy", "type accuracy (%)", 100.0, ".1f"),
    ("revolute_position_mean_mm", "revolute axis error (mm)", 1.0, ".2f"),
    ("prismatic_angle_mean_deg", "prismatic direction error (deg)", 1.0, ".2f"),
)


@dataclass(frozen=True)
class RunResult:
    """One finished run of a sweep."""

    env_id: str
    algo: str
    seed: int
    run_dir: Path
    summary: dict


def describe(values) -> dict[str, float]:
    """``n``, ``mean``, ``std`` (ddof = 1) and the 95 % bootstrap CI of the finite values."""
    values = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    n = int(values.size)
    low, high = bootstrap_ci(values)
    return {
        "n": n,
        "mean": float(values.mean()) if n else math.nan,
        "std": float(values.std(ddof=1)) if n > 1 else math.nan,
        "ci_low": low,
        "ci_high": high,
    }


def load_runs(sweep_dir: str | Path) -> list[RunResult]:
    """Every finished run under ``sweep_dir`` (a ``job.json`` beside an evaluation)."""
    runs = []
    for job_file in sorted(Path(sweep_dir).rglob("job.json")):
        run_dir = job_file.parent
        evaluation = run_dir / "evaluation" / "evaluation.json"
        if not evaluation.exists():
            continue
        job = json.loads(job_file.read_text())
        data = json.loads(evaluation.read_text())
        (summary,) = data["summaries"].values()
        runs.append(RunResult(job["env_id"], job["algo"], int(job["seed"]), run_dir, summary))
    return runs


def aggregate(runs: list[RunResult]) -> dict[str, dict[str, dict]]:
    """``{env_id: {algo: {"seeds": [...], metric: describe(...)}}}``, ordered by first
    appearance of the env and the algo."""
    table: dict[str, dict[str, dict]] = {}
    for run in runs:
        table.setdefault(run.env_id, {}).setdefault(run.algo, {"seeds": [], "runs": []})
        table[run.env_id][run.algo]["seeds"].append(run.seed)
        table[run.env_id][run.algo]["runs"].append(run.summary)
    for algos in table.values():
        for row in algos.values():
            summaries = row.pop("runs")
            for key, _, scale, _ in (*METRICS, *JOINT_METRICS):
                row[key] = describe(
                    [None if s.get(key) is None else scale * s[key] for s in summaries]
                )
    return table


def _fmt(value: float, spec: str) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value, spec)


def _cell(d: dict, spec: str, n_seeds: int) -> str:
    """``mean +- std [low, high]``; the mean alone for one value, ``-`` for none."""
    if d["n"] == 0:
        return "-"
    cell = _fmt(d["mean"], spec)
    if d["n"] > 1:
        cell += (
            f" +- {_fmt(d['std'], spec)} [{_fmt(d['ci_low'], spec)}, {_fmt(d['ci_high'], spec)}]"
        )
    if d["n"] != n_seeds:
        cell += f" ({d['n']} of {n_seeds} seeds)"
    return cell


def markdown(table: dict[str, dict[str, dict]]) -> str:
    """One markdown table per env: mean +- std [95 % CI] of each metric, by algo."""
    blocks = []
    for env_id, algos in table.items():
        joint = any(row["type_accuracy"]["n"] for row in algos.values())
        metrics = (*METRICS, *JOINT_METRICS) if joint else METRICS
        header = "| algo | seeds | " + " | ".join(title for _, title, _, _ in metrics) + " |"
        lines = [f"**{env_id}**", "", header, "|---|---|" + "---|" * len(metrics)]
        for algo, row in algos.items():
            cells = []
            for key, _, _, spec in metrics:
                cells.append(_cell(row[key], spec, len(row["seeds"])))
            lines.append(f"| {algo} | {len(row['seeds'])} | " + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    note = (
        "mean +- std across seeds [95 % bootstrap CI of the mean]; each seed's figure is the "
        "mean over its held-out evaluation episodes; steps to 5 mm over the seeds where an "
        "episode reached it."
    )
    return "\n\n".join([*blocks, note])


def learning_curve(run_dirs: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Env steps, and the mean and std across runs of the evaluations' mean return, at the
    steps all runs evaluated; ``None`` if no run has an evaluation log."""
    curves = []
    for run_dir in run_dirs:
        log = Path(run_dir) / "eval" / "evaluations.npz"
        if log.exists():
            with np.load(log) as data:
                curves.append(dict(zip(data["timesteps"].tolist(), data["results"].mean(axis=1))))
    if not curves:
        return None
    steps = sorted(set.intersection(*(set(c) for c in curves)))
    if not steps:
        return None
    values = np.array([[c[s] for s in steps] for c in curves])
    std = values.std(axis=0, ddof=1) if len(curves) > 1 else np.zeros(len(steps))
    return np.array(steps), values.mean(axis=0), std


def plot_learning_curves(runs: list[RunResult], out_dir: str | Path) -> list[Path]:
    """One ``learning_curve_<env>.png`` per env in ``out_dir``; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .plots import step_unit

    written = []
    for env_id in dict.fromkeys(r.env_id for r in runs):
        fig, ax = plt.subplots(figsize=(8.5, 4))
        plotted = False
        for algo in dict.fromkeys(r.algo for r in runs if r.env_id == env_id):
            dirs = [r.run_dir for r in runs if r.env_id == env_id and r.algo == algo]
            seeds = sorted(r.seed for r in runs if r.env_id == env_id and r.algo == algo)
            curve = learning_curve(dirs)
            if curve is None:
                continue
            steps, mean, std = curve
            seed_text = f"seed {seeds[0]}" if len(seeds) == 1 else f"mean of {len(seeds)} seeds"
            (line,) = ax.plot(
                steps, mean, marker="o", markersize=3, label=f"{algo.upper()}, {seed_text}"
            )
            if len(seeds) > 1:
                ax.fill_between(
                    steps,
                    mean - std,
                    mean + std,
                    alpha=0.2,
                    linewidth=0,
                    color=line.get_color(),
                    label=f"{algo.upper()}, +- 1 std across seeds",
                )
            plotted = True
        if plotted:
            ax.set_xlabel(f"training steps ({step_unit(env_id)})")
            ax.set_ylabel("periodic evaluation: mean episode return")
            ax.set_title(f"{env_id}: learning curves")
            ax.legend(
                title="points: periodic evaluations",
                title_fontsize=8,
                loc="upper left",
                bbox_to_anchor=(1.01, 1.0),
                fontsize=8,
            )
            fig.tight_layout()
            path = Path(out_dir) / f"learning_curve_{env_id.split('/')[-1]}.png"
            fig.savefig(path, dpi=120)
            written.append(path)
        plt.close(fig)
    return written


def write_results(sweep_dir: str | Path, plot: bool = True) -> str:
    """Aggregate the finished runs under ``sweep_dir``; write ``results.md``,
    ``results.json`` and the learning curves there; return the markdown."""
    sweep_dir = Path(sweep_dir)
    runs = load_runs(sweep_dir)
    if not runs:
        return "no finished runs"
    table = aggregate(runs)
    text = markdown(table)
    (sweep_dir / "results.md").write_text(text + "\n")
    (sweep_dir / "results.json").write_text(json.dumps(json_safe(table), indent=1, allow_nan=False))
    if plot:
        plot_learning_curves(runs, sweep_dir)
    return text


def main(argv: list[str] | None = None) -> str:
    parser = make_parser(__spec__.name if __spec__ else "agents.aggregate", __doc__)
    parser.add_argument(
        "sweep_dir", help="a sweep's folder, as agents.sweep writes it (runs/sweeps/<name>)"
    )
    parser.add_argument(
        "--no-plot", action="store_true", help="skip the learning curves (learning_curve_*.png)"
    )
    args = parser.parse_args(argv)
    if not load_runs(args.sweep_dir):
        raise ValueError(
            f"sweep_dir {args.sweep_dir!r} holds no finished run (a folder with job.json and "
            "evaluation/evaluation.json, as agents.sweep writes them)"
        )
    text = write_results(args.sweep_dir, plot=not args.no_plot)
    print(text)
    return text


if __name__ == "__main__":
    sys.exit(run_main(main))
