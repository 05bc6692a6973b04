"""What ``agents.train`` hands stable-baselines3 while it learns (``docs/design.md`` 12):
the periodic evaluation on fixed episodes and the checkpoints, each model saved with its
``VecNormalize`` statistics as JSON (``agents.runs``), and the demonstrations' anchor on
PPO's fine-tuning (:class:`DemoAnchor`).

SB3's periodic evaluation plays episodes drawn afresh at each evaluation, so the difference
between two evaluations is mostly the difference between their episodes (the prior's error,
which no policy sees, explains most of a return's variance). :class:`FixedSeedVecEnv` makes
every evaluation play the same episodes: each ``reset()`` starts over at the first seed of
its list, and each episode that ends is followed by the next seed's, so ``n`` episodes after
a reset are always ``seeds[0] .. seeds[n - 1]``, the same episodes ``agents.evaluate`` plays
on those seeds.

Stable-Baselines3 is only in the ``[train]`` extra, so only ``agents`` imports this module.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from .demonstrations import Demos
from .policies import deadband
from .runs import save_statistics, statistics_path
from .warmstart import WarmStart, clone_actions

__all__ = [
    "ActionDeadband",
    "Checkpoints",
    "DemoAnchor",
    "FixedSeedVecEnv",
    "TRUTH_INFO",
    "WithoutTruth",
    "continue_evaluations",
    "fixed_seed_evaluation",
]

#: The entries of an env's ``info`` that come from the simulator's truth (the true errors and
#: success, the true axis and joint angle, the noise-free contact force): what a truth-free
#: run's training loop never sees (:class:`WithoutTruth`).
TRUTH_INFO = (
    "is_success",
    "position_error",
    "angle_error",
    "true_axis_point",
    "true_axis_direction",
    "joint_angle",
    "max_force",
)


class FixedSeedVecEnv(VecEnvWrapper):
    """A one-env ``VecEnv`` whose episodes follow a fixed list of reset seeds (module
    docstring).

    Args:
        venv: a ``VecEnv`` of one env.
        seeds: the reset seeds, in order; the list repeats once exhausted.

    Raises:
        ValueError: a ``venv`` of more than one env, or no seeds.
    """

    def __init__(self, venv: VecEnv, seeds: Sequence[int]) -> None:
        if venv.num_envs != 1:
            raise ValueError(f"FixedSeedVecEnv needs a VecEnv of 1 env, got {venv.num_envs}")
        if len(seeds) == 0:
            raise ValueError("FixedSeedVecEnv needs at least one seed")
        super().__init__(venv)
        self.seeds = [int(s) for s in seeds]
        self.episode = 0

    def _reset_to(self, episode: int) -> np.ndarray:
        self.episode = episode
        self.venv.seed(self.seeds[episode % len(self.seeds)])
        return self.venv.reset()

    def reset(self):
        return self._reset_to(0)

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        if dones[0]:
            # The inner env has already reset itself unseeded: start the next seed instead
            # (the ended episode's last observation stays in the info).
            obs = self._reset_to(self.episode + 1)
        return obs, rewards, dones, infos


class ActionDeadband(VecEnvWrapper):
    """A ``VecEnv`` that executes every action component smaller than ``width`` in magnitude
    as 0 (``agents.policies.deadband``): the algorithm sees the deadband as part of the env,
    and a saved model acts through the same one (``agents.policies.ModelPolicy``)."""

    def __init__(self, venv: VecEnv, width: float) -> None:
        super().__init__(venv)
        self.width = float(width)

    def reset(self):
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(deadband(actions, self.width))

    def step_wait(self):
        return self.venv.step_wait()


class WithoutTruth(VecEnvWrapper):
    """A ``VecEnv`` whose infos lack the truth (:data:`TRUTH_INFO`): a truth-free run wraps
    its training and evaluation envs in it, so that nothing SB3 does with infos (its success
    rates, the evaluation's logs) reads the truth either."""

    def reset(self):
        return self.venv.reset()

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            for key in TRUTH_INFO:
                info.pop(key, None)
        return obs, rewards, dones, infos


class DemoAnchor(BaseCallback):
    """After each PPO update, ``recipe.anchor_epochs`` passes of behaviour cloning over the
    demonstrations at PPO's current learning rate (``agents.warmstart``, ``anchor_epochs``).

    It runs when a rollout starts, the first step after an update; the demonstrations'
    observations are normalised with the statistics of that moment, as PPO's next rollout
    sees its own. The minibatch order comes from ``seed``, so a run stays reproducible. The
    last pass's loss goes to the logger as ``train/anchor_loss``.
    """

    def __init__(self, demos: Demos, recipe: WarmStart, seed: int) -> None:
        import torch

        super().__init__()
        self.demos, self.recipe = demos, recipe
        self.generator = torch.Generator().manual_seed(seed)
        self.updates = 0
        self.losses: list[float] = []

    def _init_callback(self) -> None:
        import torch

        self.actions = torch.as_tensor(self.demos.acts, device=self.model.policy.device)

    def _on_rollout_start(self) -> None:
        updates = self.model._n_updates
        if updates == self.updates:  # no update since the last pass (or none yet)
            return
        self.updates = updates
        policy = self.model.policy
        vec_normalize = self.model.get_vec_normalize_env()
        obs = self.demos.obs
        if vec_normalize is not None:
            obs = vec_normalize.normalize_obs(obs)
        tensors, _ = policy.obs_to_tensor(obs)
        learning_rate = policy.optimizer.param_groups[0]["lr"]
        recipe = self.recipe
        losses = clone_actions(
            policy, tensors, self.actions, recipe.anchor_epochs, recipe.batch_size, learning_rate,
            recipe.action_std, self.generator,
        )  # fmt: skip
        self.losses += losses
        self.logger.record("train/anchor_loss", losses[-1])

    def _on_step(self) -> bool:
        return True


def fixed_seed_evaluation(
    eval_env, episodes: int, eval_freq: int, run_dir: Path, statistics_file: Path | None
) -> EvalCallback:
    """SB3's ``EvalCallback`` on an env wrapped in :class:`FixedSeedVecEnv`: ``episodes``
    episodes every ``eval_freq`` calls, the best model saved in ``run_dir`` with, where given,
    its ``VecNormalize`` statistics in ``statistics_file`` (JSON, ``agents.runs``)."""
    return EvalCallback(
        eval_env,
        n_eval_episodes=episodes,
        eval_freq=eval_freq,
        best_model_save_path=str(run_dir),
        log_path=str(run_dir / "eval"),
        deterministic=True,
        callback_on_new_best=_SaveStatistics(statistics_file) if statistics_file else None,
    )


class _SaveStatistics(BaseCallback):
    """Saves the training statistics with a new best model (the ones its evaluation used)."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path

    def _on_step(self) -> bool:
        vec_normalize = self.model.get_vec_normalize_env()
        if vec_normalize is not None:
            save_statistics(vec_normalize, self.path)
        return True


class Checkpoints(CheckpointCallback):
    """SB3's ``CheckpointCallback`` with each checkpoint's ``VecNormalize`` statistics saved
    beside it as JSON (``agents.runs.statistics_path``), not pickled.

    Args:
        save_freq: calls (env steps / envs) between checkpoints.
        save_path: the folder of ``rl_model_<n>_steps.zip``.
    """

    def __init__(self, save_freq: int, save_path: str | Path) -> None:
        super().__init__(save_freq=save_freq, save_path=str(save_path))

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            vec_normalize = self.model.get_vec_normalize_env()
            if vec_normalize is not None:
                model_path = self._checkpoint_path(extension="zip")
                save_statistics(vec_normalize, statistics_path(model_path))
        return super()._on_step()


def continue_evaluations(callback: EvalCallback, log: Path) -> None:
    """Give a resumed run's ``EvalCallback`` the evaluations made before the interruption,
    so that its log and its best model carry on rather than start again."""
    if not log.exists():
        return
    with np.load(log) as data:
        callback.evaluations_timesteps = data["timesteps"].tolist()
        callback.evaluations_results = data["results"].tolist()
        callback.evaluations_length = data["ep_lengths"].tolist()
    if callback.evaluations_results:
        callback.best_mean_reward = float(np.max(np.mean(callback.evaluations_results, axis=1)))
