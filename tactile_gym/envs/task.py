"""Reward, success and failure of the joint-axis estimation task.

The task only sees numbers that the env hands it (errors in metres and radians, forces in
newtons, the action); it never touches the simulator. Keeping these rules here, away from
``step()``, lets tests check the reward terms directly (dm_control's ``Task`` split).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AxisEstimationTask", "TaskConfig"]


@dataclass(frozen=True)
class TaskConfig:
    """Weights and thresholds of the task.

    Attributes:
        error_angle_scale: L in E = position error + L * angle error, m/rad.
        error_cap: E_max, the error while there is no estimate (and the cap on E), m.
        error_scale: E_scale, the error reduction worth a reward of 1, m.
        force_limit: force above which the penalty starts, N.
        force_penalty: penalty per unit of relative excess force, (|f| - limit) / limit.
        action_cost: penalty per unit of squared action norm.
        success_position: position error below which the episode counts as a success, m.
        success_angle: angle error below which the episode counts as a success, rad.
    """

    error_angle_scale: float = 0.05
    error_cap: float = 0.1
    error_scale: float = 0.01
    force_limit: float = 8.0
    force_penalty: float = 0.1
    action_cost: float = 1e-3
    success_position: float = 0.002
    success_angle: float = float(np.deg2rad(2.0))


class AxisEstimationTask:
    """Turns estimation errors into rewards.

    The reward is the reduction of the capped combined error,
    ``r_t = (E_{t-1} - E_t) / E_scale - force_penalty - action_cost``, where
    ``E = min(position_error + L * angle_error, E_max)`` and ``E = E_max`` while no estimate
    exists. Without penalties the return telescopes to ``(E_max - E_T) / E_scale``.
    """

    def __init__(self, config: TaskConfig) -> None:
        self.config = config
        self._previous_error = config.error_cap

    def initialize_episode(self) -> None:
        """Start an episode with no estimate: E_0 = E_max."""
        self._previous_error = self.config.error_cap

    def combined_error(self, position_error: float, angle_error: float) -> float:
        """E = position error + L * angle error, capped at E_max (m)."""
        error = position_error + self.config.error_angle_scale * angle_error
        if not np.isfinite(error):
            return self.config.error_cap
        return float(min(error, self.config.error_cap))

    def get_reward(
        self,
        position_error: float,
        angle_error: float,
        max_force: float,
        action: np.ndarray,
    ) -> tuple[float, dict[str, float]]:
        """Reward for one step and its terms.

        Args:
            position_error: distance from the true pin centre to the estimated axis, m
                (inf when there is no estimate).
            angle_error: angle between estimated and true axis, rad (pi/2 when none).
            max_force: largest contact force magnitude during the step, N.
            action: the normalised action in [-1, 1].

        Returns:
            The reward and a dict of its terms, which sum to the reward.
        """
        cfg = self.config
        error = self.combined_error(position_error, angle_error)
        error_reduction = (self._previous_error - error) / cfg.error_scale
        self._previous_error = error
        excess = max(max_force - cfg.force_limit, 0.0) / cfg.force_limit
        terms = {
            "reward_error_reduction": float(error_reduction),
            "reward_force_penalty": float(-cfg.force_penalty * excess),
            "reward_action_cost": float(-cfg.action_cost * float(np.dot(action, action))),
        }
        return float(sum(terms.values())), terms

    def is_success(self, position_error: float, angle_error: float) -> bool:
        """Both errors below their success thresholds."""
        return bool(
            position_error < self.config.success_position
            and angle_error < self.config.success_angle
        )
