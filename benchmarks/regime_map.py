"""Regime map: when does the edge measured from one wrench hold?

Run: ``python benchmarks/regime_map.py [--quick] [--readings N] [--seed S] [--figure PATH]
[--save PATH] [--physics v2|v3]``. Prints markdown tables and writes
``docs/figures/regime_map.png``; ``--quick`` runs a coarse grid for iteration; ``--physics``
chooses the contact step (``tactile_gym.sim.scene.PHYSICS``, default v2). Single process,
single thread.

Three parts: the experiment (``regime_experiment``: probes of the scissors' free link near
its edge with the shared press, read as the env reads a wrench), the analysis
(``regime_analysis``: the env gate's own rules on those readings) and the report
(``regime_report``: tables and the figure). Sections:

1. Presses and the shear map: press to 2 / 5 / 8 N along the face normal, then move the
   fingertip sideways at constant height by ``SHEARS`` (the skin sticks, then slips) in the
   direction ``theta`` from the across-edge outward direction toward the edge direction.
2. Oblique presses: the press path tilted ``alpha`` from the face normal along the edge or
   across it.
3. The gate: thresholds on the drag (3a), the drag rule (3b), the tilt (3c), the friction
   share (3d) and the combined gate on every probe (3e).
4. Slides along the edge with a contact-point trace, the path ``gamma`` off the edge.
5. A lid (axis horizontal) that gives way under the press.

The figures it measured are in ``docs/design.md`` 4 and 7.2 and the README.
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from regime_analysis import GATE_DRAGS  # noqa: E402
from regime_experiment import (  # noqa: E402
    ALONG,
    FORCES,
    GAMMAS,
    HELD,
    HOLDING,
    OBLIQUE_OFFSETS,
    OFFSETS,
    QUICK,
    SHEARS,
    SLIDE_OFFSETS,
    THETAS,
    link_run,
    oblique_presses,
    shear_map,
    slide,
)
from regime_report import (  # noqa: E402
    gate_sweep,
    plot,
    print_bias_rule,
    print_budget_gate,
    print_friction_share,
    print_link,
    print_oblique,
    print_presses,
    print_shear_map,
    print_slides,
    print_summary,
    print_tilt_rule,
    table,
)

from tactile_gym.sim import ObjectConfig, ProbeScene  # noqa: E402
from tactile_gym.sim.scene import PHYSICS  # noqa: E402

FIGURE = Path(__file__).resolve().parents[1] / "docs" / "figures" / "regime_map.png"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="coarse grid, for iteration")
    parser.add_argument("--readings", type=int, default=None, help="noisy readings per probe")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--figure", type=Path, default=FIGURE, help="PNG to write")
    parser.add_argument("--no-figure", action="store_true")
    parser.add_argument("--save", type=Path, default=None, help="pickle the results here")
    parser.add_argument("--physics", default="v2", choices=PHYSICS, help="the contact step")
    args = parser.parse_args(argv)
    grid = dict(
        OFFSETS=OFFSETS,
        THETAS=THETAS,
        OBLIQUE_OFFSETS=OBLIQUE_OFFSETS,
        GAMMAS=GAMMAS,
        SLIDE_OFFSETS=SLIDE_OFFSETS,
        HOLDING=HOLDING,
    )
    if args.quick:
        grid.update(QUICK)
    n_read = args.readings or (10 if args.quick else 40)
    t0 = time.perf_counter()
    shown = sys.argv[1:] if argv is None else argv
    print(f"`{' '.join(['python', f'benchmarks/{Path(__file__).name}', *shown])}`")
    rng = np.random.default_rng(args.seed)
    scene = ProbeScene(ObjectConfig.scissors(holding_torque=HELD), physics=args.physics)
    offsets, thetas = grid["OFFSETS"], grid["THETAS"]
    shears = shear_map(scene, rng, n_read, FORCES, offsets, thetas)
    obl = oblique_presses(scene, rng, n_read, FORCES, grid["OBLIQUE_OFFSETS"])
    slides = {
        (5.0, off, gam): slide(scene, rng, max(4, n_read // 4), off, math.radians(gam))
        for off in grid["SLIDE_OFFSETS"]
        for gam in grid["GAMMAS"]
    }
    for force in (2.0, 8.0):
        for off in grid["SLIDE_OFFSETS"][-2:]:
            slides[(force, off, 0.0)] = slide(scene, rng, max(4, n_read // 4), off, 0.0, force)
    links = {h: link_run(scene, rng, n_read, max(4, n_read // 4), h) for h in grid["HOLDING"]}
    scene.close()
    t_sim = time.perf_counter() - t0
    if args.save is not None:
        with open(args.save, "wb") as fh:
            pickle.dump(dict(shears=shears, oblique=obl, slides=slides, links=links), fh)
    turn = max(abs(r.joint) for r in [*shears.values(), *obl.values()])
    print(
        f"\nScissors free link held by {HELD} N m (largest joint turn {math.degrees(turn):.4f} "
        f"deg), probe {1e3 * ALONG:.0f} mm from the pin, {n_read} noisy readings per probe "
        "(sensor noise 0.02 N, 5e-4 N m), seed "
        f"{args.seed}. Offsets: sphere centre across the edge, + beyond it. Errors in deg."
    )
    print_presses(shears, FORCES, offsets)
    print_shear_map(shears, FORCES, offsets, thetas)
    for force in FORCES:
        print_oblique(obl, force, grid["OBLIQUE_OFFSETS"])
    along = [r for k, r in obl.items() if k[1] == "along"]
    sweeps = {
        "along-edge oblique presses": gate_sweep(along, "along-edge oblique presses"),
        "all oblique presses": gate_sweep(list(obl.values()), "all oblique presses"),
    }
    print("\nLargest drag threshold (deg) whose P95 stays under 3 / 5 deg:\n")
    rows = []
    for label, sweep in sweeps.items():
        for column, by_drag in sweep.items():
            best = []
            for bound in (3.0, 5.0):
                ok = [a for a in GATE_DRAGS if by_drag[a] < math.radians(bound)]
                best.append(("any" if math.isinf(max(ok)) else f"{max(ok):g}") if ok else "none")
            rows.append([label, column, *best])
    print(table(["population", "readings", "P95 < 3", "P95 < 5"], rows))
    print_bias_rule(
        {
            "presses along the edge, alpha > 0": [
                r for k, r in obl.items() if k[1] == "along" and k[3] > 0
            ],
            "presses across the edge, alpha > 0": [
                r for k, r in obl.items() if k[1] != "along" and k[3] > 0
            ],
            f"shear {1e3 * SHEARS[0]:.1f} mm": [r for k, r in shears.items() if k[3] == SHEARS[0]],
        }
    )
    print_tilt_rule(obl, 5.0, grid["OBLIQUE_OFFSETS"])
    groups = {
        "presses, no shear": [r for k, r in shears.items() if k[3] == 0.0],
        "presses across the edge, alpha > 0": [
            r for k, r in obl.items() if k[1] != "along" and k[3] > 0
        ],
        "presses along the edge, alpha > 0": [
            r for k, r in obl.items() if k[1] == "along" and k[3] > 0
        ],
        f"shear {1e3 * SHEARS[0]:.1f} mm": [r for k, r in shears.items() if k[3] == SHEARS[0]],
        f"shear {1e3 * SHEARS[1]:.0f} mm (slips)": [
            r for k, r in shears.items() if k[3] == SHEARS[1]
        ],
        "lid, all holding torques": [r.end for r in links.values()],
    }
    print_friction_share(groups)
    print_budget_gate(groups)
    print_slides(slides)
    print_link(links)
    print_summary(shears, obl, links)
    if not args.no_figure:
        plot(args.figure, shears, obl, slides, FORCES, offsets, thetas)
        print(f"\nFigure: {args.figure} ({args.figure.stat().st_size / 1e3:.0f} kB)")
    print(
        f"\nTook {time.perf_counter() - t0:.0f} s ({t_sim:.0f} s simulating), "
        f"{len(shears) + len(obl)} probes, {len(slides)} slides, {len(links)} link runs."
    )


if __name__ == "__main__":
    main()
