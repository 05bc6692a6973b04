"""The drawer's Table I: it runs, its finger finds the drawer's edges by touch, and the edge
lines keep the slide's direction where the contact points lose it.

Ground truth (the drawer's edge line and direction) is read here only to check the protocol.
"""

import json

import numpy as np
import pytest

from agents import reproduce_drawer as rd
from tactile_gym.sim import ProbeScene, SensorConfig

LAYOUT = rd.DrawerLayout()


def test_reduced_run_writes_the_table(tmp_path):
    results = rd.main(["--trials", "2", "--out", str(tmp_path)])
    summary = json.loads((tmp_path / "drawer.json").read_text())
    assert set(summary) == set(rd.CASES)
    for case in rd.CASES:
        assert len(summary[case]["proposed_deg"]) == len(summary[case]["simple_deg"]) == 2
    assert "| slides |" in (tmp_path / "drawer.md").read_text()
    # The target in miniature: the edge lines within 1.5 deg whatever the contact
    # does; the contact points as good only while the contact stays put.
    for case in rd.CASES:
        assert all(np.degrees(t.proposed) < 1.5 for t in results[case])
        assert not any(t.degenerate[0] for t in results[case])
    assert all(np.degrees(t.simple) < 1.5 for t in results["fixed"])
    sliding = results["slides"]
    assert np.mean([t.simple for t in sliding]) > 3 * np.mean([t.proposed for t in sliding])


@pytest.mark.parametrize("slides", [True, False])
def test_the_finger_measures_the_true_edges(slides):
    """The front edge's measurements lie just inside the drawer's true front edge at their
    displacement, along its true direction; the side edge's on one line along the slide;
    the contact stays at one place of the drawer on each edge only in the fixed case."""
    scene = ProbeScene(LAYOUT.drawer(LAYOUT.yaw), sensor_config=SensorConfig(), physics="v3")
    try:
        trial = rd.run_trial(scene, LAYOUT, slides, np.random.default_rng(3))
        front, across = scene.edge_line  # at the last displacement
        out = scene.true_axis[1]
    finally:
        scene.close()
    assert np.all(np.isfinite(trial.points))
    # Where each contact is on the drawer: moved back to the last displacement.
    shifted = trial.points + (rd.DISPLACEMENTS - 1 - trial.configs)[:, None] * rd.PULL * out
    on_front = trial.lines == 0
    # The truncated patch's pressure centre, 0.9-3.1 mm inside the face (docs/design.md 4.5).
    inside = (shifted[on_front] - front) @ out
    assert np.all((-0.0032 < inside) & (inside < 0.0))
    assert np.all(np.abs(trial.edges[on_front] @ across) > np.cos(np.radians(3.0)))
    side = shifted[~on_front, :2] @ across[:2]
    assert np.ptp(side) < 0.002
    for line, direction in ((0, across), (1, out)):
        spread = np.ptp(shifted[trial.lines == line, :2] @ direction[:2])
        assert (spread > 0.003) if slides else (spread < 0.002)
