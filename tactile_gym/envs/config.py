"""``HingeProbeConfig``: every parameter of the ``HingeProbe`` envs, each a keyword of
``gym.make`` (``docs/design.md`` 9).

Each default lives here or in the nested config it overrides (``SkinConfig``, ``SensorConfig``,
``ObjectConfig``, ``GateConfig``, ``TaskConfig``, ``ScenarioConfig``); the registered ids
(``tactile_gym/__init__.py``) set only what differs between versions. The nested configs are
built and checked once, when the config is made.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from tactile_gym.envs.scenarios import (
    FAMILIES,
    Scenario,
    ScenarioConfig,
    reset_distribution_prior,
    sample_scenario,
)
from tactile_gym.envs.task import TaskConfig
from tactile_gym.estimation import COVARIANCES, LOSSES, AxisPrior, JointAxisEstimator
from tactile_gym.perception import GateConfig, MeasurementPipeline, StreamLimits
from tactile_gym.perception.log import LogHeader
from tactile_gym.sensing import SENSOR_MODELS, FingertipGeometry, SensorConfig
from tactile_gym.sim import ObjectConfig, SkinConfig
from tactile_gym.sim.config import family_joint_type
from tactile_gym.sim.scene import FORCE_LIMIT, PHYSICS
from tactile_gym.sim.world import SUBSTEPS, TIME_STEP
from tactile_gym.validation import (
    build_config,
    check_bool,
    check_choice,
    check_int,
    check_keywords,
    check_number,
)

__all__ = ["PLANAR_FAMILIES", "HingeProbeConfig"]

#: The families whose joint the planar estimator takes: lying on the table, a vertical axis
#: or a slide along the table (or no joint).
PLANAR_FAMILIES = ("scissors", "slider", "block")


@dataclass(frozen=True)
class HingeProbeConfig:
    """Every parameter of the env; each is a keyword of ``gym.make``.

    The physical parameters are nested: ``skin``, ``sensor`` and ``object`` take fields of
    :class:`~tactile_gym.sim.SkinConfig`, :class:`~tactile_gym.sensing.SensorConfig` and
    :class:`~tactile_gym.sim.ObjectConfig` (the last applied to every family before the reset
    draws); ``gate``, ``task`` and ``scenario`` take fields of ``GateConfig``, ``TaskConfig``
    and ``ScenarioConfig``. Each holds only what differs from those classes' defaults.

    Attributes:
        families: object families drawn at reset, from ``scissors, door, lid, tilted`` (the
            families whose joint type is in ``JOINT_TYPES``).
        estimator: ``"planar"`` (axis along world z, paper eq. 16-21) or ``"3d"``.
        estimator_loss: robust loss of the estimator (``tactile_gym.estimation.LOSSES``).
        estimator_covariance: what the estimator takes each measurement's handed noise for
            (``tactile_gym.estimation.COVARIANCES``): ``"independent"`` (the v2 and v1 ids')
            or ``"calibrated"`` (with the systematic parts of a press's error,
            ``docs/design.md`` 6.9; the v3 ids').
        observation_mode: ``"dict"`` or ``"flat"`` (one Box in the order of
            ``tactile_gym.envs.observation.OBSERVATION_LAYOUT``).
        max_steps: control steps before the episode is truncated.
        time_step: physics time step, s.
        substeps: physics steps per control step (12 at 1/240 s gives 20 Hz control).
        max_translation: fingertip translation for an action of 1, m (10 um to 10 mm).
        max_rotation: fingertip rotation for an action of 1, rad.
        force_limit: guard that stops the fingertip advancing, and where the force penalty
            starts, N.
        randomize: draw the object, joint angle and fingertip start at reset; when False
            every reset uses the nominal scenario.
        sensor_model: the F/T sensor the ``sensor`` overrides apply to, from
            ``SENSOR_MODELS``: ``"realistic"`` (offset, drift, the fingertip's weight) or
            ``"ideal"`` (white noise only; the v1 ids').
        tare_action: the v2 behaviour: tare at reset and on the action's seventh component
            (the class docstring); False gives the v1 ids' 6-D action and raw reading.
        measure_gradient: the skills' presses step by the force gradient they measure
            (``PressConfig.measure_gradient``, ``docs/design.md`` 5.2) rather than the one
            they assume; how long a probe holds follows the gate (``gate.edge_std_target``).
        physics: the contact step, from ``tactile_gym.sim.scene.PHYSICS``: ``"v2"`` (the v1
            and v2 ids') or ``"v3"`` (the lean step, ``docs/design.md`` 3.6).
        skin, sensor, object, gate, task, scenario: nested overrides (above).
    """

    #: The joint types of the families this env takes (``tactile_gym.sim.JOINT_TYPES``).
    JOINT_TYPES: ClassVar[tuple[str, ...]] = ("revolute",)

    families: tuple[str, ...] = ("scissors",)
    estimator: str = "planar"
    estimator_loss: str = "soft_l1"
    estimator_covariance: str = "independent"
    observation_mode: str = "dict"
    max_steps: int = 400
    time_step: float = TIME_STEP
    substeps: int = SUBSTEPS
    max_translation: float = 0.002
    max_rotation: float = float(np.deg2rad(3.0))
    force_limit: float = FORCE_LIMIT
    randomize: bool = True
    sensor_model: str = "realistic"
    tare_action: bool = True
    measure_gradient: bool = False
    physics: str = "v2"
    skin: dict = field(default_factory=dict)
    sensor: dict = field(default_factory=dict)
    object: dict = field(default_factory=dict)
    gate: dict = field(default_factory=dict)
    task: dict = field(default_factory=dict)
    scenario: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        families = (self.families,) if isinstance(self.families, str) else self.families
        if not isinstance(families, (tuple, list)) or not families:
            raise ValueError(f"families must be a non-empty list from {FAMILIES}, got {families!r}")
        fit = tuple(f for f in FAMILIES if family_joint_type(f) in self.JOINT_TYPES)
        for family in families:
            if family in FAMILIES and family not in fit:
                raise ValueError(
                    f"families: {family!r} has a {family_joint_type(family)} joint, and this"
                    f" env takes {' or '.join(self.JOINT_TYPES)} joints only: one of {fit}"
                )
            check_choice("families[...]", family, fit)
        object.__setattr__(self, "families", tuple(families))
        check_choice("estimator", self.estimator, ("planar", "3d"))
        check_choice("estimator_loss", self.estimator_loss, LOSSES)
        check_choice("estimator_covariance", self.estimator_covariance, COVARIANCES)
        check_choice("observation_mode", self.observation_mode, ("dict", "flat"))
        if self.estimator == "planar" and set(self.families) - set(PLANAR_FAMILIES):
            raise ValueError(
                "estimator='planar' assumes a vertical axis or a slide along the table, which"
                f" only the families {PLANAR_FAMILIES} have; got families {self.families}."
                " Use estimator='3d'."
            )
        check_int("max_steps", self.max_steps, 1, 100_000)
        check_number("time_step", self.time_step, 1e-4, 0.02)
        check_int("substeps", self.substeps, 1, 100)
        check_number("max_translation", self.max_translation, 1e-5, 0.01)
        check_number("max_rotation", self.max_rotation, 0.0, 0.2, low_open=True)
        check_number("force_limit", self.force_limit, 0.5, 50.0)
        check_bool("randomize", self.randomize)
        check_choice("sensor_model", self.sensor_model, SENSOR_MODELS)
        check_bool("tare_action", self.tare_action)
        check_bool("measure_gradient", self.measure_gradient)
        check_choice("physics", self.physics, PHYSICS)
        # Build every nested config here, once (each is cached), so that a bad field fails at
        # construction.
        self.skin_config  # noqa: B018
        self.sensor_config  # noqa: B018
        axis = np.asarray(self.object_config("scissors").axis)
        if self.estimator == "planar" and abs(axis[2]) < (1.0 - 1e-9) * np.linalg.norm(axis):
            raise ValueError(
                f"estimator='planar' assumes a vertical axis, got object.axis {axis.tolist()}."
                " Use estimator='3d'."
            )
        self.gate_config  # noqa: B018
        self.scenario_config  # noqa: B018
        task = self.task_config
        if not task.hard_force_limit > self.force_limit:
            raise ValueError(
                f"task.hard_force_limit must exceed force_limit ({self.force_limit} N),"
                f" got {task.hard_force_limit!r}"
            )

    @functools.cached_property
    def skin_config(self) -> SkinConfig:
        """The ``skin`` overrides applied to ``SkinConfig``'s defaults."""
        return build_config(SkinConfig, self.skin, "skin")

    @functools.cached_property
    def sensor_config(self) -> SensorConfig:
        """``sensor_model``'s sensor with the ``sensor`` overrides (or ``sensor`` itself, a
        ``SensorConfig``)."""
        if isinstance(self.sensor, SensorConfig):
            return self.sensor
        build_config(SensorConfig, self.sensor, "sensor")  # unknown or bad fields fail here
        changes = {k: tuple(v) if isinstance(v, list) else v for k, v in self.sensor.items()}
        return SensorConfig.preset(self.sensor_model, **changes)

    def object_config(self, family: str) -> ObjectConfig:
        """The nominal object of a family with the ``object`` overrides."""
        if not isinstance(self.object, dict) or not all(isinstance(k, str) for k in self.object):
            raise ValueError(f"object must be a dict of ObjectConfig fields, got {self.object!r}")
        return ObjectConfig.family_default(family, **self.object)

    @functools.cached_property
    def gate_config(self) -> GateConfig:
        """The ``gate`` overrides applied to ``GateConfig``'s defaults."""
        return build_config(GateConfig, self.gate, "gate")

    @functools.cached_property
    def task_config(self) -> TaskConfig:
        """The ``task`` overrides applied to ``TaskConfig``'s defaults."""
        return build_config(TaskConfig, self.task, "task")

    @functools.cached_property
    def scenario_config(self) -> ScenarioConfig:
        """The ``scenario`` overrides applied to ``ScenarioConfig``'s defaults."""
        return build_config(ScenarioConfig, self.scenario, "scenario")

    def draw_scenario(self, rng: np.random.Generator, geometry: FingertipGeometry) -> Scenario:
        """One episode's start from the reset distribution (``sample_scenario``)."""
        return sample_scenario(
            rng, self.families, self.scenario_config, geometry, self.randomize, self.object
        )

    def prior(self, geometry: FingertipGeometry) -> tuple[AxisPrior, tuple[float, float]]:
        """What is known before touching: the reset distribution's axis prior and probed-edge
        distance (``reset_distribution_prior``)."""
        return reset_distribution_prior(
            self.families, self.scenario_config, geometry, self.randomize, self.object
        )

    def pipeline(self, geometry: FingertipGeometry) -> MeasurementPipeline:
        """The measurement pipeline of an env: its sensor, skin, gate and estimator, handed
        what is known before touching (``prior``)."""
        prior, edge_distance = self.prior(geometry)
        return MeasurementPipeline(
            geometry,
            self.sensor_config,
            self.skin_config.normal_stiffness,
            self.gate_config,
            JointAxisEstimator(
                mode=self.estimator,
                loss=self.estimator_loss,
                prior=prior,
                covariance=self.estimator_covariance,
            ),
            edge_distance,
            StreamLimits(period=self.time_step * self.substeps),
        )

    def log_header(self, geometry: FingertipGeometry, source: str = "") -> LogHeader:
        """The header of this env's logs (``tactile_gym.perception.log``): what its pipeline
        is built from, so that a replay builds the same one."""
        prior, edge_distance = self.prior(geometry)
        return LogHeader(
            period=self.time_step * self.substeps,
            skin_stiffness=self.skin_config.normal_stiffness,
            fingertip=dataclasses.asdict(geometry),
            sensor=dataclasses.asdict(self.sensor_config),
            gate=dataclasses.asdict(self.gate_config),
            estimator={
                "mode": self.estimator,
                "loss": self.estimator_loss,
                "covariance": self.estimator_covariance,
            },
            prior={
                "pin": prior.pin.tolist(),
                "pin_cov": prior.pin_cov.tolist(),
                "direction": prior.direction.tolist(),
                "angle_std": prior.angle_std,
            },
            edge_distance=edge_distance,
            source=source,
        )

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any]) -> HingeProbeConfig:
        """Build a config from keywords; an unknown one raises ``UnknownKeywordError`` (a
        ``TypeError`` and a ``ValueError``) naming it and the allowed ones."""
        env = cls.__name__.replace("Config", "Env")
        check_keywords(env, kwargs, [f.name for f in dataclasses.fields(cls)])
        return cls(
            **{
                k: tuple(v) if k == "families" and isinstance(v, list) else v
                for k, v in kwargs.items()
            }
        )
