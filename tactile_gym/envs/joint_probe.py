"""JointProbe: which joint is it? Identify an object's joint type by touch, and its parameters.

``JointProbeEnv`` is ``HingeProbeEnv``'s machinery (the controller, the scene on the v3 step,
the measurement pipeline, the step guard, the codec) with its own config
(``JointProbeConfig``: families of every joint type, a pipeline that drives the joint-type
estimator), task (``JointTypeTask``) and observation codec (``JOINT_OBSERVATION``). Its class
docstring documents the ids; ``make_vector_env`` is their vector entry point.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

from tactile_gym.envs.hinge_probe import HingeProbeEnv
from tactile_gym.envs.joint_config import TYPE_OF_JOINT, JointProbeConfig
from tactile_gym.envs.joint_task import JointStepFacts, JointTypeTask
from tactile_gym.envs.observation import JOINT_OBSERVATION, JointPipelineParts
from tactile_gym.envs.vector import HingeProbeVectorEnv
from tactile_gym.estimation import JointTypeEstimate, axis_error, direction_error

__all__ = ["JointProbeConfig", "JointProbeEnv", "make_vector_env"]


class JointProbeEnv(HingeProbeEnv):
    """Probe an object whose joint is unknown (a hinge, a slide, or none) with a soft
    fingertip: identify the joint type and estimate its parameters.

    ## Description

    The fingertip, the skin, the F/T sensor, the controller, the taring and the measurement
    gate are ``HingeProbeEnv``'s (``tactile_gym/envs/hinge_probe.py``), on the v3 ids' contact
    step and calibrated covariance (``docs/design.md`` 3.6, 6.9). Each reset draws an object
    from the id's families, so the joint type is unknown to the policy:

    | id                  | families                                          | estimator |
    |---------------------|---------------------------------------------------|-----------|
    | ``JointProbe-v1``   | scissors (revolute), slider (prismatic), block    | planar    |
    | ``JointProbe3D-v1`` | door, tilted (revolute), drawer, tilted_drawer    | 3d        |
    |                     | (prismatic), block (fixed)                        |           |

    A slider is a plate sliding along the table beside a rail; a drawer a box sliding out of
    its cabinet, probed on its top face; a tilted drawer slides 10-30 deg up from horizontal;
    a block is fixed to the table (``configs/objects/``, ``docs/design.md`` 3.7). The probed
    edge at the start is a hinged link's long edge, or a slide's front edge, square to its
    travel. The measurement pipeline (``tactile_gym.perception.JointPipeline``) labels each
    accepted press by the edge line it was on and the link configuration it was taken at, both
    from the readings and the poses alone, and hands it to the joint-type estimator
    (``tactile_gym.estimation.JointTypeEstimator``, ``docs/design.md`` 6.10, 7.12), which
    weighs rigid, revolute and prismatic models (and "none") by their evidence. A link moves
    only when pushed: pressing is measuring, dragging the sticking skin across or along the
    face moves a hinged or sliding link, and what moved between presses tells the joint.

    The scripted baseline (``agents/joint_scripted.py``) and its figures against issue 28's
    targets, with ``python benchmarks/joint_type_scripted.py``: ``docs/design.md`` 7.12.

    ## Action Space

    ``HingeProbeEnv``'s: ``Box(-1, 1, (7,), float32)``, a fingertip translation (2 mm at 1)
    and rotation (3 deg at 1) per step and a tare request (``a[6] > 0.5``).
    (``JointProbePrimitive-v1`` offers probing primitives instead.)

    ## Observation Space

    ``HingeProbeEnv``'s ``Dict`` (``wrench``, ``fingertip_pose``, ``contact``,
    ``last_measurement``, ``progress``), its ``estimate`` being the most probable joint
    type's parameters, and ``joint``:

    | key      | entry (index)       | meaning                                    | unit | frame |
    |----------|---------------------|--------------------------------------------|------|-------|
    | estimate | point (0-2)         | revolute: the axis point closest to the    | m    | world |
    |          |                     | world origin; else 0                       |      |       |
    |          | direction (3-5)     | revolute: the axis; prismatic: the         | -    | world |
    |          |                     | direction of travel; rigid: 0              |      |       |
    |          | position_std (6)    | revolute: 1-sigma position error; else 0   | m    | -     |
    |          | angle_std (7)       | 1-sigma angle error of the direction       | rad  | -     |
    |          |                     | (rigid: 0; prismatic before a fit: pi/2)   |      |       |
    | joint    | probabilities (0-3) | rigid, revolute, prismatic, none           | -    | -     |
    |          | flags (4-9)         | 1 per flag of the estimate: too_few,       | -    | -     |
    |          |                     | one_configuration, no_motion, one_edge,    |      |       |
    |          |                     | none_fits, best_misfits                    |      |       |
    |          | configurations (10) | link configurations pressed (0..1e4)       | -    | -     |
    |          | lines (11)          | edge lines pressed (0..1e4)                | -    | -     |

    "Most probable" is among rigid, revolute and prismatic, ties to the first. Before any
    measurement the probabilities are the prior's: each type's share of the id's families.

    ## Rewards

    ``HingeProbeEnv``'s terms, with one error that includes the type
    (``tactile_gym.envs.joint_task``):

        E = (1 - p) E_max + p E_params

    ``p`` the estimated probability of the true type; ``E_params`` the true type's parameter
    error as its model estimates it, capped at E_max = 0.1 m: revolute
    ``position_error + L angle_error`` (``HingeProbeEnv``'s E), prismatic ``L`` times the
    direction error, rigid 0; L = 0.05 m/rad. ``reward_error_reduction`` is
    ``(E_{t-1} - E_t) / E_scale`` (10 mm), ``E_0`` the prior's: the return is the error
    removed from what was known before touching. Confidence in a wrong type costs the cap.

    ## Starting State

    ``HingeProbeEnv``'s, for every family: the fingertip 2-5 mm above the face that looks up,
    45-75 % along the probed edge, -4..+3 mm across it, leaning 0-15 deg. The layout's yaw is
    drawn in -180..180 deg for every family (the scissors too, unlike ``HingeProbe``), a
    slide's travel in -10..10 mm of its range (-90..30 mm), a hinge's angle in -20..20 deg; on
    ``JointProbe3D-v1`` the probed edge's height in 0.15-0.25 m for every family, so that the
    start's pose does not tell the families apart.

    ## Episode End

    ``HingeProbeEnv``'s: ``terminated`` on ``left_workspace`` (0.25 m from the joint's
    reference point), ``shell_contact`` or ``overloaded``; ``truncated`` after ``max_steps``.
    ``info["is_success"]``: the most probable outcome is the true type, and the true type's
    position error < 2 mm and angle error < 2 deg (0 by definition where the type has none).

    ``info`` is ``HingeProbeEnv``'s (flat, numeric, the same keys at reset and every step)
    with ``position_error`` and ``angle_error`` of the true type's parameters (prismatic: 0
    and the direction error; rigid: 0 and 0), ``true_axis_point`` and ``true_axis_direction``
    (a slide's reference point and direction of travel; a fixed joint's configured axis, which
    nothing turns about), ``joint_angle`` (the joint's coordinate: rad, or m for a slide), and:
    ``joint_type`` (the true type: 0 rigid, 1 revolute, 2 prismatic), ``type_probabilities``
    (4,), ``type_correct`` and ``joint_error`` (E, m).

    ## Arguments

    Every field of ``JointProbeConfig`` is a keyword of ``gym.make``: those of
    ``HingeProbeConfig`` (families from every family: ``scissors, door, lid, tilted, slider,
    drawer, tilted_drawer, block``; an unknown name is a ``ValueError`` naming the allowed
    ones), ``labels`` (``tactile_gym.perception.LabelConfig``: how presses are labelled) and
    ``joint_prior`` (``tactile_gym.estimation.JointTypePrior`` fields but ``axis``, e.g.
    ``stuck_probability``).

    ## Version History

    * v0: initial release, on the v3 ids' contact step and calibrated covariance.
    * v1: every face that looks up at least 17 mm wide (a door and its frame 20 mm thick, a
      slider's rail and a drawer's panel 20 mm wide); a press enters the estimate once a
      second press at least 6 mm along its line agrees with it (or it keeps its line's
      direction, or its distance from a likely hinge); model fits held in a wrong minimum
      refitted from scratch (``docs/design.md`` 7.12).
    """

    config_class = JointProbeConfig
    task_class = JointTypeTask
    observation_codec = JOINT_OBSERVATION
    observation_parts = JointPipelineParts

    @property
    def joint_estimate(self) -> JointTypeEstimate:
        """The current joint-type estimate (``tactile_gym.estimation.JointTypeEstimate``)."""
        return self.pipeline.joint_estimate

    # ------------------------------------------------------------------ ground truth
    def _true_errors(self) -> tuple[float, float]:
        """The true type's parameter errors as its model estimates them (position, angle):
        revolute the axis's, prismatic (0, the direction's), rigid (0, 0); computed once per
        estimate."""
        estimate = self.pipeline.joint_estimate
        if estimate is not self._errors_of:
            joint = self._true_joint_type()
            point, direction = self._scene.true_axis
            if joint == "revolute":
                position, angle = axis_error(self.pipeline.estimate, point, direction, point)
            elif joint == "prismatic":
                # Without a fit the direction is unknown: the worst error, pi/2.
                fit = estimate.models.get("prismatic")
                angle = math.pi / 2 if fit is None else direction_error(fit.parameters, direction)
                position = 0.0
            else:
                position, angle = 0.0, 0.0
            self._errors = (float(position), float(angle))
            self._errors_of = estimate
        return self._errors

    def _true_joint_type(self) -> str:
        """The object's joint type as the estimator names it."""
        return TYPE_OF_JOINT[self._scene.true_joint_type]

    def _true_facts(self, step_info, action: np.ndarray) -> JointStepFacts:
        facts = super()._true_facts(step_info, action)
        return JointStepFacts(
            **{f.name: getattr(facts, f.name) for f in fields(facts)},
            joint_type=self._true_joint_type(),
            type_probabilities=self.pipeline.joint_estimate.probabilities,
        )


def make_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the 6-D joint ids: ``num_envs`` ``JointProbeEnv`` sub-envs."""
    return HingeProbeVectorEnv(JointProbeEnv, num_envs, **kwargs)
