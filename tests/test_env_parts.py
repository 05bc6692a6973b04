"""Parts of the env on their own: controller, reset scenarios, prior, skills, plotting."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tactile_gym  # noqa: F401 - registers the envs
from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.scenarios import FAMILIES, ScenarioConfig, probed_edge, sample_scenario
from tactile_gym.estimation import AxisPrior
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.spatial import quaternion_to_matrix

# --------------------------------------------------------------------------- controller


def test_controller_scales_translation_and_rotates_about_the_tip():
    pivot = FingertipGeometry().sphere_center
    ctrl = DeltaPoseController(0.002, np.deg2rad(3.0), pivot)
    position = np.array([0.01, 0.02, 0.05])
    orientation = Rotation.from_euler("x", 170, degrees=True).as_quat()
    new_position, new_orientation = ctrl.target(np.r_[1.0, 0, 0, 0, 0, 0], position, orientation)
    np.testing.assert_allclose(new_position - position, [0.002, 0, 0], atol=1e-12)
    assert abs(new_orientation @ orientation) == pytest.approx(1.0, abs=1e-12)

    new_position, new_orientation = ctrl.target(np.r_[0, 0, 0, 0, 1.0, 0], position, orientation)
    tip_before = position + Rotation.from_quat(orientation).apply(pivot)
    tip_after = new_position + Rotation.from_quat(new_orientation).apply(pivot)
    np.testing.assert_allclose(tip_after, tip_before, atol=1e-12)
    turn = Rotation.from_quat(new_orientation) * Rotation.from_quat(orientation).inv()
    np.testing.assert_allclose(turn.as_rotvec(), [0, np.deg2rad(3.0), 0], atol=1e-12)


# --------------------------------------------------------------------------- scenarios


@pytest.mark.parametrize("family", FAMILIES)
def test_start_is_above_the_face_near_the_edge(family):
    geometry = FingertipGeometry()
    cfg = ScenarioConfig()
    rng = np.random.default_rng(5)
    for _ in range(20):
        s = sample_scenario(rng, (family,), cfg, geometry)
        origin, direction, side, top = probed_edge(s.object_config, s.joint_angle)
        if side[2] > top[2]:
            top, side = side, top
        rotation = quaternion_to_matrix(s.fingertip_orientation)
        centre = s.fingertip_position + rotation @ geometry.sphere_center
        gap = (centre - origin) @ top - geometry.outer_radius
        across = (centre - origin) @ side
        lo, hi = cfg.start_height_range
        assert lo - 1e-9 <= gap <= hi + 1e-9
        assert cfg.start_across_range[0] - 1e-9 <= across <= cfg.start_across_range[1] + 1e-9
        lean = np.degrees(np.arccos(np.clip(-(rotation[:, 2] @ top), -1, 1)))
        assert lean <= np.degrees(cfg.lean_range[1]) + 1e-6


def test_the_start_pose_does_not_encode_the_edge_direction():
    """The finger leans in a uniformly random azimuth: its axis says nothing about the edge
    (in v0 it leaned exactly toward the side face's normal, giving the edge to 1e-6 deg)."""
    geometry = FingertipGeometry()
    rng = np.random.default_rng(0)
    offsets = []
    for _ in range(400):
        s = sample_scenario(rng, ("scissors",), ScenarioConfig(), geometry)
        _, direction, _, top = probed_edge(s.object_config, s.joint_angle)
        axis = quaternion_to_matrix(s.fingertip_orientation)[:, 2]
        lean = axis - (axis @ top) * top
        if np.linalg.norm(lean) > 1e-3:
            offsets.append(np.arctan2(np.cross(direction, lean) @ top, direction @ lean))
    # Azimuths relative to the edge are uniform: each quarter holds about a quarter.
    counts = np.histogram(offsets, bins=4, range=(-np.pi, np.pi))[0]
    assert counts.min() > 0.18 * len(offsets)


def test_scenarios_follow_the_generator():
    geometry = FingertipGeometry()
    cfg = ScenarioConfig()
    a = sample_scenario(np.random.default_rng(3), FAMILIES, cfg, geometry)
    b = sample_scenario(np.random.default_rng(3), FAMILIES, cfg, geometry)
    c = sample_scenario(np.random.default_rng(4), FAMILIES, cfg, geometry)
    assert a.object_config == b.object_config and a.joint_angle == b.joint_angle
    np.testing.assert_array_equal(a.fingertip_position, b.fingertip_position)
    assert (a.object_config, a.joint_angle) != (c.object_config, c.joint_angle)


@pytest.mark.parametrize(
    "kw",
    [
        {"joint_angle_range": (1.0, 0.0)},
        {"start_along_range": (0.5, 1.5)},
        {"lean_range": (0.0, 2.0)},
        {"position_jitter": 1000.0},
        {"start_height_range": "far"},
    ],
)
def test_scenario_config_validation(kw):
    with pytest.raises(ValueError, match="scenario"):
        ScenarioConfig(**kw)


# --------------------------------------------------------------------------- prior


def test_prior_summarises_the_reset_distribution():
    rng = np.random.default_rng(1)
    pins = rng.normal([0.017, 0.105, 0.004], 0.005, size=(4000, 3))
    tilt = rng.normal(0.0, 0.1, size=(4000, 2))
    dirs = np.column_stack([tilt, np.ones(4000)]) * rng.choice([-1, 1], (4000, 1))
    prior = AxisPrior.from_samples(pins, dirs)
    np.testing.assert_allclose(prior.pin, [0.017, 0.105, 0.004], atol=3e-4)
    np.testing.assert_allclose(np.diag(prior.pin_cov), 0.005**2, rtol=0.1)
    np.testing.assert_allclose(prior.direction, [0, 0, 1], atol=0.01)
    assert prior.angle_std == pytest.approx(0.1 * np.sqrt(2), rel=0.1)
    estimate = prior.estimate()
    assert estimate.position_std == pytest.approx(0.005 * np.sqrt(2), rel=0.1)


def test_env_starts_from_its_prior():
    env = gym.make("tactile_gym/HingeProbe-v1")
    obs, info = env.reset(seed=0)
    u = env.unwrapped
    assert u.axis_estimate.method == "prior"
    np.testing.assert_allclose(obs["estimate"][:3], u.axis_estimate.point, atol=1e-6)
    # The prior's spread is the reset's: the hinge moves +-10 mm in x and y.
    assert 0.005 < obs["estimate"][6] < 0.012
    assert np.isfinite(info["position_error"]) and info["position_error"] < 0.02
    env.close()


# --------------------------------------------------------------------------- plotting


def test_plot_top_view(tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    from agents.scripted import scripted_policy
    from tactile_gym.envs.plotting import plot_top_view

    env = gym.make("tactile_gym/HingeProbe-v1", max_steps=120)
    policy = scripted_policy(env)
    obs, _ = env.reset(seed=1000)
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy.get_action(obs))
        done = terminated or truncated
    ax = plot_top_view(env.unwrapped)
    ax.figure.savefig(tmp_path / "top.png")
    assert (tmp_path / "top.png").stat().st_size > 0
    assert len(env.unwrapped.measurements) >= 3
    assert len(ax.lines) >= 3 + len(env.unwrapped.measurements)
    env.close()
