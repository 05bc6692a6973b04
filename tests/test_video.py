"""``agents.evaluate --video``: an MP4 per policy of its first episodes, one frame per control
step, played at the env's own rate (real time)."""

from __future__ import annotations

import gymnasium as gym
import pytest

from agents import evaluate
from agents.episodes import record_video
from agents.policies import PolicySpec
from agents.scripted import scripted_policy
from tactile_gym.envs.observation import ProgressObs

pytest.importorskip("moviepy")


def control_steps(env_id: str, kwargs: dict, seed: int) -> int:
    """Control steps of the scripted policy's episode on ``seed``, from the time its last
    observation says is left (``max_steps`` given in ``kwargs``)."""
    env = gym.make(env_id, **kwargs)
    policy = scripted_policy(env)
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy.get_action(obs))
        done = terminated or truncated
    env.close()
    time_left = ProgressObs.read(env.get_wrapper_attr("codec").as_dict(obs)).time_left
    return round((1.0 - time_left) * kwargs["max_steps"])


def frames_and_clip(env_id: str, kwargs: dict, path) -> tuple[int, float, float]:
    """Frames written for the scripted policy's episode on seed 1000, and the clip's rate
    and duration as moviepy reads the file back."""
    from moviepy import VideoFileClip

    frames = record_video(PolicySpec("scripted", "scripted", env_id, kwargs), [1000], path)
    with VideoFileClip(str(path)) as clip:
        return frames, clip.fps, clip.duration


def test_a_video_has_a_frame_per_control_step_at_real_time(tmp_path):
    kwargs = {"max_steps": 12}
    frames, fps, duration = frames_and_clip("tactile_gym/HingeProbe-v2", kwargs, tmp_path / "a.mp4")
    assert frames == control_steps("tactile_gym/HingeProbe-v2", kwargs, 1000) + 1  # and the reset
    env = gym.make("tactile_gym/HingeProbe-v2")
    assert fps == env.metadata["render_fps"] == 20  # one frame per 0.05 s control step
    env.close()
    assert duration == pytest.approx(frames / fps, abs=1.5 / fps)


def test_a_primitive_ids_video_has_every_control_step(tmp_path):
    kwargs = {"max_steps": 40}
    env_id = "tactile_gym/HingeProbePrimitive-v2"
    frames, _, _ = frames_and_clip(env_id, kwargs, tmp_path / "p.mp4")
    assert frames == control_steps(env_id, kwargs, 1000) + 1


def test_evaluate_writes_one_video_per_policy(tmp_path, capsys):
    out, videos = tmp_path / "eval", tmp_path / "videos"
    evaluate.main(
        ["--policies", "random", "scripted", "--episodes", "2", "--env-kwargs", "max_steps:6",
         "--out", str(out), "--no-plot", "--video", str(videos), "--video-episodes", "2"]
    )  # fmt: skip
    assert sorted(p.name for p in videos.iterdir()) == ["random.mp4", "scripted.mp4"]
    assert f"wrote {videos / 'random.mp4'}, {videos / 'scripted.mp4'}" in capsys.readouterr().out
    with pytest.raises(ValueError, match="video_episodes"):
        evaluate.evaluate(["random"], episodes=1, out=out, video=videos, video_episodes=2)
