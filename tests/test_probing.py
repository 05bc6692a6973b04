"""The shared press and the world-frame reading of a wrench (``tactile_gym.sensing.probing``).

The press is checked on a Winkler plane whose force law is written here (F = k_n pi R d^2 at
depth d, ``docs/design.md`` 3.1), not through the simulator, so each phase can be provoked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tactile_gym.sensing import (
    TOUCH_FORCE,
    FingertipGeometry,
    HoldRule,
    PressConfig,
    PressController,
    SensorConfig,
    TouchSensor,
    estimate_contact,
    run_press,
)

GEOM = FingertipGeometry()
K_N = 8.8e7  # N/m^3


class Plane:
    """A fingertip pressed straight down on a face ``gap`` below it; ``limit`` caps the force
    (a link that gives way). Readings carry Gaussian noise of ``sigma`` N per axis."""

    def __init__(self, gap=0.002, limit=math.inf, sigma=0.02, seed=0):
        self.depth = -gap
        self.limit = limit
        self.sigma = sigma
        self.rng = np.random.default_rng(seed)
        self.moves: list[float] = []

    def force(self) -> float:
        return min(K_N * math.pi * GEOM.outer_radius * max(self.depth, 0.0) ** 2, self.limit)

    def read(self) -> np.ndarray:
        wrench = np.r_[0.0, 0.0, -self.force(), 0.0, 0.0, 0.0]
        return wrench + self.rng.normal(0.0, self.sigma, 6) * np.r_[1, 1, 1, 0, 0, 0]

    def move(self, step: float) -> None:
        self.moves.append(step)
        self.depth += step


def test_press_reaches_the_force_on_the_noisy_reading_then_holds_and_averages():
    plane = Plane()
    config = PressConfig(target_force=5.0, dwell=6, max_step=0.0005)
    press = run_press(PressController(config), plane.read, plane.move)
    assert press.phase == "done" and press.readings == 6
    assert abs(plane.force() - 5.0) <= 0.3 + 4 * 0.02
    assert np.linalg.norm(press.mean[:3]) == pytest.approx(plane.force(), abs=0.05)
    assert plane.moves[-6:] == [0.0] * 6  # held still while averaging
    # It approached at max_step, then stepped by the force error over the stiffness.
    assert plane.moves[0] == 0.0005 and press.touch_travel is not None
    assert all(abs(m) <= 0.0005 for m in plane.moves)
    # Reading on extends the average without moving (a rule over all the readings held).
    press.extend(HoldRule(10))
    run_press(press, plane.read, plane.move)
    assert press.phase == "done" and press.readings == 10 and plane.moves[-4:] == [0.0] * 4


def test_press_without_a_touch_gives_up_after_its_reach():
    plane = Plane(gap=0.05)
    press = run_press(PressController(PressConfig(reach=0.01)), plane.read, plane.move)
    assert press.phase == "missed" and press.mean is None
    assert 0.01 <= press.travel < 0.01 + 0.002


def test_press_on_a_link_that_gives_way_gives_up():
    plane = Plane(limit=2.0)
    press = run_press(PressController(PressConfig(give_way=0.004)), plane.read, plane.move)
    assert press.phase == "gave_way"
    assert press.travel - press.touch_travel == pytest.approx(0.004, abs=0.002)


def test_press_with_no_dwell_ends_on_reaching_the_force():
    plane = Plane(sigma=0.0)
    config = PressConfig(target_force=3.0, max_step=0.0005)
    press = run_press(PressController(config), plane.read, plane.move)
    assert press.phase == "done" and press.readings == 0 and abs(plane.force() - 3.0) <= 0.3
    with pytest.raises(ValueError, match="done"):
        PressController(PressConfig()).extend(3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"target_force": 0.1}, "press.target_force"),
        ({"tolerance": 5.0}, "press.tolerance"),
        ({"max_step": 0.0}, "press.max_step"),
        ({"dwell": -1}, "press.dwell"),
        ({"give_way": 0.0}, "press.give_way"),
    ],
)
def test_press_config_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PressConfig(**kwargs)


def test_touch_sensor_reads_a_wrench_in_the_world_frame_with_the_plane_shape():
    """A 5 N press tilted 8 deg across an edge: the world-frame touch is the sensor-frame
    estimate (the default shape, ``"plane"``) moved by the pose, its noise scaled by the number
    of readings, its edge oriented along n x f."""
    sensor = SensorConfig()
    tilt = math.radians(8.0)
    contact = GEOM.sphere_center + GEOM.outer_radius * np.array([0, math.sin(tilt), math.cos(tilt)])
    force = np.array([0.0, 0.0, -5.0])
    wrench = np.r_[force, np.cross(contact, force)]
    rotation = np.diag([1.0, -1.0, -1.0])
    position = np.array([0.05, 0.1, 0.05])
    touch = TouchSensor(GEOM, sensor, K_N).sense(wrench, rotation, position, readings=4)
    est = estimate_contact(
        force,
        wrench[3:],
        GEOM,
        force_noise_std=sensor.force_noise_std / 2,
        moment_noise_std=sensor.moment_noise_std / 2,
        skin_stiffness=K_N,
    )
    assert touch.valid and touch.observable
    np.testing.assert_allclose(touch.point, rotation @ est.corrected_point + position)
    np.testing.assert_allclose(touch.force, rotation @ force)
    assert touch.edge_std == pytest.approx(est.edge_std)
    assert np.linalg.det(np.array([touch.edge, touch.normal, touch.force])) > 0.0
    below = np.r_[0.5 * TOUCH_FORCE * np.array([0.0, 0.0, -1.0]), 0.0, 0.0, 0.0]
    assert not TouchSensor(GEOM, sensor, K_N).sense(below, rotation, position).valid
