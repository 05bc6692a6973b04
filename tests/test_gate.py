"""The measurement gate in simulation: what it accepts, what it refuses, and why.

Truth (the free link's edge) is read only inside these tests, to judge the gate.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym  # noqa: F401 - registers the envs
from tactile_gym.perception.gate import (
    GateConfig,
    patch_displacement,
    tangential_travel,
    travel_along,
)
from tactile_gym.sensing import PressConfig, PressController

DOWN = np.array([0.0, 0.0, -1.0])


def make(**scenario):
    env = gym.make("tactile_gym/HingeProbe-v1", randomize=False, scenario=scenario)
    obs, _ = env.reset(seed=0)
    return env, env.unwrapped, obs


ZERO = np.zeros(3)


def press(env, obs, target=5.0, sideways=ZERO, hold=6, turn=ZERO):
    """The shared press down (plus ``sideways`` per step, m) to |f| ~ target, then hold
    (optionally turning by ``turn`` per step, rad); return the last observation."""
    u = env.unwrapped
    step = u.config.max_translation
    control = PressController(
        PressConfig(target_force=target, max_step=step, approach_step=0.5 * step)
    )
    for _ in range(40):
        down = control.step(obs["wrench"])
        if down is None:
            break
        obs, *_ = env.step(np.r_[(DOWN * down + sideways) / step, 0, 0, 0].astype(np.float32))
    for _ in range(hold):
        obs, *_ = env.step(np.r_[0, 0, 0, turn / u.config.max_rotation].astype(np.float32))
    return obs


def edge_error_deg(u, m) -> tuple[float, float]:
    origin, direction = u.scene.edge_line
    angle = np.degrees(np.arccos(min(1.0, abs(m.edge @ direction))))
    v = m.point - origin
    return angle, float(np.linalg.norm(v - (v @ direction) * direction))


def test_a_pure_press_on_the_edge_is_one_measurement_of_it():
    env, u, obs = make(start_across_range=(0.0005, 0.0005))
    obs = press(env, obs, hold=15)
    assert len(u.measurements) == 1  # one per touch, however long the hold
    m = u.measurements[0]
    angle, distance = edge_error_deg(u, m)
    assert angle < 3.0 and distance < 0.003
    # Oriented physically: the face's interior lies on the side of (force x edge).
    force = u.pipeline.touch.force / np.linalg.norm(u.pipeline.touch.force)
    _, direction = u.scene.edge_line
    side = u.scene.object_config.edge_side
    interior = -side * np.cross(u.scene.true_axis[1], direction)
    assert np.cross(force, m.edge) @ interior > 0
    eig = np.linalg.eigvalsh(m.edge_cov)
    assert eig.min() > -1e-12 and np.sqrt(eig.sum()) == pytest.approx(m.edge_std)
    # Lift off and press again: a new touch, a second measurement.
    for _ in range(3):
        obs, *_ = env.step(np.r_[0, 0, 1, 0, 0, 0].astype(np.float32))
    press(env, obs)
    assert len(u.measurements) == 2
    env.close()


def test_a_press_that_drags_along_the_edge_is_refused():
    env, u, obs = make(start_across_range=(0.0005, 0.0005))
    _, direction = u.scene.edge_line  # truth aims the drag: this test attacks the gate
    press(env, obs, sideways=direction * 2e-5)  # ~1 deg of the path along the edge
    assert not u.measurements
    assert "drag bias" in u.gate.last_rejection
    env.close()


def test_a_press_on_the_flat_face_is_refused():
    env, u, obs = make(start_across_range=(-0.008, -0.008))
    press(env, obs)
    assert not u.measurements
    assert "tilt" in u.gate.last_rejection or "no edge" in u.gate.last_rejection
    env.close()


def test_a_turning_or_moving_fingertip_is_not_measured():
    env, u, obs = make(start_across_range=(0.0005, 0.0005))
    press(env, obs, hold=8, turn=np.array([0.0, 0.0, 0.002]))
    assert not u.measurements
    env.close()
    env, u, obs = make(start_across_range=(0.0005, 0.0005))
    press(env, obs, hold=0)
    for _ in range(8):  # creep sideways at 0.05 mm per step while pressed
        env.step(np.r_[0.025, 0, 0, 0, 0, 0].astype(np.float32))
    assert not u.measurements
    env.close()


def test_a_press_outside_the_force_band_is_not_measured():
    env, u, obs = make(start_across_range=(0.0005, 0.0005))
    press(env, obs, target=2.5)
    assert not u.measurements
    env.close()


@pytest.mark.parametrize(
    "kw",
    [
        {"force_band": (5.0, 1.0)},
        {"dwell": 0},
        {"dwell": 2.5},
        {"friction_share": -0.1},
        {"bias_budget": 2.0},
        {"point_std": 0.0},
        {"preload_rule": "yes"},
        {"force_band": (0.1, 5.0)},  # its min below TOUCH_FORCE
    ],
)
def test_gate_config_validation(kw):
    with pytest.raises(ValueError, match="gate"):
        GateConfig(**kw)


def test_the_patch_path_counts_rocks_and_returns():
    # A rock of 2 deg about a pivot 10 mm above the contact moves the skin there by 0.35 mm
    # along the level, a straight press not at all off its line; a shear undone still counts
    # twice, since the sticking springs keep what the skin slipped.
    pivot, contact = np.array([0.0, 0.0, 0.01]), np.zeros(3)
    angle = np.deg2rad(2.0)
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about y
    before = (np.eye(3), np.zeros(3))
    after = (turn, pivot - turn @ pivot)  # the same rotation about the pivot
    moved = patch_displacement(contact, before, after)
    assert np.linalg.norm(moved) == pytest.approx(0.01 * angle, rel=1e-3)
    assert abs(moved[2]) < 1e-5  # tangential to a level face
    press = np.array([[0.0, 0.0, -2e-4]] * 5)
    assert tangential_travel(press, DOWN) == pytest.approx(0.0, abs=1e-15)
    assert travel_along(press, np.array([0.6, 0.0, -0.8]), DOWN) == 0.0
    shear = np.array([[3e-4, 0.0, 0.0], [-3e-4, 0.0, 0.0]])
    path = np.vstack([press, shear])
    assert tangential_travel(path, DOWN) == pytest.approx(6e-4)
    assert travel_along(path, np.array([1.0, 0.0, 0.0]), DOWN) == pytest.approx(6e-4)


@pytest.mark.parametrize("rule", [True, False])
def test_a_press_rocked_and_rocked_back_is_refused(rule):
    # Rocked 2 deg about the edge's direction and back, then held still: the net pose is the
    # press's, but the skin at the contact travelled about 0.7 mm across the edge (the v1
    # gate takes it).
    env = gym.make(
        "tactile_gym/HingeProbe-v1",
        randomize=False,
        scenario={"start_across_range": (0.0005, 0.0005)},
        gate={"preload_rule": rule},
    )
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    _, direction = u.scene.edge_line  # truth aims the rock: this test attacks the gate
    obs = press(env, obs, hold=0)
    rock = direction * np.deg2rad(2.0) / u.config.max_rotation
    for turn in (rock, -rock):
        env.step(np.r_[0, 0, 0, turn].astype(np.float32))
    for _ in range(8):
        env.step(np.zeros(6, np.float32))
    assert len(u.measurements) == (0 if rule else 1)
    if rule:
        assert "skin preload" in u.gate.last_rejection or "drag" in u.gate.last_rejection
    env.close()
