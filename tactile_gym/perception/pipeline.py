"""The measurement pipeline: touch sensing, the measurement gate and the axis estimator, wired.

Each control step one noisy F/T reading and the fingertip's pose (both known to a real robot)
go in. The pipeline estimates the contact in the world frame (``TouchSensor``,
``docs/design.md`` 5), offers the reading to the gate (7.2), keeps what the gate accepts on the
probed edge (``MeasurementGate.same_edge``: the edge line at the distance from the current
estimate that the reset distribution predicts), fuses it into the estimate
(``JointAxisEstimator``, 6) and counts the distinct edge directions measured (the observation's
progress, 7.5). It never sees the simulator (8).

What is known before touching comes from the reset distribution, drawn from a fixed seed and
never from the episode: the axis prior (6.6) and the probed edge's distance from the axis
(``reset_distribution_prior``).

This is the one module of the env that imports the probing stack (touch sensing and gate);
the env and the tests take its parts from here.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np

from tactile_gym.envs.gate import GateConfig, Measurement, MeasurementGate, line_distance
from tactile_gym.envs.scenarios import ScenarioConfig, probed_edge, sample_scenario
from tactile_gym.estimation import AxisEstimate, AxisPrior, JointAxisEstimator
from tactile_gym.sensing import FingertipGeometry, SensorConfig, Touch, TouchSensor

__all__ = [
    "DISTINCT_ANGLE",
    "GateConfig",
    "Measurement",
    "MeasurementPipeline",
    "reset_distribution_prior",
]

#: Edge directions closer than this count as one link angle in the progress, rad.
DISTINCT_ANGLE = float(np.deg2rad(3.0))
#: Scenario draws behind the prior (the reset distribution's), from a fixed seed.
PRIOR_SAMPLES = 512


class MeasurementPipeline:
    """Turns each step's F/T reading and fingertip pose into measurements and an estimate.

    Args:
        geometry: the fingertip.
        sensor: the F/T sensor's noise (the predicted errors of the sensing).
        skin_stiffness: Winkler modulus of the skin, N/m^3 (the indentation correction).
        gate: the gate's thresholds.
        estimator: ``"planar"`` or ``"3d"`` (``JointAxisEstimator``'s mode).
        loss: the estimator's robust loss.
        prior: the axis prior; the estimate before any measurement.
        edge_distance: expected distance of the probed edge from the axis (mean, std), m.
    """

    def __init__(
        self,
        geometry: FingertipGeometry,
        sensor: SensorConfig,
        skin_stiffness: float,
        gate: GateConfig,
        estimator: str,
        loss: str,
        prior: AxisPrior,
        edge_distance: tuple[float, float],
    ) -> None:
        self.sensor = TouchSensor(geometry, sensor, skin_stiffness)
        self.gate = MeasurementGate(gate, self.sensor)
        self.gate.edge_distance = edge_distance
        # The estimator fuses the prior with the measurements (maximum a posteriori), so its
        # estimate is the prior before any measurement and leaves it as evidence accrues.
        self.estimator = JointAxisEstimator(mode=estimator, loss=loss, prior=prior)
        self.measurements: list[Measurement] = []

    def reset(self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> None:
        """Start an episode from its first reading (sensed, not offered to the gate)."""
        self.gate.reset()
        self.estimator.reset()
        self.measurements = []
        self._directions: list[np.ndarray] = []  # one representative per distinct direction
        self.span = 0.0
        self.estimate: AxisEstimate = self.estimator.estimate()
        self.touch: Touch = self.sensor.sense(wrench, rotation, position)

    def step(self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> int:
        """Take one control step's reading; return how many measurements it added.

        Args:
            wrench: (6,) the F/T reading, sensor frame, N and N m.
            rotation: (3, 3) the fingertip's rotation after the step, sensor to world.
            position: (3,) the sensor origin after the step, world frame, m.
        """
        self.touch = self.sensor.sense(wrench, rotation, position)
        offered = self.gate.offer(wrench, rotation, position, self.touch)
        accepted = [m for m in offered if self.gate.same_edge(m, self.estimate)]
        for m in accepted:
            self.estimator.add(m.point, m.edge, m.point_std, m.edge_std, edge_cov=m.edge_cov)
            self._count_direction(m.edge)
        self.measurements.extend(accepted)
        if accepted:
            self.estimate = self.estimator.estimate()
        return len(accepted)

    @property
    def directions(self) -> int:
        """Distinct edge directions measured (closer than ``DISTINCT_ANGLE`` count as one)."""
        return len(self._directions)

    @property
    def last(self) -> Measurement | None:
        """The last accepted measurement, or None."""
        return self.measurements[-1] if self.measurements else None

    def _count_direction(self, edge: np.ndarray) -> None:
        """Update the span and the distinct directions of the measured edges with one more."""
        if self._directions:
            cos = np.array(self._directions) @ edge
            self.span = max(self.span, float(np.arccos(np.clip(cos.min(), -1.0, 1.0))))
            if cos.max() >= np.cos(DISTINCT_ANGLE):
                return
        self._directions.append(edge)


def reset_distribution_prior(
    families: tuple[str, ...],
    scenario: ScenarioConfig,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: dict,
) -> tuple[AxisPrior, tuple[float, float]]:
    """What is known before touching: the axis prior of a reset distribution, and the
    distance of the probed edge from the axis (mean, std, m; ``MeasurementGate.same_edge``).

    Drawn from ``PRIOR_SAMPLES`` scenarios (one without ``randomize``) of a fixed seed, never
    from an episode. Every env made with the same families, ranges and overrides draws the
    same scenarios, so the result is drawn once per process and shared (its arrays are
    read-only): the draws are most of a ``gym.make``'s time.
    """
    return _drawn_prior(
        tuple(families),
        _frozen(dataclasses.asdict(scenario)),
        geometry,
        bool(randomize),
        _frozen(object_overrides),
    )


@functools.lru_cache(maxsize=64)
def _drawn_prior(
    families: tuple[str, ...],
    scenario: tuple,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: tuple,
) -> tuple[AxisPrior, tuple[float, float]]:
    """``reset_distribution_prior`` of hashable (``_frozen``) arguments."""
    scenario_config = ScenarioConfig(**dict(scenario))
    rng = np.random.default_rng(0)
    pins, directions, distances = [], [], []
    for _ in range(PRIOR_SAMPLES if randomize else 1):
        drawn = sample_scenario(
            rng, families, scenario_config, geometry, randomize, dict(object_overrides)
        )
        config = drawn.object_config
        pins.append(config.joint_position)
        directions.append(config.axis)
        origin, edge, _, _ = probed_edge(config, 0.0)
        distances.append(
            line_distance(origin, edge, np.asarray(config.joint_position), config.axis)
        )
    prior = AxisPrior.from_samples(np.array(pins), np.array(directions))
    for array in (prior.pin, prior.pin_cov, prior.direction):
        array.flags.writeable = False
    return prior, (float(np.mean(distances)), float(np.std(distances)))


def _frozen(value: Any) -> Any:
    """A hashable copy of a config value: dicts as sorted item pairs, sequences as tuples."""
    if isinstance(value, dict):
        return tuple(sorted((key, _frozen(item)) for key, item in value.items()))
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_frozen(item) for item in value)
    return value
