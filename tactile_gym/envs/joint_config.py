"""``JointProbeConfig``: every parameter of the ``JointProbe`` envs, each a keyword of
``gym.make`` (``docs/design.md`` 7.12, 9).

It is ``HingeProbeConfig`` with families of every joint type, a pipeline that drives the
joint-type estimator (``tactile_gym.perception.JointPipeline``), and what that estimator is
told before touching: the reset distribution's share of each joint type, its revolute axis
and its slides' range (``joint_type_prior``).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from tactile_gym.envs.config import HingeProbeConfig
from tactile_gym.envs.scenarios import ScenarioConfig, reset_distribution_prior, sample_scenario
from tactile_gym.estimation import JOINT_TYPES as ESTIMATED_TYPES
from tactile_gym.estimation import JointTypeEstimator, JointTypePrior
from tactile_gym.perception import JointPipeline, LabelConfig, StreamLimits
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.sim import ObjectConfig
from tactile_gym.sim.config import JOINT_TYPES, family_joint_type
from tactile_gym.validation import build_config, check_bool

__all__ = ["JOINT_SCENARIO", "TYPE_OF_JOINT", "JointProbeConfig", "joint_type_prior"]

#: The estimator's name (``tactile_gym.estimation.JOINT_TYPES``) of each simulated joint.
TYPE_OF_JOINT = {"fixed": "rigid", "revolute": "revolute", "prismatic": "prismatic"}
#: Least prior probability of a joint type that the reset distribution does not draw: the
#: estimator takes no type as impossible.
TYPE_FLOOR = 0.01
#: The joint ids' reset draws beyond ``ScenarioConfig``'s defaults, by estimator: every
#: family's layout yawed (the scissors too, whose layout would otherwise tell them apart),
#: and in 3D the probed edge's height drawn for every family (the families' own heights
#: differ by type).
JOINT_SCENARIO = {
    "planar": {"fixed_layouts": ()},
    "3d": {"fixed_layouts": (), "face_height_range": (0.15, 0.25)},
}
#: ``JointTypePrior`` fields the reset distribution sets (``joint_type_prior``); the
#: ``joint_prior`` keyword may set the others.
_DRAWN = ("axis",)


@dataclass(frozen=True)
class JointProbeConfig(HingeProbeConfig):
    """``HingeProbeConfig`` for an unknown joint (module docstring); each field is a keyword
    of ``gym.make``.

    Attributes:
        families: object families drawn at reset, from every family
            (``tactile_gym.sim.config.FAMILIES``): revolute, prismatic and fixed.
        labels: fields of ``tactile_gym.perception.LabelConfig``: how presses are labelled by
            edge line and link configuration.
        joint_prior: fields of ``tactile_gym.estimation.JointTypePrior`` but ``axis``: its
            defaults but the type probabilities (the share of each joint type among
            ``families``, at least ``TYPE_FLOOR``) and the travel range (the slides' widest
            range) come from the reset distribution (``joint_type_prior``).
        restart_misfits: the joint-type estimator refits a model whose refit from its last
            solution fails its goodness-of-fit test from scratch too
            (``JointTypeEstimator``'s ``restart_misfits``; the v1 ids).

    The rest as ``HingeProbeConfig``, with 800 control steps (40 s: telling the joint apart
    takes pushes as well as presses), the v3 ids' contact step and calibrated covariance by
    default (``physics="v3"``, ``estimator_covariance="calibrated"``), and ``scenario``
    applied over ``JOINT_SCENARIO`` (every family's layout yawed at random; with the 3D
    estimator, the probed edge at a height drawn for every family). ``task.reward_source``
    must be ``"truth"`` (the joint task has no predicted error to score).
    """

    JOINT_TYPES: ClassVar[tuple[str, ...]] = JOINT_TYPES

    families: tuple[str, ...] = ("scissors", "slider", "block")
    max_steps: int = 800
    physics: str = "v3"
    estimator_covariance: str = "calibrated"
    labels: dict = field(default_factory=dict)
    joint_prior: dict = field(default_factory=dict)
    restart_misfits: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        self.label_config  # noqa: B018 - built and checked once
        check_bool("restart_misfits", self.restart_misfits)
        if not isinstance(self.joint_prior, dict) or set(self.joint_prior) & set(_DRAWN):
            raise ValueError(
                "joint_prior must be a dict of JointTypePrior fields but"
                f" {_DRAWN} (the reset distribution's), got {self.joint_prior!r}"
            )
        build_config(JointTypePrior, self.joint_prior, "joint_prior")
        if self.task_config.reward_source != "truth":
            raise ValueError(
                "task.reward_source must be 'truth' on the joint ids (no predicted error of"
                f" the joint type is scored), got {self.task_config.reward_source!r}"
            )

    @functools.cached_property
    def scenario_config(self) -> ScenarioConfig:
        """``JOINT_SCENARIO`` (its ``"3d"`` entry with the 3D estimator), then the ``scenario``
        overrides, applied to ``ScenarioConfig``'s defaults."""
        if not isinstance(self.scenario, dict):
            raise ValueError(
                f"scenario must be a dict of ScenarioConfig fields, got {self.scenario!r}"
            )
        defaults = JOINT_SCENARIO[self.estimator]
        return build_config(ScenarioConfig, {**defaults, **self.scenario}, "scenario")

    @functools.cached_property
    def label_config(self) -> LabelConfig:
        """The ``labels`` overrides applied to ``LabelConfig``'s defaults."""
        return build_config(LabelConfig, self.labels, "labels")

    def joint_type_prior(self, geometry: FingertipGeometry) -> JointTypePrior:
        """What the estimator knows before touching (``joint_type_prior``), with the
        ``joint_prior`` overrides."""
        drawn = joint_type_prior(
            self.families,
            self.scenario_config,
            geometry,
            self.randomize,
            self.object,
            self.estimator,
        )
        return dataclasses.replace(drawn, **self.joint_prior)

    def pipeline(self, geometry: FingertipGeometry) -> JointPipeline:
        """The env's pipeline: its sensor, skin and gate, and the joint-type estimator with
        the reset distribution's priors."""
        estimator = JointTypeEstimator(
            mode=self.estimator,
            prior=self.joint_type_prior(geometry),
            loss=self.estimator_loss,
            covariance=self.estimator_covariance,
            restart_misfits=self.restart_misfits,
        )
        return JointPipeline(
            geometry,
            self.sensor_config,
            self.skin_config.normal_stiffness,
            self.gate_config,
            estimator,
            self.label_config,
            StreamLimits(period=self.time_step * self.substeps),
        )


def joint_type_prior(
    families: tuple[str, ...],
    scenario: ScenarioConfig,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: dict,
    mode: str,
) -> JointTypePrior:
    """The joint-type estimator's priors from a reset distribution (never from an episode):

    * ``type_probabilities``: each joint type's share of ``families`` (which the reset draws
      uniformly), at least ``TYPE_FLOOR``;
    * ``axis``: the revolute families' axis prior (``reset_distribution_prior``); without a
      revolute family, the estimator's broad default about the families' mean pin;
    * ``travel_range``: the widest joint range of the prismatic families (else the default).

    ``mode`` is the estimator's, ``"planar"`` or ``"3d"``. The revolute axis prior is drawn
    once per process for each distribution (``reset_distribution_prior`` is cached).
    """
    types = [TYPE_OF_JOINT[family_joint_type(f)] for f in families]
    shares = [max(types.count(t) / len(types), TYPE_FLOOR) for t in ESTIMATED_TYPES]
    revolute = tuple(f for f in families if family_joint_type(f) == "revolute")
    if revolute:
        axis, _ = reset_distribution_prior(
            revolute, scenario, geometry, randomize, object_overrides
        )
    else:
        default = JointTypePrior()
        pins = [
            sample_scenario(
                np.random.default_rng(0), (f,), scenario, geometry, False, object_overrides
            ).object_config.joint_position
            for f in families
        ]
        axis = default.axis_prior(mode, np.mean(pins, axis=0))
    slides = [
        ObjectConfig.family_default(f, **object_overrides)
        for f in families
        if family_joint_type(f) == "prismatic"
    ]
    travel = {}
    if slides:
        travel["travel_range"] = max(c.upper_limit - c.lower_limit for c in slides)
    return JointTypePrior(type_probabilities=tuple(shares), axis=axis, **travel)
