"""The Table I reproduction: it runs, finds the edge by touch, and does not lean on the truth.

Ground truth (the edge line, the true wrench) is read here only to check the protocol.
"""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from agents import paper_finger as pf
from agents import reproduce_paper as rp
from agents.paper_scene import HAND_HOLD_TORQUE
from tactile_gym.sim import ObjectConfig, ProbeScene, SensorConfig, SkinConfig

NOMINAL = rp.NominalLayout.of(rp.condition_object("nominal"))


@pytest.fixture(scope="module")
def scene():
    with rp.make_scene("nominal") as s:
        yield s


def _true_edge(scene):
    """Edge point, unit edge direction and unit outward direction (away from the pin)."""
    point, direction = scene.edge_line
    outward = np.cross(direction, [0.0, 0.0, 1.0])
    if (point - scene.true_axis[0]) @ outward < 0:
        outward = -outward
    return point, direction, outward


def test_reduced_run_writes_table1(tmp_path):
    argv = ["--trials", "1", "--schemes", "paper", "--variants", "noise_x2", "--out", str(tmp_path)]
    results = rp.main(argv)
    table = json.loads((tmp_path / "table1.json").read_text())
    cells = [f"paper/{case}" for case in rp.CASES]
    assert set(table) == set(cells) | {f"noise_x2/{cell}" for cell in cells}
    for cell in table.values():
        assert set(cell) == {"proposed_mm", "simple_mm"}
        assert len(cell["proposed_mm"]) == len(cell["simple_mm"]) == 1
    assert (tmp_path / "table1.md").exists()
    assert (tmp_path / "fig_slides.png").exists() and (tmp_path / "fig_fixed.png").exists()
    # The paper's finding in miniature: sliding contacts break the simple method only.
    sliding = results[("paper", "slides")]
    assert sliding["proposed_mm"][0] < 6.0 < 3 * 6.0 < sliding["simple_mm"][0]


def _finger(scene, rng, sensor="realistic"):
    return pf.Finger(scene, pf.log_header(scene, "nominal", sensor), rng)


@pytest.mark.parametrize("offset", [-0.008, -0.003, 0.005])
def test_edge_search_finds_the_edge_by_touch(scene, offset):
    rng = np.random.default_rng(0)
    scene.reset(0.3, [0.0, 0.1, 0.1], pf.DOWN, rng=rng)
    point, direction, outward = _true_edge(scene)
    start = (point + 0.04 * direction + offset * outward)[:2]
    # The search is told a direction across the edge 10 degrees off.
    c, s = math.cos(0.17), math.sin(0.17)
    told = np.array([c * outward[0] - s * outward[1], s * outward[0] + c * outward[1]])
    finger = _finger(scene, rng)
    pressed, _, presses = pf.find_edge(finger, start, told, NOMINAL)
    past = (pressed.centre - point) @ outward  # sphere centre past the edge line
    assert -0.001 < past < 0.002
    # The corrected point is the truncated patch's pressure centre, 0.9-3.1 mm inside the face
    # (docs/design.md 4.5).
    assert -0.0032 < (pressed.point - point) @ outward < 0.0
    assert math.degrees(math.acos(abs(pressed.edge @ direction))) < 3.0
    assert presses <= 5
    # The pipeline's gate measured the press the search ended on, on the readings it held:
    # as many as its hold rule asked for.
    rule = pf.GATE.hold_rule
    assert pressed.measurement is not None
    assert finger.pipeline.measurements == [pressed.measurement]
    assert rule.least <= pressed.readings <= rule.budget
    np.testing.assert_allclose(pressed.measurement.point, pressed.point, atol=1e-12)


def test_press_stops_on_the_noisy_reading():
    # A force bias of 1.5 N along the finger axis makes the reading 1.5 N higher than the
    # true force: untared, the press must stop on the reading, at a true 3.5 N.
    sensor = SensorConfig.ideal(force_bias=(0.0, 0.0, -1.5))
    config = ObjectConfig.scissors(holding_torque=HAND_HOLD_TORQUE)
    with ProbeScene(config, SkinConfig(), sensor) as biased:
        biased.reset(0.0, [0.06, 0.105, 0.05], pf.DOWN)
        targets = []
        step = biased.control_step

        def recording_step(position, orientation):
            targets.append(np.array(position))
            return step(position, orientation)

        biased.control_step = recording_step
        xy = np.array([0.06, 0.105])  # the middle of the grip's top face
        finger = _finger(biased, np.random.default_rng(0), "ideal")
        pressed = pf.press(finger, xy, NOMINAL, tare=False)
        assert pressed.touched
        assert abs(np.linalg.norm(pressed.wrench[:3]) - 5.0) <= pf.PRESS.tolerance
        assert 3.1 < np.linalg.norm(biased.true_wrench[:3]) < 3.9
        # A pure press: every target below the travel height is straight over xy.
        low = [t for t in targets if t[2] < targets[-1][2] + 0.001]
        assert np.allclose([t[:2] for t in low], xy, atol=1e-12)


def test_proposed_method_does_not_need_the_true_layout():
    # The operator's nominal layout off by 3 mm and 6 degrees: the search still finds the
    # edge by touch, and the estimate stays accurate.
    guess = replace(NOMINAL, hinge=(0.020, 0.102), heading=math.radians(6.0))
    results = rp.reproduce(trials=2, schemes=("paper",), nominal=guess)
    for case in rp.CASES:
        assert max(results[("paper", case)]["proposed_mm"]) < 6.0
    sliding = results[("paper", "slides")]
    assert np.mean(sliding["simple_mm"]) > 3 * np.mean(sliding["proposed_mm"])


def test_sensor_choice_and_the_tare_before_each_press():
    # --sensor picks the scene's sensor; a condition's sensor_model overrides it.
    with rp.make_scene("nominal", "offset") as scene:
        assert scene.sensor_config == rp.SENSORS["offset"]
    with rp.make_scene("ideal") as scene:
        assert scene.sensor_config == SensorConfig.ideal()
    # A tared press on the realistic sensor (offset, weight) stops at the true 5 N.
    config = ObjectConfig.scissors(holding_torque=HAND_HOLD_TORQUE)
    with ProbeScene(config, SkinConfig(), SensorConfig()) as scene:
        rng = np.random.default_rng(0)
        scene.reset(0.0, [0.05, 0.105, 0.05], pf.DOWN, rng=rng)
        finger = _finger(scene, rng)
        pressed = pf.press(finger, np.array([0.06, 0.105]), NOMINAL)
        assert pressed.touched and len(finger.pipeline.tares) == 1
        assert abs(np.linalg.norm(scene.true_wrench[:3]) - 5.0) <= pf.PRESS.tolerance + 0.1
        # The tare was taken in free air over the press, after moving there from 10 mm
        # away: the later the tare, the less the sensor drifts before the press is read.
        tared = [sample for sample in finger.samples if sample.tare]
        assert len(tared) == 1
        np.testing.assert_allclose(tared[0].position[:2], [0.06, 0.105], atol=1e-9)
    with pytest.raises(SystemExit):
        rp.main(["--sensor", "perfect"])


def test_table1_from_its_logs_equals_table1_direct(tmp_path):
    logs = tmp_path / "logs"
    argv = ["--trials", "1", "--schemes", "paper", "--no-plot", "--record-logs", str(logs)]
    direct = rp.main([*argv, "--out", str(tmp_path / "direct")])
    assert len(list(logs.glob("*.npz"))) == len(list(logs.glob("*.truth.json"))) == 2
    replayed = rp.main(["--logs", str(logs), "--no-plot", "--out", str(tmp_path / "replayed")])
    for name in ("table1.json", "table1.md"):
        assert (tmp_path / "direct" / name).read_text() == (
            tmp_path / "replayed" / name
        ).read_text()
    for key, cell in direct.items():
        for a, b in zip(cell["trials"], replayed[key]["trials"]):
            np.testing.assert_array_equal(a.points, b.points)
            np.testing.assert_array_equal(a.proposed, b.proposed)
            assert len(a.points) == len(a.presses)  # every measurement press accepted
    with pytest.raises(ValueError, match="no trial logs"):
        rp.from_logs(tmp_path / "direct")


def test_a_skin_twice_as_stiff_as_configured_no_longer_stops_the_protocol(tmp_path):
    # Issue 26: the press assumed 6000 N/m and never settled on this skin.
    argv = ["--trials", "1", "--schemes", "paper", "--no-plot", "--out", str(tmp_path)]
    results = rp.main([*argv, "--world", "skin_stiffness=2"])
    for case in rp.CASES:
        assert results[("paper", case)]["proposed_mm"][0] < 6.0


def test_world_factors_change_the_world_not_the_sensing():
    world = rp.parse_world("skin_stiffness=2, noise=4 drift=0.5")
    assert world == {"skin_stiffness": 2.0, "noise": 4.0, "drift": 0.5}
    with rp.make_scene("nominal", world=world) as scene:
        header = pf.log_header(scene, "nominal")
        configured = SensorConfig()
        assert scene.skin_config.normal_stiffness == 2 * SkinConfig().normal_stiffness
        assert scene.sensor_config.force_noise_std == 4 * configured.force_noise_std
        assert scene.sensor_config.moment_drift == 0.5 * configured.moment_drift
        assert header.skin_stiffness == SkinConfig().normal_stiffness
        assert header.sensor_config() == configured
    for text, match in [
        ("stiffness=2", "--world takes"),
        ("noise=0", "factor"),
        ("noise=x", "factor"),
    ]:
        with pytest.raises(ValueError, match=match):
            rp.parse_world(text)
