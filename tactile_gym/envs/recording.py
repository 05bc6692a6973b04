"""Record simulated episodes as robot logs (``tactile_gym.perception.log``), so that the
replay (``python -m tactile_gym.replay``) and any robot tool read them as a real robot's.

A log holds only what a robot has: the noisy readings, the fingertip's poses and the tare
events, one row per control step (the reset's reading first). The episode's truth (the axis,
the object) goes into a sidecar, ``<log>.truth.json``, for scoring only.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np

from tactile_gym.perception import Sample
from tactile_gym.perception.log import ProbeLog, truth_path

__all__ = ["RecordProbeLog"]


class RecordProbeLog(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Write each episode of a ``HingeProbe`` env (6-D or primitive) as a log.

    Args:
        env: the env, e.g. ``gym.make("tactile_gym/HingeProbe-v2")``.
        directory: where the logs go: ``<name_prefix>-episode-<k>.npz`` (or ``.csv``) and
            their truth sidecars.
        name_prefix: the logs' name prefix.
        episode_trigger: which episodes (0, 1, ...) to record; default all.
        suffix: ``".npz"`` or ``".csv"``.

    ``paths`` lists the logs written so far. An episode's log is written when it ends (or at
    the next reset or ``close``).
    """

    def __init__(
        self,
        env: gym.Env,
        directory: str | Path,
        name_prefix: str = "probe",
        episode_trigger: Callable[[int], bool] | None = None,
        suffix: str = ".npz",
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self, directory=str(directory), name_prefix=name_prefix, suffix=suffix
        )
        super().__init__(env)
        if suffix not in (".npz", ".csv"):
            raise ValueError(f"suffix must be '.npz' or '.csv', got {suffix!r}")
        base = env.unwrapped
        self._control = getattr(base, "control_env", base)
        self.directory = Path(directory)
        self.name_prefix = name_prefix
        self.episode_trigger = episode_trigger or (lambda episode: True)
        self.suffix = suffix
        self.paths: list[Path] = []
        self._episode = -1
        self._samples: list[Sample] | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._write()
        self._episode += 1
        self._seed = seed
        record = self.episode_trigger(self._episode)
        self._samples = [] if record else None
        self._control.pipeline.recorder = self._samples.append if record else None
        obs, info = self.env.reset(seed=seed, options=options)
        if record:
            self._truth = self._true_sidecar()
        return obs, info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            self._write()
        return obs, reward, terminated, truncated, info

    def close(self):
        self._write()
        super().close()

    def _write(self) -> None:
        """Write the episode recorded so far, if any."""
        samples, self._samples = self._samples, None
        self._control.pipeline.recorder = None
        if not samples:
            return
        control = self._control
        spec = self.env.spec
        source = f"{spec.id if spec else type(control).__name__} seed {self._seed}"
        header = control.config.log_header(control.geometry, source)
        path = self.directory / f"{self.name_prefix}-episode-{self._episode}{self.suffix}"
        path = ProbeLog.from_samples(header, samples).save(path)
        truth_path(path).write_text(json.dumps(self._truth, indent=1))
        self.paths.append(path)

    def _true_sidecar(self) -> dict:
        """The episode's truth, for scoring only: the axis, the joint, the object."""
        scene = self._control.scene
        point, direction = scene.true_axis
        config = scene.object_config
        return {
            "axis_point": point.tolist(),
            "axis_direction": direction.tolist(),
            "joint_type": "revolute",
            "family": config.family,
            "joint_angle": float(scene.joint_angle),
            "object": json.loads(json.dumps(dataclasses.asdict(config), default=_number)),
        }


def _number(value):
    """JSON for the NumPy values of a config."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else str(value)
