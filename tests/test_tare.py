"""The realistic F/T sensor and taring: the fingertip's weight, the drift, the tare's round
trip, bad input, and the tare in the v2 ids (refused mid-contact, never taken by the scripted
policy while touching)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym
from agents.scripted import scripted_policy
from tactile_gym.presets import load_preset
from tactile_gym.sensing import (
    TOUCH_FORCE,
    FingertipGeometry,
    SensorConfig,
    SensorErrors,
    Tare,
    fingertip_mass_properties,
    gravity_wrench,
)
from tactile_gym.spatial import rotvec_to_matrix

G = 9.80665
PERIOD = 0.05  # s, one reading per control step
SIX_D = [i for i in tactile_gym.ENV_IDS if "Primitive" not in i]


def test_fingertip_mass_from_its_shape():
    # Solid aluminium shell (r 11 mm: a 20 mm cylinder and a hemisphere) under 5 mm of
    # silicone, by hand: volumes times densities.
    r, big, length = 0.011, 0.016, 0.020
    shell = math.pi * r**2 * length + 2 / 3 * math.pi * r**3
    skin = math.pi * (big**2 - r**2) * length + 2 / 3 * math.pi * (big**3 - r**3)
    mass, com = fingertip_mass_properties(FingertipGeometry())
    assert mass == pytest.approx(2700 * shell + 1070 * skin, rel=1e-12)
    assert 0.040 < mass < 0.047  # about 43 g
    assert com[:2] == (0.0, 0.0) and length / 2 < com[2] < length
    assert SensorConfig().mass == mass and SensorConfig().center_of_mass == com


@pytest.mark.parametrize(
    "rotvec, force, moment",
    [
        # Finger pointing down: sensor z is world -z, the weight pulls along sensor +z, and
        # its line passes through the sensor origin.
        ([math.pi, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]),
        # Finger pointing up: the weight pulls along sensor -z.
        ([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]),
        # Finger along world +x (turned +90 deg about y): world -z is sensor +x, and the
        # weight at (0, 0, c) gives a moment c m g about sensor +y.
        ([0.0, math.pi / 2, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ],
)
def test_gravity_load_in_closed_form(rotvec, force, moment):
    mass, c = 0.043, 0.015
    got = gravity_wrench(rotvec_to_matrix(np.array(rotvec)), mass, (0.0, 0.0, c))
    np.testing.assert_allclose(got[:3], mass * G * np.array(force), atol=1e-12)
    np.testing.assert_allclose(got[3:], c * mass * G * np.array(moment), atol=1e-12)


def test_gravity_load_at_a_tilt():
    # 30 deg lean about x, a centre of mass off the axis: f = R^T (0, 0, -m g), m = c x f.
    mass, com = 0.05, np.array([0.002, -0.001, 0.012])
    a = math.radians(30.0)
    rotation = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    f = mass * G * np.array([0.0, -math.sin(a), -math.cos(a)])
    m = np.array(
        [
            com[1] * f[2] - com[2] * f[1],
            com[2] * f[0] - com[0] * f[2],
            com[0] * f[1] - com[1] * f[0],
        ]
    )
    np.testing.assert_allclose(gravity_wrench(rotation, mass, com), np.r_[f, m], atol=1e-12)


def test_tare_round_trip_in_free_air():
    # Tared at pose A, moved to pose B in free air over 5 s: the compensated reading is the
    # noise plus the drift since the tare, not the offset (0.5 N) or the weight (0.42 N).
    config = SensorConfig()
    a = rotvec_to_matrix(np.array([math.pi, 0.0, 0.0]))
    b = rotvec_to_matrix(np.array([math.pi - 0.5, 0.4, 0.0]))
    free = np.zeros(6)
    worst = np.zeros(6)
    for seed in range(50):
        rng = np.random.default_rng(seed)
        sensor = SensorErrors(config, PERIOD)
        sensor.reset(rng)
        tare = Tare.of(config)
        tare.take(np.array([sensor.read(free, a, rng) for _ in range(10)]), a)
        for _ in range(100):
            reading = sensor.read(free, b, rng)
        worst = np.maximum(worst, np.abs(tare.compensate(reading, b)))
    # 4.5 sigma of one reading's noise, of the tare's mean, and of 5.5 s of drift.
    seconds = 110 * PERIOD
    force = 4.5 * math.hypot(0.02 * math.sqrt(1.1), 0.005 * math.sqrt(seconds))
    moment = 4.5 * math.hypot(5e-4 * math.sqrt(1.1), 5e-5 * math.sqrt(seconds))
    assert np.all(worst[:3] < force) and np.all(worst[3:] < moment)
    # Without the tare the weight and the offset stay.
    untared = Tare.of(SensorConfig.ideal())
    assert np.linalg.norm(untared.compensate(reading, b)[:3]) > 0.2


def test_drift_variance_grows_linearly_with_time():
    config = SensorConfig(force_noise_std=0.0, moment_noise_std=0.0, mass=0.0)
    rng = np.random.default_rng(7)
    runs, steps = 1500, 60
    at = {10: [], 60: []}
    for _ in range(runs):
        sensor = SensorErrors(config, PERIOD)
        for k in range(1, steps + 1):
            sensor.read(np.zeros(6), np.eye(3), rng)
            if k in at:
                at[k].append(sensor.drift.copy())
    for k, drifts in at.items():
        var = np.var(np.array(drifts), axis=0)
        t = k * PERIOD
        # 1500 runs x 3 axes: the variance's relative std is about 2 %; 12 % is 6 of them.
        np.testing.assert_allclose(var[:3].mean(), config.force_drift**2 * t, rtol=0.12)
        np.testing.assert_allclose(var[3:].mean(), config.moment_drift**2 * t, rtol=0.12)


def test_the_ideal_sensor_draws_only_the_noise():
    ideal = SensorConfig.ideal(force_bias=(0.1, 0.0, 0.0))
    sensor = SensorErrors(ideal, PERIOD)
    rng, same = np.random.default_rng(3), np.random.default_rng(3)
    sensor.reset(rng)
    wrench = np.arange(6.0)
    got = sensor.read(wrench, rotvec_to_matrix(np.array([0.3, 0.0, 0.0])), rng)
    noise = same.standard_normal(6) * np.repeat([0.02, 5e-4], 3)
    np.testing.assert_array_equal(got, wrench + noise + np.r_[0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert load_preset("env", "ideal") == {"sensor_model": "ideal"}


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"mass": -0.01}, "sensor.mass"),
        ({"force_noise_std": -0.1}, "sensor.force_noise_std"),
        ({"moment_offset_std": -1e-3}, "sensor.moment_offset_std"),
        ({"force_drift": math.nan}, "sensor.force_drift"),
        ({"moment_drift": math.inf}, "sensor.moment_drift"),
        ({"center_of_mass": (0.0, 0.0, 0.05)}, "sensor.center_of_mass"),
        ({"center_of_mass": (0.02, 0.0, 0.01)}, "sensor.center_of_mass"),
        ({"center_of_mass": (0.0, 0.0, -0.001)}, "sensor.center_of_mass"),
    ],
)
def test_bad_sensor_fields_raise(changes, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        SensorConfig(**changes)
    with pytest.raises(ValueError, match=field.split(".")[1]):
        gym.make(tactile_gym.ENV_IDS[0], sensor=changes)


def test_bad_tare_input_raises():
    tare = Tare.of(SensorConfig())
    with pytest.raises(ValueError, match="readings"):
        tare.take(np.zeros(5), np.eye(3))
    with pytest.raises(ValueError, match="readings"):
        tare.take(np.full(6, np.nan), np.eye(3))
    with pytest.raises(ValueError, match="sensor_model"):
        gym.make(tactile_gym.ENV_IDS[0], sensor_model="perfect")


@pytest.mark.parametrize("env_id", SIX_D)
def test_a_tare_mid_contact_is_refused(env_id):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    assert env.action_space.shape == (7,)
    # In free air at the start a tare is taken.
    obs, *_, info = env.step(np.r_[np.zeros(6), 1.0].astype(np.float32))
    assert info["tared"] and not info["tare_refused"] and info["tare_age"] == 0.0
    down = np.r_[0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.0].astype(np.float32)
    for _ in range(40):
        obs, *_, info = env.step(down)
        if np.linalg.norm(obs["wrench"][:3]) > 1.0:
            break
    assert np.linalg.norm(obs["wrench"][:3]) > 1.0, "never touched"
    age = info["tare_age"]
    obs, *_, info = env.step(np.r_[np.zeros(6), 1.0].astype(np.float32))
    assert info["tare_refused"] and not info["tared"]
    assert info["tare_age"] == pytest.approx(age + PERIOD)
    assert np.linalg.norm(obs["wrench"][:3]) >= TOUCH_FORCE  # the contact is still read
    env.close()


@pytest.mark.parametrize("env_id", SIX_D)
def test_scripted_never_tares_in_contact(env_id):
    # The test reads the truth: at every tare the skin carries no load at all.
    env = gym.make(env_id, max_steps=250)
    policy = scripted_policy(env)
    tares = 0
    for seed in (0, 1):
        obs, _ = env.reset(seed=seed)
        policy.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
            done = terminated or truncated
            assert not info["tare_refused"]
            if info["tared"]:
                tares += 1
                assert np.linalg.norm(env.unwrapped.scene.true_wrench) == 0.0
    assert tares >= 6  # one before each press
    env.close()


def test_v1_ids_keep_the_ideal_sensor_and_no_tare():
    for env_id in [i for i in tactile_gym.LEGACY_ENV_IDS if i.endswith("-v1")]:
        env = gym.make(env_id)
        base = env.unwrapped
        base = base.control_env if env.action_space.shape == (3,) else base
        assert base.config.sensor_model == "ideal" and not base.config.tare_action
        assert base.pipeline.sensor.sensor == SensorConfig.ideal()
        assert env.action_space.shape in ((6,), (3,))
        env.close()
