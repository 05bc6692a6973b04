"""Seeded episodes of a policy: their records, their summary, and their video.

Episode k of an evaluation uses seed ``seed + k`` for the env and the action space, so every
policy meets the same objects and every episode depends on its seed alone: the episodes of
any chunk of seeds, in any process, are those of a serial run (:func:`run_episodes`).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from tactile_gym.estimation import JOINT_TYPES

from .cli import make_env
from .policies import BUILTIN_POLICIES, PolicySpec, make_policy
from .resources import torch_threads

__all__ = [
    "NO_ESTIMATE_ERROR",
    "REACH_THRESHOLD",
    "EpisodeRecord",
    "joint_figures",
    "record_video",
    "run_episode",
    "run_episodes",
    "summarize",
]

#: Position error reported while there is no estimate, m (the task's E_max).
NO_ESTIMATE_ERROR = 0.1
#: The "steps to reach" threshold of the table, m.
REACH_THRESHOLD = 0.005


@dataclass
class EpisodeRecord:
    seed: int
    position_error: list[float]
    angle_error: list[float]
    success: bool
    n_measurements: int
    terminated: bool
    episode_return: float = 0.0
    #: The joint ids' true type (its index in ``tactile_gym.estimation.JOINT_TYPES``) and
    #: whether the final estimate has it strictly most probable; ``None`` on the hinge ids.
    joint_type: int | None = None
    type_correct: bool | None = None


def run_episode(env: gym.Env, policy, seed: int) -> EpisodeRecord:
    """One episode from ``seed`` alone (env and action space); errors are recorded after
    reset and after every step, and the return (the env's rewards summed: truth-free where
    the env's reward is) at the end."""
    obs, info = env.reset(seed=seed)
    env.action_space.seed(seed)
    policy.reset()
    position, angle = [_finite(info["position_error"])], [float(info["angle_error"])]
    terminated = truncated = False
    episode_return = 0.0
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(policy.get_action(obs))
        episode_return += float(reward)
        position.append(_finite(info["position_error"]))
        angle.append(float(info["angle_error"]))
    return EpisodeRecord(
        seed=seed,
        position_error=position,
        angle_error=angle,
        success=bool(info["is_success"]),
        n_measurements=int(info["n_measurements"]),
        terminated=bool(terminated),
        episode_return=episode_return,
        joint_type=int(info["joint_type"]) if "joint_type" in info else None,
        type_correct=bool(info["type_correct"]) if "type_correct" in info else None,
    )


def run_episodes(spec: PolicySpec, seeds: list[int], progress=None) -> list[EpisodeRecord]:
    """Episodes of one policy on a fresh env (what a Ray worker runs for a chunk of seeds).

    Torch runs on one thread, so a model acts the same here and in any worker.

    Args:
        spec: the policy and its env.
        seeds: one episode per seed.
        progress: a progress bar whose ``update()`` is called after each episode.
    """
    env = make_env(spec.env_id, **spec.env_kwargs)
    try:
        policy = make_policy(spec.name, env, spec.trust_pickle)
        records = []
        with _model_threads(spec):
            for seed in seeds:
                records.append(run_episode(env, policy, seed))
                if progress is not None:
                    progress.update()
        return records
    finally:
        env.close()


def _model_threads(spec: PolicySpec):
    return contextlib.nullcontext() if spec.name in BUILTIN_POLICIES else torch_threads(1)


def _finite(error: float) -> float:
    return float(min(error, NO_ESTIMATE_ERROR))


def summarize(records: list[EpisodeRecord]) -> dict[str, float]:
    """Table figures over episodes: errors in mm and degrees (NaN where undefined); on the
    joint ids also the type accuracy and each type's parameter error (:func:`joint_figures`)."""
    final_pos = np.array([r.position_error[-1] for r in records]) * 1e3
    final_ang = np.degrees([r.angle_error[-1] for r in records])
    reach = [
        next((i for i, e in enumerate(r.position_error) if e < REACH_THRESHOLD), None)
        for r in records
    ]
    reached = [i for i in reach if i is not None]
    return {
        "episodes": len(records),
        "position_mean_mm": float(final_pos.mean()),
        "position_median_mm": float(np.median(final_pos)),
        "position_p90_mm": float(np.percentile(final_pos, 90)),
        "angle_mean_deg": float(final_ang.mean()),
        "angle_median_deg": float(np.median(final_ang)),
        "success_rate": float(np.mean([r.success for r in records])),
        "reached_5mm_rate": len(reached) / len(records),
        "steps_to_5mm_mean": float(np.mean(reached)) if reached else float("nan"),
        "measurements_mean": float(np.mean([r.n_measurements for r in records])),
        "failure_rate": float(np.mean([r.terminated for r in records])),
        "return_mean": float(np.mean([r.episode_return for r in records])),
        **joint_figures(records),
    }


def joint_figures(records: list[EpisodeRecord]) -> dict[str, float]:
    """The joint ids' figures (none on the hinge ids): the share of episodes ending with the
    true type most probable, and the mean final parameter error of each type's episodes, the
    axis position (mm) of the revolute ones and the direction (deg) of the prismatic ones
    (NaN without such episodes). A rigid object has no parameter."""
    if any(r.type_correct is None for r in records):
        return {}
    revolute, prismatic = (JOINT_TYPES.index(t) for t in ("revolute", "prismatic"))

    def mean_final(errors: list[float]) -> float:
        return float(np.mean(errors)) if errors else float("nan")

    return {
        "type_accuracy": float(np.mean([r.type_correct for r in records])),
        "revolute_position_mean_mm": mean_final(
            [r.position_error[-1] * 1e3 for r in records if r.joint_type == revolute]
        ),
        "prismatic_angle_mean_deg": mean_final(
            [np.degrees(r.angle_error[-1]) for r in records if r.joint_type == prismatic]
        ),
    }


def record_video(spec: PolicySpec, seeds: list[int], path: str | Path) -> int:
    """An MP4 of the policy's episodes on ``seeds``, one after the other, at the env's
    ``metadata["render_fps"]`` (real time), written with moviepy as Gymnasium's
    ``RecordVideo`` writes it; returns the number of frames.

    The env renders into a list (``render_mode="rgb_array_list"``): every frame since the
    last ``render()``, from the reset on. The episodes are the evaluation's own (each depends
    on its seed alone, and rendering changes nothing in a rollout).
    """
    from moviepy.video.io.ImageSequenceClip import ImageSequenceClip

    env = _rendering_env(spec)
    try:
        policy = make_policy(spec.name, env, spec.trust_pickle)
        frames: list[np.ndarray] = []
        with _model_threads(spec):
            for seed in seeds:
                run_episode(env, policy, seed)
                frames.extend(env.render())
        fps = env.metadata["render_fps"]
    finally:
        env.close()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    clip = ImageSequenceClip(frames, fps=fps)
    clip.write_videofile(str(path), logger=None)
    clip.close()
    return len(frames)


def _rendering_env(spec: PolicySpec) -> gym.Env:
    """``spec``'s env with ``render_mode="rgb_array_list"``: every control step's frame (the
    primitive env renders those of each primitive; for a 6-D id ``gym.make`` wraps the env in
    Gymnasium's ``RenderCollection``)."""
    return make_env(spec.env_id, render_mode="rgb_array_list", **spec.env_kwargs)
