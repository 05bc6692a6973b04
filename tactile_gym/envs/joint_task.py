"""Reward, success and termination of the joint-type task (``docs/design.md`` 7.12).

The axis task's rules (``task.py``) with one error that includes the joint type. With
``p`` the estimated probability of the true type (of rigid, revolute, prismatic and none) and
``E_params`` the error of the true type's parameters as its model estimates them, capped at
``E_max``:

    E = (1 - p) E_max + p E_params

* revolute: ``E_params = min(position_error + L angle_error, E_max)`` (the axis task's E);
* prismatic: ``min(L direction_error, E_max)``, L = 0.05 m/rad as there;
* rigid: 0: nothing to estimate.

A step earns ``(E_{t-1} - E_t) / E_scale`` less the axis task's penalties, and ``E_0`` is
the prior's, so the return telescopes to the error removed from what was known before
touching. ``E`` is linear in ``p`` with slope ``E_params - E_max <= 0``: it never rises when
the true type gains probability, and confidence in a wrong type leaves ``p`` near 0 and ``E``
near the cap whatever the parameters: it cannot be gamed by sharpening the estimate, only by
making it right (``docs/design.md`` 7.12).

Success needs the most probable outcome to be the true type and the true type's parameter
errors under the axis task's thresholds (a prismatic joint's position error and a rigid
link's errors are 0 by definition).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tactile_gym.envs.task import AxisEstimationTask, StepFacts
from tactile_gym.estimation import JOINT_TYPES, OUTCOMES

__all__ = ["JointStepFacts", "JointTypeTask"]


@dataclass(frozen=True)
class JointStepFacts(StepFacts):
    """``StepFacts`` of the joint task: ``position_error`` and ``angle_error`` are the true
    type's parameter errors (a prismatic joint's direction error as its angle error, 0 for
    its position; 0 and 0 for a rigid link), and:

    Attributes:
        joint_type: the true type, one of ``tactile_gym.estimation.JOINT_TYPES``.
        type_probabilities: (4,) the estimate's probabilities of ``OUTCOMES``.
    """

    joint_type: str = "revolute"
    type_probabilities: np.ndarray = field(
        default_factory=lambda: np.full(len(OUTCOMES), 1.0 / len(OUTCOMES))
    )

    @property
    def type_probability(self) -> float:
        """The estimate's probability of the true type."""
        return float(self.type_probabilities[OUTCOMES.index(self.joint_type)])

    @property
    def type_correct(self) -> bool:
        """Whether the true type is more probable than every other outcome (a tie, such as a
        uniform prior's, is not a correct type)."""
        p = np.asarray(self.type_probabilities)
        i = OUTCOMES.index(self.joint_type)
        return bool(p[i] > np.delete(p, i).max())


class JointTypeTask(AxisEstimationTask):
    """Turns joint-type estimates and step facts into rewards, success and termination."""

    def joint_error(self, facts: JointStepFacts) -> float:
        """E of the module docstring, m."""
        p = facts.type_probability
        params = self.combined_error(facts.position_error, facts.angle_error)
        return (1.0 - p) * self.config.error_cap + p * params

    def scored_error(self, facts: JointStepFacts) -> float:
        """The error the reward scores: E; ``prior_error`` while no measurement has entered
        the estimate, when it is set."""
        cfg = self.config
        if cfg.prior_error is not None and facts.measurements == 0:
            return cfg.prior_error
        return self.joint_error(facts)

    def info(
        self,
        facts: JointStepFacts,
        terms: dict[str, float] | None = None,
        reasons: dict[str, bool] | None = None,
    ) -> dict[str, np.generic]:
        """The axis task's entries (``is_success`` needing the type right too), and the true
        ``joint_type`` (a code: its index in ``JOINT_TYPES``, 0 rigid, 1 revolute, 2
        prismatic), ``type_probabilities`` (4,), ``type_correct`` and ``joint_error`` (E)."""
        info = super().info(facts, terms, reasons)
        correct = facts.type_correct
        info["is_success"] = np.bool_(correct and bool(info["is_success"]))
        info["joint_type"] = np.int64(JOINT_TYPES.index(facts.joint_type))
        info["type_probabilities"] = np.array(facts.type_probabilities, dtype=np.float64)
        info["type_correct"] = np.bool_(correct)
        info["joint_error"] = np.float64(self.joint_error(facts))
        return info
