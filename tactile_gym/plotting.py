"""Top-view plots in the style of the paper's Fig. 12/13, drawn with matplotlib.

Everything is drawn in the world x-y plane, in millimetres: measured contact points (green
squares) with their edge directions (green lines), the true joint position (blue circle, when
known) and the estimate (red cross), where the axes cross the plane of the true pin (or of the
measurements). Each mark carries its legend label (``LABELS``) once per call, and
``add_legend`` draws the key below the axes, off the data, with each label once. No simulator:
the env (``plot_top_view``) and the log replay (``draw_top_view``) draw alike.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "LABELS",
    "add_legend",
    "draw_estimate",
    "draw_measurements",
    "draw_top_view",
    "plot_top_view",
]

MM = 1e3
#: The legend entry of each mark.
LABELS = {
    "points": "measured contact points",
    "edges": "measured edge directions",
    "truth": "true joint position",
    "estimate": "estimated joint position",
}


def draw_measurements(ax, points: np.ndarray, edges: np.ndarray, length: float = 0.03) -> None:
    """Contact points (N, 3) and edge directions (N, 3), world frame, m; NaN edges skipped."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    edges = np.asarray(edges, dtype=float).reshape(-1, 3)
    ax.plot(
        points[:, 0] * MM, points[:, 1] * MM, "s", color="tab:green", ms=3, label=LABELS["points"]
    )
    label = LABELS["edges"]
    for x, e in zip(points, edges):
        if np.all(np.isfinite(e)) and np.all(np.isfinite(x)):
            seg = np.array([x - length * e, x + length * e]) * MM
            ax.plot(seg[:, 0], seg[:, 1], color="tab:green", lw=0.5, alpha=0.6, label=label)
            label = "_nolegend_"  # one entry for all the edges


def draw_estimate(ax, true_point: np.ndarray | None, estimate_point: np.ndarray | None) -> None:
    """The true axis point (blue circle; None: unknown) and the estimate (red cross), world
    x-y, m."""
    if true_point is not None:
        x, y = true_point[0] * MM, true_point[1] * MM
        ax.plot(x, y, "o", mfc="none", color="tab:blue", ms=10, label=LABELS["truth"])
    if estimate_point is not None and np.all(np.isfinite(estimate_point)):
        x, y = estimate_point[0] * MM, estimate_point[1] * MM
        ax.plot(x, y, "x", color="tab:red", ms=8, label=LABELS["estimate"])


def add_legend(fig, axes, ncol: int = 3) -> None:
    """The key of every labelled mark on ``axes``, each label once, below them (off the data;
    the figure needs ``layout="constrained"``)."""
    entries: dict = {}
    for ax in np.atleast_1d(axes):
        for handle, label in zip(*ax.get_legend_handles_labels()):
            entries.setdefault(label, handle)
    fig.legend(entries.values(), entries.keys(), loc="outside lower center", ncol=ncol, fontsize=8)


def draw_top_view(ax, measurements, estimate, true_point=None, title: str = "") -> None:
    """A top view of measurements (``.point``, ``.edge``) and an axis estimate (or None),
    with the true axis point when known (m, world frame), and its key below the axes."""
    if measurements:
        points = np.array([m.point for m in measurements])
        draw_measurements(ax, points, np.array([m.edge for m in measurements]))
    plane = true_point
    if plane is None and measurements:
        plane = np.mean([m.point for m in measurements], axis=0)
    estimate_point = None
    if estimate is not None and not estimate.degenerate and plane is not None:
        # The estimated axis where it crosses the plane of the true pin (or measurements).
        u = estimate.direction
        if abs(u[2]) > 1e-6:
            estimate_point = estimate.point + u * (plane[2] - estimate.point[2]) / u[2]
    draw_estimate(ax, true_point, estimate_point)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    ax.set_title(f"{title}, top view: {len(measurements)} measurements", fontsize=9)
    add_legend(ax.figure, ax, ncol=2)


def plot_top_view(env, ax=None):
    """Top view of a ``HingeProbe`` episode so far: its measurements, the free link's edge
    now, and the true and estimated axes, with their key below the axes.

    Args:
        env: a ``HingeProbe`` env (``gym.make(...).unwrapped``, 6-D or primitive) after
            ``reset``.
        ax: a matplotlib axes in a figure with ``layout="constrained"`` (which makes room
            for the key); a new figure is made when None.

    Returns:
        The axes.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 5), layout="constrained")
    scene = env.scene
    origin, direction = scene.edge_line
    link = np.array([origin, origin + 0.1 * direction]) * MM
    ax.plot(link[:, 0], link[:, 1], color="grey", lw=2, label="free link edge (now)")
    true_point, _ = scene.true_axis
    name = env.spec.id if env.spec is not None else type(env).__name__
    draw_top_view(ax, env.measurements, env.axis_estimate, true_point, name)
    return ax
