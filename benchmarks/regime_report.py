"""Regime map, the report: markdown tables and the figure of what the probes measured.

Each table says what it shows; the figures they print are quoted in ``docs/design.md`` 4 and
7.2 and the README's regime map. Run through ``benchmarks/regime_map.py``.
"""

from __future__ import annotations

import math

import numpy as np
from regime_analysis import (
    GATE,
    GATE_DRAGS,
    GATE_STD,
    STRAIGHT_PRESS,
    bias_ratios,
    drag_sweep,
    p95,
    passes,
    pool,
)
from regime_experiment import (
    ALPHAS,
    AVERAGE,
    LID_ANGLE,
    LINK_TRAVEL,
    OBLIQUE_DIRS,
    SHEARS,
    Readings,
)

from tactile_gym.perception.gate import drag_bias, friction_free


def deg(x: float, digits: int = 1) -> str:
    """An angle in rad as degrees, "—" for NaN."""
    return "—" if not np.isfinite(x) else f"{math.degrees(x):.{digits}f}"


def mm(x: float, digits: int = 1) -> str:
    return "—" if not np.isfinite(x) else f"{1e3 * x:+.{digits}f}"


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def print_presses(shears, forces, offsets) -> None:
    print("\n### 1a. Presses along the face normal (no shear); cells: 2 · 5 · 8 N\n")
    rows = []
    for off in offsets:
        cells = [[] for _ in range(8)]
        for force in forces:
            r = shears[(force, off, None, 0.0)]
            med, p, flagged = r.single.stats()
            med10, p10, _ = r.mean.stats()
            cells[0].append(deg(r.tilt))
            cells[1].append(deg(r.error))
            cells[2].append(f"{deg(med)}/{deg(p)}")
            cells[3].append(f"{deg(med10)}/{deg(p10)}")
            cells[4].append(f"{100 * flagged:.0f}")
            cells[5].append(deg(r.deviation, 2))
            cells[6].append(f"{1e3 * r.travel:.2f} ({r.travel_ratio:.1f})")
            cells[7].append(mm(r.point_offset))
        rows.append([mm(off)] + [" · ".join(c) for c in cells])
    print(
        table(
            [
                "offset (mm)",
                "tilt (deg)",
                "error (deg)",
                "single med/P95 (deg)",
                f"mean of {AVERAGE} med/P95",
                "flagged (%)",
                "deviation (deg)",
                "travel, mm (/ flat-face travel)",
                "contact point across (mm)",
            ],
            rows,
        )
    )


def print_shear_map(shears, forces, offsets, thetas) -> None:
    for size in SHEARS:
        for force in forces:
            print(
                f"\n### 1b. Shear {1e3 * size:.1f} mm after a {force:.0f} N press: noise-free "
                "error (noisy P95), deg; — flagged\n"
            )
            rows = []
            for off in offsets:
                row = [mm(off)]
                for th in thetas:
                    r = shears[(force, off, th, size)]
                    _, p95, _ = r.noisy_stats()
                    row.append(f"{deg(r.error, 0)} ({deg(p95, 0)})")
                rows.append(row)
            print(table(["offset (mm) \\ theta (deg)"] + [str(t) for t in thetas], rows))


def print_oblique(obl, force, offsets) -> None:
    print(
        f"\n### 2. Oblique presses at {force:.0f} N: noise-free error / drag (deg), by path "
        "angle alpha\n"
    )
    rows = []
    for toward in OBLIQUE_DIRS:
        for off in offsets:
            row = [toward, mm(off), deg(obl[(force, toward, off, 0.0)].tilt)]
            for a in ALPHAS:
                r = obl[(force, toward, off, a)]
                row.append(f"{deg(r.error)} / {deg(r.drag, 2)}")
            rows.append(row)
    print(table(["path tilted", "offset (mm)", "tilt (deg)"] + [f"{a:g}" for a in ALPHAS], rows))


def _cell(p, keep) -> str:
    return f"{deg(p95(p['errors'][keep]))} ({100 * keep.mean():.0f} %)"


def gate_sweep(readings, label) -> dict[str, dict[float, float]]:
    """Print the P95 of the error under drag <= A (and the gate's friction share); return
    {column: {A: P95}}."""
    print(
        f"\n### 3a. Gate on the drag, {label}: P95 of the edge error, deg (share passing), "
        f"deviation <= {GATE.friction_share:g} x tilt\n"
    )
    columns = {
        "noise-free": ("clean", math.inf),
        "single": ("single", math.inf),
        f"single, edge_std <= {GATE_STD:g}": ("single", GATE_STD),
        f"mean of {AVERAGE}": ("mean", math.inf),
        f"mean of {AVERAGE}, edge_std <= {GATE_STD:g}": ("mean", GATE_STD),
    }
    sweep = drag_sweep(readings, columns)
    out: dict[str, dict[float, float]] = {c: {} for c in columns}
    rows = []
    for a in GATE_DRAGS:
        row = ["any" if math.isinf(a) else f"{a:g}"]
        for name in columns:
            errors, keep = sweep[name][a]
            out[name][a] = p95(errors[keep])
            row.append(f"{deg(out[name][a])} ({100 * keep.mean():.0f} %)")
        rows.append(row)
    print(table(["drag <= (deg)", *columns], rows))
    return out


def print_friction_share(groups: dict[str, list[Readings]]) -> None:
    """Deviation / tilt: near 0 when the truncated patch tilts the force, >= 1 when friction
    does."""
    print(
        "\n### 3d. Friction share: deviation / tilt of the observable readings (noise-free; "
        f"single: share passing deviation <= {GATE.friction_share:g} tilt), and the error of those "
        "that pass and fail\n"
    )
    rows = []
    for name, readings in groups.items():
        clean = pool(readings, "clean")
        ok = clean["observables"].astype(bool)
        if not ok.any():
            continue
        ratio = clean["deviations"][ok] / clean["tilts"][ok]
        keep = passes(clean)
        fail = ok & ~keep
        single = pool(readings, "single")
        s_ok = single["observables"].astype(bool)
        rows.append(
            [
                name,
                str(int(ok.sum())),
                f"{ratio.min():.2f} / {np.median(ratio):.2f} / {ratio.max():.2f}",
                f"{100 * keep[ok].mean():.0f}",
                deg(np.max(clean["errors"][keep])) if keep.any() else "—",
                deg(np.min(clean["errors"][fail])) if fail.any() else "—",
                f"{100 * passes(single)[s_ok].mean():.0f}" if s_ok.any() else "—",
            ]
        )
    print(
        table(
            [
                "probes",
                "observable",
                "deviation/tilt min / median / max",
                "pass (%)",
                "largest error passing",
                "smallest error failing",
                "single readings pass (%)",
            ],
            rows,
        )
    )


def print_budget_gate(groups: dict[str, list[Readings]]) -> None:
    """The combined gate: drag rule bias + 2 edge_std within a budget, deviation bounded."""
    print(
        "\n### 3e. Combined gate: observable, deviation <= "
        f"{GATE.friction_share:g} x tilt, atan({GATE.drag_gain:g} tan(drag)/tan(tilt)) "
        "+ 2 edge_std <= budget. "
        "P95 of the error, deg (share passing)\n"
    )
    rows = []
    for name, readings in groups.items():
        row = [name]
        for kind in ("clean", "single", "mean"):
            p = pool(readings, kind)
            ok = p["observables"].astype(bool)
            row.append(_cell(p, ok))
            for budget in (3.0, 5.0):
                keep = passes(p, budget=math.radians(budget))
                row.append(_cell(p, keep))
        rows.append(row)
    header = ["probes"]
    for kind in ("noise-free", "single", f"mean of {AVERAGE}"):
        header += [f"{kind}: observable", "budget 3", "budget 5"]
    print(table(header, rows))


def print_bias_rule(groups: dict[str, list[Readings]]) -> None:
    print(
        "\n### 3b. The drag rule: noise-free error / "
        f"atan({GATE.drag_gain:g} tan(drag)/tan(tilt)), probes whose "
        f"error exceeds 1 deg and whose deviation is at most {GATE.friction_share:g} x tilt\n"
    )
    rows = []
    for name, readings in groups.items():
        ratio = bias_ratios(readings)
        if not len(ratio):
            continue
        q = np.quantile(ratio, [0.05, 0.5, 0.95])
        rows.append([name, str(len(ratio)), f"{q[1]:.2f}", f"{q[0]:.2f}-{q[2]:.2f}"])
    print(table(["probes", "count", "median ratio", "5-95 %"], rows))


def print_tilt_rule(obl, force, offsets) -> None:
    print(
        f"\n### 3c. Edge error against the tilt, {force:.0f} N along-edge presses: noise-free "
        f"error (rule with c = {STRAIGHT_PRESS:g}, a straight press / c = {GATE.drag_gain:g}, any "
        "path), deg\n"
    )
    rows = []
    for off in offsets:
        r0 = obl[(force, "along", off, 0.0)]
        row = [mm(off), deg(r0.tilt)]
        for a in ALPHAS[1:]:
            r = obl[(force, "along", off, a)]
            low = float(drag_bias(r.drag, r.tilt, STRAIGHT_PRESS))
            high = float(drag_bias(r.drag, r.tilt, GATE.drag_gain))
            row.append(f"{deg(r.error)} ({deg(low)}/{deg(high)})")
        rows.append(row)
    print(table(["offset (mm)", "tilt (deg)"] + [f"alpha {a:g}" for a in ALPHAS[1:]], rows))
    print(
        "\nLeast tilt (deg) that keeps the bias of a residual drag under 1 / 3 / 5 deg, "
        f"tilt = atan(c tan(drag) / tan(bias)): straight press (c = {STRAIGHT_PRESS:g}) / any "
        f"path (c = {GATE.drag_gain:g})\n"
    )
    rows = []
    for d in (0.1, 0.25, 0.5, 1.0):
        cells = []
        for b in (1.0, 3.0, 5.0):
            tb = math.tan(math.radians(b))
            lo, hi = (
                math.atan(c * math.tan(math.radians(d)) / tb)
                for c in (STRAIGHT_PRESS, GATE.drag_gain)
            )
            cells.append(f"{math.degrees(lo):.1f} / {math.degrees(hi):.1f}")
        rows.append([f"{d:g}", *cells])
    print(table(["drag (deg)", "bias 1 deg", "bias 3 deg", "bias 5 deg"], rows))


def print_slides(slides) -> None:
    print(
        "\n### 4. Slides along the edge (8 mm at constant height, first 2 mm left out): line "
        "through the contact points; angles in deg\n"
    )
    rows = []
    for (force, off, gam), s in slides.items():
        rows.append(
            [
                f"{force:g}",
                mm(off),
                f"{gam:+g}",
                deg(s.fit_error, 2),
                f"{deg(np.median(s.fit_errors), 2)}/{deg(p95(s.fit_errors), 2)}",
                deg(s.fit_std, 1),
                deg(s.along),
                deg(s.across, 2),
                f"{math.degrees(s.across_slope) * 1e-3:+.2f} "
                f"({math.degrees(np.median(np.abs(s.across_slopes))) * 1e-3:.2f})",
                f"{s.drift:+.3f} ({np.median(np.abs(s.drifts)):.3f})",
                f"{mm(s.point_offset[0], 2)}->{mm(s.point_offset[1], 2)}",
                f"{mm(s.centroid_offset[0], 2)}->{mm(s.centroid_offset[1], 2)}",
                deg(s.wrench_error, 0),
            ]
        )
    print(
        table(
            [
                "force (N)",
                "offset (mm)",
                "gamma (deg)",
                "fit error",
                "noisy med/P95",
                "trace std",
                "along tilt",
                "across tilt",
                "across-tilt slope, deg/mm (noisy |.|)",
                "drift mm/mm (noisy |.|)",
                "contact point across (mm)",
                "true centroid across (mm)",
                "one-wrench error",
            ],
            rows,
        )
    )


def print_link(runs) -> None:
    print(
        f"\n### 5. A link that gives way: 5 N press along the face normal at offset 0 on a lid "
        f"opened {math.degrees(LID_ANGLE):.0f} deg (its axis horizontal: the press turns it), "
        f"giving up {1e3 * LINK_TRAVEL:.0f} mm past touchdown; then 1 s with the fingertip "
        "still\n"
    )
    rows = []
    for h, r in runs.items():
        e = r.end
        med, p, _ = e.noisy_stats()
        rows.append(
            [
                f"{h:g}",
                f"{math.degrees(r.turn):.2f}",
                f"{e.force:.2f}",
                f"{1e3 * e.travel:.2f} ({e.travel_ratio:.1f})",
                deg(e.drag, 2),
                deg(e.deviation, 2),
                deg(e.tilt),
                deg(e.error),
                f"{deg(med)}/{deg(p)}",
                f"{math.degrees(r.turn_hold):.3f}",
                f"{r.force_change:+.3f}",
                f"{1e3 * r.drift:.3f} ({1e3 * np.median(r.drifts):.3f})",
            ]
        )
    print(
        table(
            [
                "holding (N m)",
                "turn in press (deg)",
                "|f| (N)",
                "travel, mm (/ flat-face)",
                "drag",
                "deviation",
                "tilt",
                "error",
                "noisy med/P95",
                "turn in hold (deg)",
                "|f| change in hold (N)",
                "contact drift mm/s (noisy)",
            ],
            rows,
        )
    )


def print_summary(shears, obl, links) -> None:
    """The gate this benchmark supports, with the numbers it rests on."""
    held = [r for k, r in shears.items() if k[3] == 0.0] + list(obl.values())
    ratio_held = max(r.travel_ratio for r in held if r.travel > 0)
    gave = [r.end.travel_ratio for r in links.values() if abs(r.turn) > math.radians(0.1)]
    print("\n### Gate supported here (observables only; tables 1a, 3a-3e, 5)\n")
    print(
        "1. `edge_observable` (tilt_snr > 3).\n"
        f"2. Friction share: deviation <= {GATE.friction_share:g} x tilt (deviation: path since "
        "touchdown vs force line).\n"
        f"3. Drag bias plus noise: atan({GATE.drag_gain:g} tan(drag)/tan(tilt)) + 2 edge_std <= "
        "budget (drag: path-force angle along the measured edge).\n"
        f"4. A press's travel since touchdown <= {GATE.max_travel_ratio:g} x a flat-face press's "
        f"to the same force (presses on the held link here: at most {ratio_held:.1f}; links that "
        "gave way: " + (", ".join(f"{g:.1f}" for g in gave) if gave else "none in this run") + ")."
    )


# --- figure -------------------------------------------------------------------------------------

BOUNDS = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 45.0, 90.0)  # deg, colour bins


def plot(path, shears, obl, slides, forces, offsets, thetas) -> None:
    """Heat maps of the shear map and the gate's support; writes a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm

    cmap = plt.get_cmap("YlOrRd", len(BOUNDS) - 1).copy()
    cmap.set_bad("0.8")
    norm = BoundaryNorm(BOUNDS, cmap.N)
    fig, axes = plt.subplots(
        4, len(forces), figsize=(4.4 * len(forces), 15.0), layout="constrained"
    )
    cols = [None, *thetas]
    y = 1e3 * np.array(offsets)
    panels = [
        (SHEARS[0], False, f"noise-free, shear {1e3 * SHEARS[0]:.1f} mm"),
        (SHEARS[0], True, f"noisy P95, shear {1e3 * SHEARS[0]:.1f} mm"),
        (SHEARS[1], False, f"noise-free, shear {1e3 * SHEARS[1]:.0f} mm (slips)"),
    ]
    for row, (size, noisy, title) in enumerate(panels):
        for j, force in enumerate(forces):
            ax = axes[row, j]
            grid = np.full((len(offsets), len(cols)), np.nan)
            flagged = np.zeros_like(grid, dtype=bool)
            for i, off in enumerate(offsets):
                for k, th in enumerate(cols):
                    r = shears[(force, off, th, 0.0 if th is None else size)]
                    if noisy:
                        _, value, frac = r.noisy_stats()
                        flagged[i, k] = frac > 0.5
                    else:
                        value, flagged[i, k] = r.error, not r.observable
                    grid[i, k] = math.degrees(value) if np.isfinite(value) else np.nan
            ax.pcolormesh(
                np.arange(len(cols) + 1) - 0.5,
                np.concatenate([y - 0.5, [y[-1] + 0.5]]),
                np.ma.masked_invalid(grid),
                cmap=cmap,
                norm=norm,
            )
            ii, kk = np.nonzero(flagged)
            ax.plot(kk, y[ii], "x", color="0.3", ms=4)
            ax.axvline(0.5, color="k", lw=1)
            ax.axhline(0.0, color="k", lw=0.5, ls=":")
            ax.set_xticks(range(len(cols)))
            ax.set_xticklabels(["none"] + [str(t) if t in (90, 180, 270) else "" for t in thetas])
            ax.set_title(f"{force:.0f} N: {title}", fontsize=9)
            if j == 0:
                ax.set_ylabel("centre offset across the edge (mm)")
            if row == len(panels) - 1:
                ax.set_xlabel("shear direction from across-edge outward (deg)")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(
        sm, ax=axes[:3, -1].tolist(), label="edge error (deg); grey/x: flagged", shrink=0.5
    )

    # Gate support: error against the drag and against the rule; slide traces. Probes whose
    # tilt is mostly friction (the gate's friction share fails) in grey.
    probes = {
        "o": [r for r in obl.values() if r.observable and r.drag > 0],
        "s": [r for k, r in shears.items() if k[3] == SHEARS[0] and r.observable and r.drag > 0],
    }
    shared = {m: [friction_free(r.deviation, r.tilt, GATE) for r in rs] for m, rs in probes.items()}
    ax = axes[3, 0]
    for marker, rs in probes.items():
        ok = np.array(shared[marker])
        x = np.degrees([r.drag for r in rs])
        y = np.degrees([r.error for r in rs])
        ax.scatter(x[~ok], y[~ok], s=6, marker=marker, c="0.75")
        sc = ax.scatter(
            x[ok],
            y[ok],
            c=np.degrees([r.tilt for r in rs])[ok],
            s=7,
            marker=marker,
            cmap="viridis",
            vmin=0.0,
            vmax=20.0,
        )
    fig.colorbar(sc, ax=ax, label="tilt (deg)")
    d = np.logspace(-2, 1, 50)
    for t in (4.0, 8.0, 14.0):
        ax.plot(
            d, np.degrees(drag_bias(np.radians(d), np.radians(t), GATE.drag_gain)), "k--", lw=0.7
        )
        ax.text(
            d[-1],
            math.degrees(drag_bias(math.radians(d[-1]), math.radians(t), GATE.drag_gain)),
            f"{t:g}",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.005, 10)
    ax.set_ylim(0.01, 90)
    ax.set_xlabel("drag: path-force angle along the edge (deg)")
    ax.set_ylabel("noise-free edge error (deg)")
    ax.set_title(
        "o: oblique presses, s: 0.1 mm shears, grey: friction share > "
        f"{GATE.friction_share:g}\n--: rule at tilt 4/8/14 deg",
        fontsize=9,
    )

    ax = axes[3, 1]
    for marker, rs in probes.items():
        ok = np.array(shared[marker])
        x = np.degrees([float(drag_bias(r.drag, r.tilt, GATE.drag_gain)) for r in rs])
        y = np.degrees([r.error for r in rs])
        ax.scatter(x[~ok], y[~ok], s=6, marker=marker, c="0.75")
        ax.scatter(
            x[ok],
            y[ok],
            s=7,
            marker=marker,
            c="C0" if marker == "o" else "C3",
            label={"o": "oblique presses", "s": "0.1 mm shears"}[marker],
        )
    x = np.array([0.01, 90.0])
    ax.plot(x, x, "k--", lw=0.7, label="error = rule")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.01, 90)
    ax.set_ylim(0.01, 90)
    ax.set_xlabel(f"rule: atan({GATE.drag_gain:g} tan(drag) / tan(tilt)) (deg)")
    ax.set_ylabel("noise-free edge error (deg)")
    ax.set_title("the drag rule, noise-free (grey: friction share too large)", fontsize=9)
    ax.legend(fontsize=7)

    ax = axes[3, 2] if len(forces) > 2 else axes[3, -1]
    five = {(o, g): v for (f, o, g), v in slides.items() if f == 5.0}
    for off in sorted({k[0] for k in five}):
        gs = sorted(g for (o, g) in five if o == off)
        ax.plot(
            gs,
            [math.degrees(five[(off, g)].fit_error) for g in gs],
            "o-",
            ms=3,
            label=f"{1e3 * off:+.0f} mm",
        )
    g = np.array(sorted({k[1] for k in five}))
    ax.plot(g, np.abs(g), "k--", lw=0.7, label="path")
    ax.set_xlabel("slide path off the edge, outward + (deg)")
    ax.set_ylabel("line-fit error (deg)")
    ax.set_title("slides, 5 N: line through the contact points", fontsize=9)
    ax.legend(fontsize=7)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=65)
    plt.close(fig)
