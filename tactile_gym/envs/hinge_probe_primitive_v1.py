"""HingeProbePrimitive v1: the same task and physics, acted on with probing primitives."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.hinge_probe_v1 import HingeProbeEnv
from tactile_gym.envs.skills import PRIMITIVES, PrimitiveExecutor, PrimitiveScales
from tactile_gym.validation import check_choice, check_int, check_number

__all__ = ["HingeProbePrimitiveEnv", "PRIMITIVES"]


class HingeProbePrimitiveEnv(gym.Env):
    """``HingeProbe`` with probing primitives as actions; each runs the 6-D env underneath.

    ## Description

    The task, the physics, the measurement gate, the estimator, the observation and the reward
    are those of ``HingeProbeEnv`` (``tactile_gym/envs/hinge_probe_v1.py``), which runs
    underneath: a primitive is a short closed-loop motion (``tactile_gym.envs.skills``) that
    sends 6-D actions to it until done. The primitives read observations only.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``; ``a[0] < 0`` selects ``probe``, ``a[0] >= 0`` ``turn``:

    | primitive | a[1] at 1                              | a[2] at 1                           |
    |-----------|----------------------------------------|-------------------------------------|
    | probe     | across offset ``probe_across`` (3 mm), | along offset ``probe_along`` (10 mm)|
    |           | positive beyond the last edge          | in the edge's direction             |
    | turn      | drag ``turn_distance`` (20 mm),        | along offset before the drag, as    |
    |           | positive toward the face's interior    | for probe                           |

    * ``probe``: lift off, move by the offsets in the plane of the probed face (relative to
      the last contact, along and across the last measured edge), press along the face normal
      to 5 N and hold still for the gate's dwell: a pure press, measured when the edge
      truncates the patch.
    * ``turn``: lift, move by the along offset, press to 5.5 N, and drag across the edge by the
      distance: the sticking skin carries the link round its hinge (toward the interior it
      sticks; outward the skin partly slides). Before the first edge is known, ``turn`` only
      presses.

    ## Observation Space, Rewards

    ``HingeProbeEnv``'s observation after the primitive, plus ``primitive``: the kind of the
    last primitive (-1 probe, +1 turn, 0 none yet), whether it produced a measurement (0 or 1)
    and the fraction of the episode's control steps it took. The reward is the sum of the 6-D
    env's rewards during the primitive (so the return still telescopes to the error removed
    from the prior). ``info`` adds ``primitive`` and ``steps`` (6-D steps the primitive took).

    ## Episode End

    When the 6-D env terminates or runs out of its ``max_steps`` (the budget is in control
    steps, so a primitive's cost is its duration), or after ``max_primitives`` primitives.

    ## Arguments

    ``max_primitives``, ``probe_across``, ``probe_along``, ``turn_distance``, and every keyword
    of ``HingeProbeEnv`` (passed through).

    ## Version History

    * v1: initial release.
    """

    metadata = HingeProbeEnv.metadata

    def __init__(
        self,
        render_mode: str | None = None,
        max_primitives: int = 64,
        probe_across: float = PrimitiveScales.probe_across,
        probe_along: float = PrimitiveScales.probe_along,
        turn_distance: float = PrimitiveScales.turn_distance,
        **kwargs: Any,
    ) -> None:
        self.max_primitives = check_int("max_primitives", max_primitives, 1, 10_000)
        self.scales = PrimitiveScales(
            probe_across=check_number("probe_across", probe_across, 0.0, 0.01, low_open=True),
            probe_along=check_number("probe_along", probe_along, 0.0, 0.05),
            turn_distance=check_number("turn_distance", turn_distance, 0.0, 0.1, low_open=True),
        )
        # The skills read dict observations: the env underneath always makes them, and this
        # env flattens its own when asked to.
        self.observation_mode = check_choice(
            "observation_mode", kwargs.get("observation_mode", "dict"), ("dict", "flat")
        )
        self.env = HingeProbeEnv(render_mode=render_mode, **{**kwargs, "observation_mode": "dict"})
        self.render_mode = render_mode
        self.metadata = self.env.metadata
        self.dict_observation_space = spaces.Dict(
            {
                **self.env.dict_observation_space.spaces,
                "primitive": spaces.Box(
                    np.array([-1.0, 0.0, 0.0], np.float32), np.ones(3, np.float32)
                ),
            }
        )
        if self.observation_mode == "flat":
            self.observation_space = spaces.flatten_space(self.dict_observation_space)
        else:
            self.observation_space = self.dict_observation_space
        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self._executor = PrimitiveExecutor(
            self.env.config.max_translation,
            self.env.gate.config.dwell + 1,
            self.env.config.max_steps,
            self.scales,
        )
        self._obs = None

    @property
    def config(self):
        return self.env.config

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs, info = self.env.reset(seed=seed, options=options)
        self._obs = obs
        self._executor.reset()
        self._primitives = 0
        self._over = False
        return self._observation(self._executor.summary), info

    def step(self, action):
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        if self._over:
            raise RuntimeError(
                "the episode has ended (terminated or truncated); call reset() before step()"
            )
        action = np.asarray(action)
        if action.shape != (3,):
            raise ValueError(f"action must have shape (3,), got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action.tolist()}")
        name = self._executor.start(action, self._obs)
        total, terms, steps = 0.0, {}, 0
        terminated = truncated = False
        info: dict = {}
        while not (terminated or truncated):
            low = self._executor.act(self._obs)
            if low is None:
                break
            self._obs, reward, terminated, truncated, info = self.env.step(low.astype(np.float32))
            steps += 1
            total += reward
            for key in ("reward_error_reduction", "reward_force_penalty", "reward_action_cost"):
                terms[key] = terms.get(key, 0.0) + info[key]
        self._executor.finish(self._obs)  # also when the episode's end cut it short
        self._primitives += 1
        truncated = truncated or (self._primitives >= self.max_primitives and not terminated)
        self._over = terminated or truncated
        info = {**info, **terms, "primitive": name, "steps": steps}
        return self._observation(self._executor.summary), total, terminated, truncated, info

    def _observation(self, primitive: np.ndarray):
        """The 6-D env's observation plus what the last primitive was and did."""
        obs = {**self._obs, "primitive": primitive.astype(np.float32)}
        if self.observation_mode == "flat":
            return spaces.flatten(self.dict_observation_space, obs)
        return obs

    def render(self):
        return self.env.render()

    def close(self):
        self.env.close()

    @property
    def unwrapped_env(self) -> HingeProbeEnv:
        """The 6-D env underneath (measurements, estimate, scene)."""
        return self.env

    @property
    def measurements(self):
        return self.env.measurements

    @property
    def scene(self):
        return self.env.scene

    @property
    def axis_estimate(self):
        return self.env.axis_estimate
