"""The env's parts in isolation: reward task, measurement gate, controller, start scenarios."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tactile_gym  # noqa: F401 - registers the envs
from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.measurement import GateConfig, MeasurementGate
from tactile_gym.envs.scenarios import ScenarioConfig, probed_edge, sample_scenario
from tactile_gym.envs.task import AxisEstimationTask, TaskConfig
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.sim import ProbeScene
from tactile_gym.sim.config import FAMILIES

# --------------------------------------------------------------------------- task


def test_error_reduction_telescopes_to_total_reduction():
    cfg = TaskConfig()
    task = AxisEstimationTask(cfg)
    task.initialize_episode()
    errors = [(np.inf, np.pi / 2), (0.08, 0.1), (0.03, 0.02), (0.05, 0.0), (0.004, 0.001)]
    total = sum(
        task.get_reward(p, a, max_force=0.0, action=np.zeros(6))[1]["reward_error_reduction"]
        for p, a in errors
    )
    final = errors[-1][0] + cfg.error_angle_scale * errors[-1][1]
    assert total == pytest.approx((cfg.error_cap - final) / cfg.error_scale)


def test_penalties_and_cap():
    cfg = TaskConfig(force_limit=8.0, force_penalty=0.1, action_cost=0.001)
    task = AxisEstimationTask(cfg)
    reward, terms = task.get_reward(0.5, 0.0, max_force=12.0, action=np.ones(6))
    assert terms["reward_error_reduction"] == 0.0  # 0.5 m is capped at E_max, as is the start
    assert terms["reward_force_penalty"] == pytest.approx(-0.1 * 4.0 / 8.0)
    assert terms["reward_action_cost"] == pytest.approx(-0.006)
    assert reward == pytest.approx(sum(terms.values()))
    assert task.is_success(0.0019, np.deg2rad(1.9))
    assert not task.is_success(0.0021, 0.0)
    assert not task.is_success(0.001, np.deg2rad(2.1))


# --------------------------------------------------------------------------- gate

EDGE = np.array([1.0, 0.0, 0.0])
DOWN = np.array([0.0, 0.0, -5.0])


def _gate(**kw) -> MeasurementGate:
    return MeasurementGate(GateConfig(**kw))


def test_gate_accepts_a_fresh_tilted_press_once():
    gate = _gate(trace_length=0.0)
    p = np.zeros(3)
    assert gate.offer(True, DOWN, p, EDGE, 0.02)[0].source == "wrench"
    # The same contact again: nothing new.
    assert gate.offer(True, DOWN, p, EDGE, 0.02) == []
    # 1 mm further along: new.
    assert len(gate.offer(True, DOWN, p + [0.001, 0, 0], EDGE, 0.02)) == 1


@pytest.mark.parametrize(
    "valid, force, edge, std",
    [
        (False, DOWN, EDGE, 0.02),  # no contact
        (True, np.array([0, 0, -2.0]), EDGE, 0.02),  # force below the band
        (True, np.array([0, 0, -9.0]), EDGE, 0.02),  # force above the band
        (True, DOWN, np.full(3, np.nan), np.pi / 2),  # edge unobservable
        (True, DOWN, EDGE, np.deg2rad(8.0)),  # edge too uncertain
    ],
)
def test_gate_rejects(valid, force, edge, std):
    assert _gate(trace_length=0.0).offer(valid, force, np.zeros(3), edge, std) == []


def test_gate_rejects_wrench_edges_once_the_contact_has_slid():
    gate = _gate(trace_length=0.0)
    accepted = [gate.offer(True, DOWN, np.array([0.0005 * k, 0, 0]), EDGE, 0.02) for k in range(8)]
    # Accepted while the contact travelled at most 1.5 mm, never after.
    assert [bool(a) for a in accepted[:4]] == [True, False, True, False]
    assert not any(accepted[4:])
    # Lifting off makes the next contact fresh again.
    gate.offer(False, np.zeros(3), np.zeros(3), EDGE, np.pi)
    assert gate.offer(True, DOWN, np.array([0.01, 0, 0]), EDGE, 0.02)


def test_gate_signs_edges_by_continuity():
    gate = _gate(trace_length=0.0)
    first = gate.offer(True, DOWN, np.zeros(3), EDGE, 0.02)[0]
    gate.offer(False, np.zeros(3), np.zeros(3), EDGE, np.pi)
    turned = np.array([-np.cos(0.3), -np.sin(0.3), 0.0])
    second = gate.offer(True, DOWN, np.array([0.0, 0.01, 0.0]), turned, 0.02)[0]
    assert first.edge @ second.edge > 0


def _slide(gate, force_along: float, rng) -> list:
    """A 6 mm slide along x with a force whose component along the motion is given."""
    accepted = []
    for k in range(13):
        point = np.array([0.0005 * k, rng.normal(0, 5e-5), 0.0])
        force = np.array([-force_along, 0.0, -5.0])
        accepted += gate.offer(True, force, point, np.full(3, np.nan), np.pi / 2)
    return accepted


def test_gate_trace_from_a_slide_along_the_edge():
    rng = np.random.default_rng(0)
    traces = [m for m in _slide(_gate(), 1.5, rng) if m.source == "trace"]
    assert traces
    assert abs(traces[0].edge @ EDGE) > np.cos(np.deg2rad(3.0))


def test_gate_rejects_a_trace_whose_force_acts_along_the_motion():
    # A push that turns the link: the contact moves along the force.
    rng = np.random.default_rng(0)
    assert _slide(_gate(), 6.0, rng) == []


@pytest.mark.parametrize(
    "kw",
    [
        {"force_band": (5.0, 1.0)},
        {"max_edge_std": 0.0},
        {"trace_length": -1.0},
        {"trace_max_force_ratio": 1.5},
        {"max_contact_travel": 0.0},
    ],
)
def test_gate_config_validation(kw):
    with pytest.raises(ValueError):
        GateConfig(**kw)


# --------------------------------------------------------------------------- controller


def test_controller_scales_translation_and_rotates_about_the_tip():
    pivot = FingertipGeometry().sphere_center
    ctrl = DeltaPoseController(0.002, np.deg2rad(3.0), pivot)
    position = np.array([0.01, 0.02, 0.05])
    orientation = Rotation.from_euler("x", 170, degrees=True).as_quat()
    new_position, new_orientation = ctrl.target(np.r_[1.0, 0, 0, 0, 0, 0], position, orientation)
    np.testing.assert_allclose(new_position - position, [0.002, 0, 0], atol=1e-12)
    np.testing.assert_allclose(new_orientation, orientation, atol=1e-12)

    new_position, new_orientation = ctrl.target(np.r_[0, 0, 0, 0, 1.0, 0], position, orientation)
    tip_before = position + Rotation.from_quat(orientation).apply(pivot)
    tip_after = new_position + Rotation.from_quat(new_orientation).apply(pivot)
    np.testing.assert_allclose(tip_after, tip_before, atol=1e-12)
    turn = Rotation.from_quat(new_orientation) * Rotation.from_quat(orientation).inv()
    np.testing.assert_allclose(turn.as_rotvec(), [0, np.deg2rad(3.0), 0], atol=1e-12)


# --------------------------------------------------------------------------- scenarios


@pytest.mark.parametrize("family", FAMILIES)
def test_start_pose_is_free_and_points_at_the_edge(family):
    geometry = FingertipGeometry()
    rng = np.random.default_rng(5)
    scenario = sample_scenario(rng, (family,), ScenarioConfig(), geometry)
    scene = ProbeScene(scenario.object_config)
    try:
        scene.reset(
            scenario.joint_angle, scenario.fingertip_position, scenario.fingertip_orientation
        )
        assert np.linalg.norm(scene.true_wrench[:3]) == 0.0
        origin, direction, _, _ = probed_edge(scenario.object_config, scenario.joint_angle)
        edge_origin, edge_direction = scene.edge_line
        assert abs(direction @ edge_direction) == pytest.approx(1.0)
        # The finger axis passes within a millimetre of the edge line.
        tip = scene.sensor_to_world_point(geometry.sphere_center)
        axis = scene.sensor_to_world_vector(np.array([0.0, 0.0, 1.0]))
        gap = tip - edge_origin
        normal = np.cross(axis, edge_direction)
        assert abs(gap @ normal) / np.linalg.norm(normal) < 1e-3
    finally:
        scene.close()


def test_scenarios_follow_the_generator():
    geometry = FingertipGeometry()
    cfg = ScenarioConfig()
    a = sample_scenario(np.random.default_rng(3), FAMILIES, cfg, geometry)
    b = sample_scenario(np.random.default_rng(3), FAMILIES, cfg, geometry)
    c = sample_scenario(np.random.default_rng(4), FAMILIES, cfg, geometry)
    assert a.object_config == b.object_config and a.joint_angle == b.joint_angle
    assert (a.object_config, a.joint_angle) != (c.object_config, c.joint_angle)


@pytest.mark.parametrize(
    "kw",
    [
        {"joint_angle_range": (1.0, 0.0)},
        {"start_along_range": (0.5, 1.5)},
        {"approach_tilt": 2.0},
        {"holding_torque": -0.1},
    ],
)
def test_scenario_config_validation(kw):
    with pytest.raises(ValueError):
        ScenarioConfig(**kw)


# --------------------------------------------------------------------------- plotting


def test_plot_top_view(tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    from agents.scripted import ScriptedProbePolicy
    from tactile_gym.envs.plotting import plot_top_view

    env = gym.make("tactile_gym/HingeProbe-v0")
    policy = ScriptedProbePolicy.for_env(env.unwrapped)
    obs, _ = env.reset(seed=1000)
    for _ in range(160):
        obs, *_ = env.step(policy.get_action(obs))
    ax = plot_top_view(env.unwrapped)
    ax.figure.savefig(tmp_path / "top.png")
    assert (tmp_path / "top.png").stat().st_size > 0
    # Measurements and the estimate were drawn, not only the link and the truth.
    assert len(env.unwrapped.measurements) >= 3
    assert len(ax.lines) >= 3 + len(env.unwrapped.measurements)
    env.close()
