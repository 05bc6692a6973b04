"""Reward, success and termination of the joint-axis estimation task (``docs/design.md`` 7.4,
7.8).

The task sees only numbers that the env hands it: estimation errors (metres, radians), forces
(newtons), the fingertip's distance from the hinge and the action. Keeping these rules here,
away from ``step()``, lets tests check every reward term and every termination reason directly
(dm_control's ``Task`` split).

Reward. With the combined error ``E = min(position_error + L * angle_error, E_max)``, a step
earns ``(E_{t-1} - E_t) / E_scale`` minus its penalties, and ``E_0`` is the error of the
estimate at reset. The env's estimate at reset is its prior: the nominal layout and the spread
of the reset distribution (``tactile_gym.estimation.AxisPrior``), what a user knows before
touching anything. So the return telescopes to ``(E_0 - E_T) / E_scale``, the error the agent
removed from what it knew at the start: an early, poorly supported estimate does not pay
unless it is better than the prior, and random actions earn about nothing. A step that ends
the episode as a failure (``TERMINATION_REASONS``) also pays ``termination_penalty``: without it
a failure only forfeits the error still to be removed, which early in an episode is little.

``prior_error`` scores the prior by a fixed error instead of its true one: while no
measurement has entered the estimate, ``E`` is ``prior_error``, and the return becomes
``(prior_error - E_T) / E_scale``. It differs from the default return by ``E_0 - prior_error``,
a constant of the episode that no action changes and no observation shows, so the optimal
policy is the same; but the return then varies with the final error alone, not with the
prior's error, which dominates the default return's spread (``docs/design.md`` 12). It is a
training option: the ids' default stays the prior's true error.

``reward_source="predicted"`` scores the estimator's own predicted error instead of the true
one: ``U = min(position_std + L * angle_std, E_max)``, from the uncertainty the estimate states
(``AxisEstimate.position_std``, ``angle_std``), with the prior's as ``U_0``. A robot can
compute it, so a policy can be trained or fine-tuned on hardware; it is honest only as far as
the predicted uncertainty is calibrated (``docs/design.md`` 6, 7.4). ``info`` keeps the true
errors for evaluation, and ``predicted_error`` (U) under either source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.validation import check_choice, check_number

__all__ = [
    "AxisEstimationTask",
    "REWARD_SOURCES",
    "WORKSPACE_CENTERS",
    "REWARD_TERMS",
    "StepFacts",
    "TaskConfig",
    "TERMINATION_REASONS",
]

#: The terms of a step's reward, as named in ``info``; they sum to the reward.
REWARD_TERMS = (
    "reward_error_reduction",
    "reward_force_penalty",
    "reward_action_cost",
    "reward_termination",
)

#: What the reward's error reduction can score (``TaskConfig.reward_source``).
REWARD_SOURCES = ("truth", "predicted")
#: Where the workspace is centred (``TaskConfig.workspace_center``).
WORKSPACE_CENTERS = ("hinge", "start")

#: Why an episode can end as a failure, in the order they are checked.
TERMINATION_REASONS = ("left_workspace", "shell_contact", "overloaded")


@dataclass(frozen=True)
class TaskConfig:
    """Weights and thresholds of the task.

    Attributes:
        error_angle_scale: L in E = position error + L * angle error, m/rad.
        error_cap: E_max, the cap on E, m.
        error_scale: E_scale, the error reduction worth a reward of 1, m.
        force_penalty: penalty per unit of relative excess force, (|f| - limit) / limit.
        action_cost: penalty per unit of squared action norm.
        success_position: position error below which the episode counts as a success, m.
        success_angle: angle error below which the episode counts as a success, rad.
        hard_force_limit: force that ends the episode as a failure, N.
        workspace_radius: the episode fails when the sensor origin is further than this from
            the workspace's centre, m.
        workspace_center: that centre: ``"hinge"``, the true hinge pin, or ``"start"``, the
            sensor origin where the episode started (what a robot knows: with
            ``reward_source="predicted"`` nothing of the task then reads the truth).
        termination_penalty: reward lost by the step that ends the episode as a failure
            (``TERMINATION_REASONS``), in units of reward (1 = ``error_scale`` of error).
        prior_error: the error E counts as while no measurement has entered the estimate,
            m; None: the prior's true error (module docstring).
        reward_source: what the error reduction scores: ``"truth"``, the true error E, or
            ``"predicted"``, the estimator's predicted error U (module docstring).
    """

    error_angle_scale: float = 0.05
    error_cap: float = 0.1
    error_scale: float = 0.01
    force_penalty: float = 0.1
    action_cost: float = 1e-3
    success_position: float = 0.002
    success_angle: float = float(np.deg2rad(2.0))
    hard_force_limit: float = 30.0
    workspace_radius: float = 0.25
    workspace_center: str = "hinge"
    termination_penalty: float = 0.0
    prior_error: float | None = None
    reward_source: str = "truth"

    def __post_init__(self) -> None:
        check_number("task.error_angle_scale", self.error_angle_scale, 0.0, 1.0)
        check_number("task.error_cap", self.error_cap, 0.0, 1.0, low_open=True)
        check_number("task.error_scale", self.error_scale, 1e-5, 1.0)
        check_number("task.force_penalty", self.force_penalty, 0.0, 100.0)
        check_number("task.action_cost", self.action_cost, 0.0, 10.0)
        check_number("task.success_position", self.success_position, 0.0, 0.1, low_open=True)
        check_number("task.success_angle", self.success_angle, 0.0, np.pi / 2, low_open=True)
        check_number("task.hard_force_limit", self.hard_force_limit, 1.0, 200.0)
        check_number("task.workspace_radius", self.workspace_radius, 0.05, 1.0)
        check_choice("task.workspace_center", self.workspace_center, WORKSPACE_CENTERS)
        check_number("task.termination_penalty", self.termination_penalty, 0.0, 100.0)
        if self.prior_error is not None:
            check_number("task.prior_error", self.prior_error, 0.0, self.error_cap, low_open=True)
        check_choice("task.reward_source", self.reward_source, REWARD_SOURCES)


@dataclass(frozen=True)
class StepFacts:
    """What the task needs to know about one control step.

    Attributes:
        position_error: distance from the true hinge pin to the estimated axis, m.
        angle_error: angle between the estimated and the true axis, rad.
        max_force: largest contact force during the step, N.
        force_limit: the guarded move's limit, where the force penalty starts, N.
        shell_contact: the object reached the rigid shell through the skin.
        hinge_distance: distance of the fingertip's sensor origin from the hinge pin, m.
        start_distance: its distance from where it started the episode, m.
        action: the normalised action.
        measurements: measurements in the estimate (0: it is the prior).
        position_std: the estimate's predicted position error (1 sigma), m.
        angle_std: its predicted angle error (1 sigma), rad.
    """

    position_error: float
    angle_error: float
    max_force: float
    force_limit: float
    shell_contact: bool
    hinge_distance: float
    action: np.ndarray
    measurements: int
    position_std: float = float("inf")
    angle_std: float = float("inf")
    start_distance: float = 0.0


class AxisEstimationTask:
    """Turns estimation errors and step facts into rewards, success and termination."""

    def __init__(self, config: TaskConfig) -> None:
        self.config = config
        self._previous_error = config.error_cap

    def combined_error(self, position_error: float, angle_error: float) -> float:
        """E = position error + L * angle error, capped at E_max (m)."""
        error = position_error + self.config.error_angle_scale * angle_error
        if not math.isfinite(error):
            return self.config.error_cap
        return float(min(error, self.config.error_cap))

    def scored_error(self, facts: StepFacts) -> float:
        """The error the reward scores (``reward_source``): E, or U; ``prior_error`` while no
        measurement has entered the estimate, when it is set."""
        cfg = self.config
        if cfg.prior_error is not None and facts.measurements == 0:
            return cfg.prior_error
        if cfg.reward_source == "predicted":
            return self.combined_error(facts.position_std, facts.angle_std)
        return self.combined_error(facts.position_error, facts.angle_error)

    def initialize_episode(self, facts: StepFacts) -> None:
        """Start an episode from the estimate at reset (the prior): its scored error."""
        self._previous_error = self.scored_error(facts)

    def get_reward(self, facts: StepFacts, terminated: bool) -> tuple[float, dict[str, float]]:
        """Reward for one step and its terms, which sum to the reward; a step that fails
        (``terminated``, from :meth:`get_termination`) pays the termination penalty."""
        cfg = self.config
        error = self.scored_error(facts)
        error_reduction = (self._previous_error - error) / cfg.error_scale
        self._previous_error = error
        excess = max(facts.max_force - facts.force_limit, 0.0) / facts.force_limit
        action = np.asarray(facts.action, dtype=float)
        values = (
            error_reduction,
            -cfg.force_penalty * excess,
            -cfg.action_cost * (action @ action),
            -cfg.termination_penalty * bool(terminated),
        )
        terms = {name: float(value) for name, value in zip(REWARD_TERMS, values)}
        return float(sum(terms.values())), terms

    def get_termination(self, facts: StepFacts) -> dict[str, bool]:
        """Each failure reason (``TERMINATION_REASONS``) and whether it happened."""
        return {
            "left_workspace": bool(self._workspace_distance(facts) > self.config.workspace_radius),
            "shell_contact": bool(facts.shell_contact),
            "overloaded": bool(facts.max_force > self.config.hard_force_limit),
        }

    def _workspace_distance(self, facts: StepFacts) -> float:
        if self.config.workspace_center == "start":
            return facts.start_distance
        return facts.hinge_distance

    def info(
        self,
        facts: StepFacts,
        terms: dict[str, float] | None = None,
        reasons: dict[str, bool] | None = None,
    ) -> dict[str, np.generic]:
        """The task's entries of a step's ``info``, NumPy scalars: success, the true errors,
        the predicted error U, each reward term (``REWARD_TERMS``) and a
        ``termination_<reason>`` flag per reason (``TERMINATION_REASONS``); without a step (a
        reset) the terms are 0 and the flags False."""
        info = {
            "is_success": np.bool_(self.is_success(facts.position_error, facts.angle_error)),
            "position_error": np.float64(facts.position_error),
            "angle_error": np.float64(facts.angle_error),
            "predicted_error": np.float64(self.combined_error(facts.position_std, facts.angle_std)),
        }
        for term in REWARD_TERMS:
            info[term] = np.float64(0.0 if terms is None else terms[term])
        for reason in TERMINATION_REASONS:
            info[f"termination_{reason}"] = np.bool_(reasons is not None and reasons[reason])
        return info

    def is_success(self, position_error: float, angle_error: float) -> bool:
        """Both errors below their success thresholds."""
        return bool(
            position_error < self.config.success_position
            and angle_error < self.config.success_angle
        )
