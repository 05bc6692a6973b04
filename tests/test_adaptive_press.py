"""The adaptive press: the force gradient it measures, and how long a press holds.

The force laws are the Winkler skin's (``docs/design.md`` 3.1), written here and not taken from
the simulator: a sphere of radius R pressed by depth d into a foundation of modulus k carries
the pressure k (d - r^2 / 2R) over its contact patch, so dF/dd = k x (the patch's area). On a
plane the patch is a disc of radius sqrt(2 R d): F = pi k R d^2, dF/dd = 2 sqrt(pi k R F). On a
face that ends at an edge a distance c beyond the sphere's lowest point (c < 0: the lowest
point lies past the edge), the patch is the part x < c of that disc, a circular segment of
area a^2 acos(-c / a) + c sqrt(a^2 - c^2); with c = 0 it is half the disc, F = pi k R d^2 / 2
and dF/dd = sqrt(2 pi k R F).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from tactile_gym.perception import GateConfig, MeasurementGate
from tactile_gym.perception.gate import force_change
from tactile_gym.sensing import (
    FingertipGeometry,
    GradientEstimate,
    HoldRule,
    PressConfig,
    PressController,
    SensorConfig,
    TouchSensor,
    effective_readings,
    predicted_edge_std,
    run_press,
)

GEOM = FingertipGeometry()
R = GEOM.outer_radius
K_N = 8.8e7  # N/m^3, the configured skin
SENSOR = SensorConfig()
TOUCH = TouchSensor(GEOM, SENSOR, K_N)


def segment_area(a: float, c: float) -> float:
    """Area of the part x < c of a disc of radius a centred at x = 0, m^2."""
    if c >= a:
        return math.pi * a * a
    if c <= -a:
        return 0.0
    return a * a * math.acos(-c / a) + c * math.sqrt(a * a - c * c)


class Winkler:
    """A fingertip pressed straight down on a face ``gap`` below it, its skin ``k`` (N/m^3);
    the face ends at an edge ``c`` beyond the lowest point (None: no edge). Readings carry
    Gaussian noise of ``sigma`` N per axis."""

    def __init__(self, k=K_N, c=None, gap=0.002, sigma=0.0, seed=0):
        self.k, self.c, self.sigma = k, c, sigma
        self.depth = -gap
        self.rng = np.random.default_rng(seed)
        self.readings = 0

    def area(self, d: float) -> float:
        a = math.sqrt(2.0 * R * max(d, 0.0))
        return math.pi * a * a if self.c is None else segment_area(a, self.c)

    def force(self) -> float:
        if self.depth <= 0.0:
            return 0.0
        if self.c is None:
            return math.pi * self.k * R * self.depth**2
        return self.k * quad(self.area, 0.0, self.depth, limit=200)[0]

    def gradient(self) -> float:
        return self.k * self.area(self.depth)

    def read(self) -> np.ndarray:
        self.readings += 1
        wrench = np.r_[0.0, 0.0, -self.force(), 0.0, 0.0, 0.0]
        return wrench + self.rng.normal(0.0, self.sigma, 6) * np.r_[1, 1, 1, 0, 0, 0]

    def move(self, step: float) -> None:
        self.depth += step


ADAPTIVE = PressConfig(max_step=0.0003, measure_gradient=True, reach=0.01)


@pytest.mark.parametrize(
    ("c", "closed_form"),
    [
        (None, lambda f, k: 2.0 * math.sqrt(math.pi * k * R * f)),
        (0.0, lambda f, k: math.sqrt(2.0 * math.pi * k * R * f)),
    ],
    ids=["plane", "edge"],
)
@pytest.mark.parametrize("factor", [0.5, 1.0, 2.0])
def test_the_measured_gradient_is_the_closed_form_of_a_sphere_on_a_plane_and_an_edge(
    c, closed_form, factor
):
    skin = Winkler(k=factor * K_N, c=c)
    press = run_press(PressController(ADAPTIVE), skin.read, skin.move)
    assert press.phase == "done"
    force = skin.force()
    # Noise-free, sqrt(F) is linear in the depth: the estimate is exact.
    assert press.gradient.gradient(force) == pytest.approx(closed_form(force, skin.k), rel=1e-9)
    assert skin.gradient() == pytest.approx(closed_form(force, skin.k), rel=1e-6)
    assert abs(force - ADAPTIVE.target_force) <= ADAPTIVE.tolerance
    # The move it would take from two touching readings lands on the force exactly.
    estimate = GradientEstimate(6000.0, 5.0, spread=4.0)
    for depth in (0.0002, 0.0004):
        skin.depth = depth
        estimate.add(depth, skin.force())
    skin.depth += estimate.step(skin.force())
    assert skin.force() == pytest.approx(5.0, rel=1e-9)


@pytest.mark.parametrize("c", [-0.0015, -0.0005, 0.0005, 0.0015])
def test_the_measured_gradient_follows_an_edge_off_the_lowest_point(c):
    # The force law is no longer F = b^2 d^2; the estimate is the press's mean slope of
    # sqrt(F), within 20 % of the local gradient k A(d) at the end.
    skin = Winkler(c=c)
    press = run_press(PressController(ADAPTIVE), skin.read, skin.move)
    assert press.phase == "done"
    assert abs(skin.force() - 5.0) <= ADAPTIVE.tolerance
    assert press.gradient.gradient(skin.force()) == pytest.approx(skin.gradient(), rel=0.2)


def test_the_estimate_weighs_each_difference_by_its_noise_and_stays_in_bounds():
    estimate = GradientEstimate(6000.0, 5.0, spread=4.0)
    assert estimate.gradient(5.0) == pytest.approx(6000.0)  # the assumed one, until measured
    estimate.add(0.0, 1.0)
    estimate.add(1e-4, 1.44)  # sqrt F: 1 -> 1.2 over 0.1 mm
    assert estimate.slope == pytest.approx(2000.0)
    assert estimate.gradient(5.0) == pytest.approx(2.0 * 2000.0 * math.sqrt(5.0))
    estimate.add(2e-4, None)  # the skin let go: the next difference starts afresh
    estimate.add(3e-4, 4.0)
    assert estimate.slope == pytest.approx(2000.0)
    # Slope 3000 over 0.1 mm, weighed 1 / (1/4 + 1/6.25) against 1 / (1 + 1/1.44).
    estimate.add(4e-4, 2.3**2)
    w1, w2 = 1.0 / (1.0 + 1.0 / 1.44), 1.0 / (1.0 / 4.0 + 1.0 / 2.3**2)
    assert estimate.slope == pytest.approx((2000.0 * w1 + 3000.0 * w2) / (w1 + w2))
    assert estimate.step(4.0) == pytest.approx((math.sqrt(5.0) - 2.0) / estimate.slope)
    # A link that gives way reads no rise: the slope is held at the bound.
    flat = GradientEstimate(6000.0, 5.0, spread=4.0)
    flat.add(0.0, 2.0)
    flat.add(3e-4, 2.0)
    assert flat.gradient(5.0) == pytest.approx(6000.0 / 4.0)


@pytest.mark.parametrize("factor", [0.5, 0.7, 1.0, 1.4, 2.0])
@pytest.mark.parametrize("c", [None, 0.0, -0.001])
@pytest.mark.parametrize("sigma", [0.02, 0.08])
def test_the_press_settles_on_skins_half_to_twice_as_stiff_as_assumed(factor, c, sigma):
    skin = Winkler(k=factor * K_N, c=c, sigma=sigma, seed=int(factor * 10))
    press = run_press(PressController(ADAPTIVE), skin.read, skin.move, limit=40)
    assert press.phase == "done"
    assert abs(skin.force() - 5.0) <= ADAPTIVE.tolerance + 4 * sigma
    # As many steps as the travel takes at 0.3 mm a step (2 mm above the face, then the
    # depth of 5 N), and at most four more to settle.
    assert skin.readings <= math.ceil((0.002 + skin.depth) / ADAPTIVE.max_step) + 4


def test_the_assumed_gradient_never_settles_on_a_skin_twice_as_stiff():
    # The press of issue 26: 6000 N/m assumed, 13 300 N/m met on a plane at 5 N, so every
    # step overshoots by more than the error it corrects.
    skin = Winkler(k=2.0 * K_N, sigma=0.02)
    fixed = PressConfig(max_step=0.0003, reach=0.01)
    with pytest.raises(RuntimeError, match="did not end"):
        run_press(PressController(fixed), skin.read, skin.move)


def tilted_wrench(tilt_deg: float = 8.0, force: float = 5.0) -> np.ndarray:
    """A press whose force's line of action meets the skin ``tilt_deg`` off its pole."""
    tilt = math.radians(tilt_deg)
    contact = GEOM.sphere_center + R * np.array([0.0, math.sin(tilt), math.cos(tilt)])
    f = np.array([0.0, 0.0, -force])
    return np.r_[f, np.cross(contact, f)]


def test_the_predicted_edge_std_of_a_mean_scales_as_one_over_sqrt_n():
    wrench = tilted_wrench()
    one = TOUCH.sense(wrench, np.eye(3), np.zeros(3)).edge_std
    for n in (1, 4, 9, 25):
        readings = np.tile(wrench, (n, 1))  # no scatter: the configured noise alone
        assert effective_readings(SENSOR, readings) == n
        assert predicted_edge_std(TOUCH, readings) == pytest.approx(one / math.sqrt(n), rel=1e-9)


def test_a_hold_reaches_its_target_when_the_sqrt_n_scaling_says_and_stops_at_its_budget():
    wrench = tilted_wrench()
    one = TOUCH.sense(wrench, np.eye(3), np.zeros(3)).edge_std
    target = one / 3.5  # sqrt(n) >= 3.5 first at n = 13
    rule = HoldRule(least=4, target=target, budget=40)
    met = [n for n in range(1, 41) if rule.enough(TOUCH, np.tile(wrench, (n, 1)))]
    assert met[0] == math.ceil(3.5**2) == 13
    # At least ``least`` readings, however sure the first ones are.
    assert HoldRule(4, one * 2.0, 40).enough(TOUCH, np.tile(wrench, (3, 1))) is False
    assert HoldRule(4, one * 2.0, 40).enough(TOUCH, np.tile(wrench, (4, 1))) is True
    # A press that shows no edge never reaches it: the budget ends the hold.
    flat = tilted_wrench(0.0)
    assert TOUCH.sense(flat, np.eye(3), np.zeros(3)).edge_std == pytest.approx(math.pi / 2)
    stops = [n for n in range(1, 41) if rule.enough(TOUCH, np.tile(flat, (n, 1)))]
    assert stops[0] == 40
    # Without a target: exactly ``least`` readings.
    assert [n for n in range(1, 10) if HoldRule(6).enough(None, range(n))][0] == 6


def test_readings_that_scatter_more_than_configured_count_for_fewer():
    rng = np.random.default_rng(1)
    n = 400
    noise = np.r_[[SENSOR.force_noise_std] * 3, [SENSOR.moment_noise_std] * 3]
    readings = tilted_wrench() + 4.0 * noise * rng.standard_normal((n, 6))
    assert effective_readings(SENSOR, readings) == pytest.approx(n / 16.0, rel=0.1)
    quiet = tilted_wrench() + 0.5 * noise * rng.standard_normal((n, 6))
    assert effective_readings(SENSOR, quiet) == n  # never more than their count


def test_the_compiled_hold_rule_is_numpys_formula_to_the_bit():
    """``effective_readings`` and ``predicted_edge_std`` run compiled (one kernel per call);
    written here with NumPy's var and mean and a touch of the mean, they agree to the bit,
    for windows of 1 to 60 readings, steady and trending."""
    rng = np.random.default_rng(4)
    noise = np.r_[[SENSOR.force_noise_std] * 3, [SENSOR.moment_noise_std] * 3]
    for n in range(1, 61):
        trend = np.outer(np.arange(n), rng.standard_normal(6)) * noise * (n % 2)
        readings = tilted_wrench(8.0) + 3.0 * noise * rng.standard_normal((n, 6)) + trend
        count = float(n)
        if n >= 2:
            variance = readings.var(axis=0, ddof=1)
            ratio = max(
                1.0, variance[:3].mean() / noise[0] ** 2, variance[3:].mean() / noise[3] ** 2
            )
            count = n / ratio
        assert effective_readings(SENSOR, readings) == count
        mean = TOUCH.sense(readings.mean(axis=0), np.eye(3), np.zeros(3), readings=count)
        assert predicted_edge_std(TOUCH, readings) == mean.edge_std


def test_the_hold_rule_refuses_readings_that_are_not_finite_or_none():
    readings = np.tile(tilted_wrench(), (3, 1))
    readings[1, 4] = np.nan
    with pytest.raises(ValueError, match="readings must be finite"):
        predicted_edge_std(TOUCH, readings)
    with pytest.raises(ValueError, match="readings must be finite"):
        effective_readings(SENSOR, readings)
    with pytest.raises(ValueError, match="at least one wrench"):
        predicted_edge_std(TOUCH, np.zeros((0, 6)))


def test_a_press_holds_until_its_rule_is_met_and_can_be_extended():
    skin = Winkler()
    wrench = tilted_wrench()

    def read():  # a tilted press, scaled to the force the skin carries
        return wrench * (-skin.read()[2] / 5.0)

    one = TOUCH.sense(wrench, np.eye(3), np.zeros(3)).edge_std
    config = PressConfig(
        tolerance=0.001,
        max_step=0.0003,
        measure_gradient=True,
        dwell=4,
        edge_std_target=one / 2.9,  # sqrt(n) >= 2.9 first at n = 9
        reach=0.01,
    )
    press = run_press(PressController(config, TOUCH), read, skin.move)
    assert press.phase == "done" and press.readings == 9
    press.extend(HoldRule(4, one / 4.1, 12))  # n = 17 would be needed
    run_press(press, read, skin.move)
    assert press.phase == "done" and press.readings == 12  # the budget
    with pytest.raises(ValueError, match="TouchSensor"):
        PressController(config)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"measure_gradient": 1}, "press.measure_gradient"),
        ({"gradient_spread": 0.5}, "press.gradient_spread"),
        ({"edge_std_target": 0.0}, "press.edge_std_target"),
        ({"edge_std_target": 0.01, "dwell": 8, "dwell_budget": 4}, "press.dwell_budget"),
    ],
)
def test_press_config_validation_of_the_adaptive_fields(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PressConfig(**kwargs)


# --- the gate measures on the same rule ------------------------------------------------------

DOWN_POSE = np.diag([1.0, -1.0, -1.0])  # sensor z pointing down, sensor to world


def gate_stream(gate: MeasurementGate, wrench: np.ndarray, still: int) -> int | None:
    """Offer a straight press (1 mm down from free air, then ``still`` readings of ``wrench``
    held still); return on which still reading the gate judged it (accepted or refused)."""
    top = np.array([0.05, 0.1, 0.1])
    free = np.zeros(6)
    gate.offer(free, DOWN_POSE, top, TOUCH.sense(free, DOWN_POSE, top))
    position = top - [0.0, 0.0, 0.001]
    gate.offer(wrench, DOWN_POSE, position, TOUCH.sense(wrench, DOWN_POSE, position))  # moved
    judged = gate.refusals
    for k in range(1, still + 1):
        touch = TOUCH.sense(wrench, DOWN_POSE, position)
        if gate.offer(wrench, DOWN_POSE, position, touch) or gate.refusals > judged:
            return k
    return None


def test_the_gate_measures_a_still_press_when_its_hold_rule_is_met():
    wrench = tilted_wrench(10.0)
    one = TOUCH.sense(wrench, np.eye(3), np.zeros(3)).edge_std
    # v2: exactly ``dwell`` readings.
    assert gate_stream(MeasurementGate(GateConfig(), TOUCH), wrench, 30) == GateConfig().dwell
    # The adaptive rule: when sqrt(n) first reaches 2.9, or at the budget.
    config = GateConfig(dwell=4, edge_std_target=one / 2.9, dwell_budget=20)
    gate = MeasurementGate(config, TOUCH)
    assert gate_stream(gate, wrench, 30) == 9 and len(gate.last_rule) == 0  # accepted
    flat = MeasurementGate(config, TOUCH)
    assert gate_stream(flat, tilted_wrench(0.0), 30) == 20
    assert flat.last_rule == "observable"
    assert config.hold_rule == HoldRule(4, one / 2.9, 20)


def test_the_trend_of_a_steady_force_stays_small_however_long_the_window():
    assert force_change([5.0, 5.1, 5.2, 5.3]) == pytest.approx(0.3)
    assert force_change([5.0]) == 0.0
    rng = np.random.default_rng(0)
    for n in (6, 20, 100):
        windows = 5.0 + 0.08 * rng.standard_normal((4000, n))
        changes = np.array([force_change(w) for w in windows])
        # A straight-line fit's change has std sigma sqrt(12 (n - 1) / (n (n + 1))) ...
        expected = 0.08 * math.sqrt(12.0 * (n - 1) / (n * (n + 1)))
        assert np.sqrt(np.mean(changes**2)) == pytest.approx(expected, rel=0.05)
        # ... while the peak-to-peak spread grows with n (0.08 N of noise: 4x the default).
        assert np.ptp(windows, axis=1).mean() > 2.5 * 0.08
    with pytest.raises(ValueError, match="gate.steady_rule"):
        GateConfig(steady_rule="smooth")
    with pytest.raises(ValueError, match="gate.dwell_budget"):
        GateConfig(dwell=8, edge_std_target=0.01, dwell_budget=4)


# --- the env: the skills hold on the gate's rule ----------------------------------------------

#: The keywords that turn the adaptive press on in an env (``benchmarks/adaptive_press.py``).
ADAPTIVE_ENV = {
    "gate": {"edge_std_target": math.radians(1.0), "dwell_budget": 24, "steady_rule": "trend"},
    "measure_gradient": True,
}


@pytest.mark.parametrize("skin", [1.0, 2.0])
@pytest.mark.parametrize(
    ("env_id", "adaptive"),
    [("tactile_gym/HingeProbe-v2", ADAPTIVE_ENV), ("tactile_gym/HingeProbe-v3", {})],
    ids=["v2-told", "v3-registered"],
)
def test_the_skill_never_lifts_before_the_gates_window_is_complete(
    monkeypatch, skin, env_id, adaptive
):
    """On v2 with the adaptive keywords, and on v3 as registered (whose keywords are the
    adaptive press's: docs/design.md 5.2)."""
    import gymnasium as gym

    import tactile_gym  # noqa: F401 - registers the envs
    from agents.episodes import run_episode
    from agents.scripted import scripted_policy
    from tactile_gym.envs import skills

    kwargs = {**adaptive, "skin": {"normal_stiffness": skin * K_N}, "max_steps": 150}
    env = gym.make(env_id, **kwargs)
    pipeline = env.unwrapped.pipeline
    rule = env.unwrapped.gate.config.hold_rule
    assert rule.target is not None and env.unwrapped.config.measure_gradient
    holds = []
    move = skills.Press._move

    def watched(press, reading):
        if not hasattr(press, "judged"):
            press.judged = len(pipeline.presses)
        out = move(press, reading)
        if out is None and press.press.phase == "done" and press.press.rule.most > 0:
            holds.append((press.judged, len(pipeline.presses), press.press.readings))
        return out

    monkeypatch.setattr(skills.Press, "_move", watched)
    policy = scripted_policy(env)
    for seed in (0, 1):
        run_episode(env, policy, seed)
    env.close()
    assert len(holds) >= 4
    # Every probe that held was judged by the gate (accepted or refused) before it let go.
    assert all(after == before + 1 for before, after, _ in holds)
    # It held as long as the rule asked: at least the gate's dwell, at most its budget.
    readings = [n for *_, n in holds]
    assert min(readings) >= rule.least and max(readings) <= rule.budget
    assert len(pipeline.measurements) >= 1
