"""The figures the agents' commands draw, made to explain themselves: the env id in the
title, what a step is on the axis, a legend entry for every line, band and mark, placed off
the data, and plain tick labels on log axes.

``agents.evaluate`` draws ``error_vs_step.png`` (:func:`plot_errors`); ``agents.aggregate``
its learning curves, with :func:`step_unit` on the axis.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tactile_gym import PRIMITIVE_ENV_IDS


def step_unit(env_id: str) -> str:
    """What one env step of ``env_id`` is, for axis labels: a primitive (the primitive ids)
    or a control step of 0.05 s (the 6-D ids)."""
    return "primitives" if env_id in PRIMITIVE_ENV_IDS else "control steps (0.05 s each)"


def plot_errors(records: dict[str, list], path: Path, env_id: str, threshold: float) -> None:
    """Median and inter-quartile band of the position error against the step, per policy.

    Args:
        records: each policy's episodes (``agents.evaluate.EpisodeRecord``: their
            ``position_error`` after reset and after each step, m), by legend label.
        path: the PNG to write.
        env_id: the id the episodes ran on (the title, and what a step is).
        threshold: the "reached" error drawn as a dotted line, m.

    An episode that ended early keeps its last error to the longest episode's end; step 0
    is the prior's error, before any measurement.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig, ax = plt.subplots(figsize=(9, 4))
    handles, labels = [], []
    for name, recs in records.items():
        length = max(len(r.position_error) for r in recs)
        padded = (
            np.array(
                [
                    r.position_error + [r.position_error[-1]] * (length - len(r.position_error))
                    for r in recs
                ]
            )
            * 1e3
        )
        steps = np.arange(length)
        (line,) = ax.plot(steps, np.median(padded, axis=0))
        band = np.percentile(padded, [25, 75], axis=0)
        ax.fill_between(steps, *band, alpha=0.2, linewidth=0, color=line.get_color())
        handles.append((Patch(color=line.get_color(), alpha=0.2, linewidth=0), line))
        labels.append(name)
    ax.axhline(threshold * 1e3, color="grey", linestyle=":", linewidth=1)
    handles.append(Line2D([], [], color="grey", linestyle=":", linewidth=1))
    labels.append(f"{threshold * 1e3:.0f} mm ('reached 5 mm')")
    n = len(next(iter(records.values())))
    fig.suptitle(f"{env_id}: axis position error, {n} episode{'s' if n != 1 else ''}")
    ax.set_xlabel(f"step ({step_unit(env_id)}; 0 = the prior, before any touch)")
    ax.set_ylabel("axis position error (mm)")
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(plain_log_ticks(minor=False))
    ax.yaxis.set_minor_formatter(plain_log_ticks(minor=True))
    ax.legend(
        handles,
        labels,
        title="line: median; band: 25-75 % of episodes",
        title_fontsize=8,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plain_log_ticks(minor: bool):
    """Tick labels of a log axis as plain numbers (``0.5``, ``2``, ``10``, not ``5x10^-1``);
    of the minor ticks, only 2, 3 and 5 times a power of ten, so that labels do not crowd."""
    from matplotlib.ticker import FuncFormatter

    def label(value: float, _position) -> str:
        if value <= 0:
            return ""
        mantissa = round(value / 10 ** math.floor(math.log10(value)), 6)
        if minor and mantissa not in (2, 3, 5):
            return ""
        return f"{value:g}"

    return FuncFormatter(label)
