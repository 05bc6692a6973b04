"""Parts of the env on their own: controller, observation codec, measurement pipeline, step
guard, reset scenarios, prior, plotting."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tactile_gym  # noqa: F401 - registers the envs
from agents.scripted import scripted_policy
from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.observation import (
    OBSERVATION,
    ContactObs,
    EstimateObs,
    LastMeasurementObs,
    ProgressObs,
    WrenchObs,
)
from tactile_gym.envs.scenarios import FAMILIES, ScenarioConfig, probed_edge, sample_scenario
from tactile_gym.envs.step_guard import StepGuard
from tactile_gym.estimation import AxisPrior
from tactile_gym.perception import Sample
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.spatial import quaternion_to_matrix

# --------------------------------------------------------------------------- controller


def test_controller_scales_translation_and_rotates_about_the_tip():
    pivot = FingertipGeometry().sphere_center
    ctrl = DeltaPoseController(0.002, np.deg2rad(3.0), pivot)
    position = np.array([0.01, 0.02, 0.05])
    rotation = Rotation.from_euler("x", 170, degrees=True).as_matrix()
    new_position, new_rotation = ctrl.target(np.r_[1.0, 0, 0, 0, 0, 0], position, rotation)
    np.testing.assert_allclose(new_position - position, [0.002, 0, 0], atol=1e-12)
    np.testing.assert_allclose(new_rotation, rotation, atol=1e-12)

    new_position, new_rotation = ctrl.target(np.r_[0, 0, 0, 0, 1.0, 0], position, rotation)
    np.testing.assert_allclose(new_position + new_rotation @ pivot, position + rotation @ pivot)
    turn = Rotation.from_matrix(new_rotation @ rotation.T)
    np.testing.assert_allclose(turn.as_rotvec(), [0, np.deg2rad(3.0), 0], atol=1e-12)


# --------------------------------------------------------------------------- observation


def test_codec_names_every_entry_of_the_observation():
    """Encoding named groups and reading them back gives the values, at their places."""
    env = gym.make("tactile_gym/HingeProbe-v2")
    obs, _ = env.reset(seed=4)
    codec = env.unwrapped.codec
    assert codec.dict_space == env.observation_space
    contact = ContactObs.read(obs)
    assert contact.point.shape == (3,) and isinstance(contact.tilt, float)
    again = ContactObs.from_array(contact.to_array()).to_array()
    np.testing.assert_array_equal(again, obs["contact"])
    progress = ProgressObs.read(obs)
    assert (progress.measurements, progress.time_left) == (0.0, 1.0)
    flat = codec.encode({key: np.asarray(value, float) for key, value in obs.items()}, "flat")
    np.testing.assert_array_equal(flat, gym.spaces.flatten(codec.dict_space, obs))
    for key, view in codec.as_dict(flat).items():
        np.testing.assert_array_equal(view, obs[key])
    env.close()


def test_codec_clips_to_the_bounds_and_zeroes_nan():
    parts = {key: g.space().high.astype(float) * 2.0 for key, g in OBSERVATION.groups.items()}
    contact = ContactObs.from_array(parts["contact"])
    parts["contact"] = dataclasses.replace(contact, point=np.full(3, np.nan)).to_array()
    obs = OBSERVATION.encode(parts, "dict")
    np.testing.assert_array_equal(WrenchObs.read(obs).force, 60.0)  # the force bound, N
    np.testing.assert_array_equal(ContactObs.read(obs).point, 0.0)
    with pytest.raises(ValueError, match="observation_mode"):
        OBSERVATION.space("list")


# --------------------------------------------------------------------------- measurement


def test_pipeline_turns_a_held_press_into_one_measurement():
    """The pipeline's state after the scripted policy's first measurement, and its rule of
    one measurement per touch on more readings of the held press."""
    env = gym.make("tactile_gym/HingeProbe-v1")  # v1: the raw readings below are the ideal sensor's
    u = env.unwrapped
    policy = scripted_policy(env)
    obs, info = env.reset(seed=1000)
    while not info.get("new_measurements"):
        obs, _, _, _, info = env.step(policy.get_action(obs))
    pipeline = u.pipeline
    assert len(pipeline.measurements) == 1 and pipeline.last is pipeline.measurements[0]
    assert pipeline.estimate.method != "prior"
    assert pipeline.directions == 1 and pipeline.span == 0.0
    np.testing.assert_array_equal(LastMeasurementObs.read(obs).edge, np.float32(pipeline.last.edge))
    scene = u.scene
    time = pipeline.tare_time + u._steps * u.period
    for k in range(1, 11):
        sample = Sample(
            time + k * u.period,
            scene.read_wrench(u.np_random),
            scene.fingertip_position,
            scene.fingertip_rotation,
        )
        perceived = pipeline.step(sample)
        assert perceived.accepted == () and perceived.fault == ""
    env.close()


# --------------------------------------------------------------------------- step guard


def test_step_guard():
    guard = StepGuard(gym.spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32))
    with pytest.raises(RuntimeError, match="reset"):
        guard.check(np.zeros(2))
    guard.begin()
    np.testing.assert_array_equal(guard.check(np.array([3.0, -0.5])), [1.0, -0.5])
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        guard.check(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        guard.check(np.array([np.nan, 0.0]))
    guard.end(True)
    with pytest.raises(RuntimeError, match="ended"):
        guard.check(np.zeros(2))


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
    env = gym.make("tactile_gym/HingeProbe-v2")
    obs, info = env.reset(seed=0)
    u = env.unwrapped
    assert u.axis_estimate.method == "prior"
    estimate = EstimateObs.read(obs)
    np.testing.assert_allclose(estimate.point, u.axis_estimate.point, atol=1e-6)
    # The prior's spread is the reset's: the hinge moves +-10 mm in x and y.
    assert 0.005 < estimate.position_std < 0.012
    assert np.isfinite(info["position_error"]) and info["position_error"] < 0.02
    env.close()


# --------------------------------------------------------------------------- plotting


def test_plot_top_view(tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    from tactile_gym.plotting import LABELS, plot_top_view

    env = gym.make("tactile_gym/HingeProbe-v2", max_steps=120)
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
    # Every kind of mark is in the key, once.
    (key,) = ax.figure.legends
    labels = [text.get_text() for text in key.get_texts()]
    assert sorted(labels) == sorted([*LABELS.values(), "free link edge (now)"])
    env.close()
