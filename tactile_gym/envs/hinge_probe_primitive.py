"""HingeProbePrimitive v2 and v1: the same task and physics, acted on with probing primitives.

``HingeProbePrimitiveEnv`` is a ``gym.Wrapper`` over ``HingeProbeEnv``: each primitive runs
the probing skills (``skills.py``) on the 6-D env until done (``docs/design.md`` 7.6). The
registered ids are made by ``make_primitive_env``, which splits the wrapper's keywords from
the 6-D env's; v2 and v1 wrap the 6-D env of their version.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.hinge_probe import HingeProbeEnv
from tactile_gym.envs.observation import PrimitiveObs
from tactile_gym.envs.skills import PrimitiveExecutor, PrimitiveScales
from tactile_gym.envs.step_guard import StepGuard
from tactile_gym.envs.task import REWARD_TERMS
from tactile_gym.validation import check_int, check_number

__all__ = ["PRIMITIVE_KEYWORDS", "HingeProbePrimitiveEnv", "make_primitive_env"]

#: The wrapper's own keywords of ``gym.make``; the others go to ``HingeProbeEnv``.
PRIMITIVE_KEYWORDS = ("max_primitives", "probe_across", "probe_along", "turn_distance")


def make_primitive_env(render_mode: str | None = None, **kwargs: Any) -> HingeProbePrimitiveEnv:
    """The entry point of the primitive ids: ``HingeProbeEnv`` of the 6-D keywords, wrapped
    with the primitive keywords (``PRIMITIVE_KEYWORDS``)."""
    own = {key: kwargs.pop(key) for key in PRIMITIVE_KEYWORDS if key in kwargs}
    return HingeProbePrimitiveEnv(HingeProbeEnv(render_mode=render_mode, **kwargs), **own)


class HingeProbePrimitiveEnv(gym.Wrapper):
    """``HingeProbe`` with probing primitives as actions; each runs the 6-D env underneath.

    ## Description

    The task, the physics, the measurement gate, the estimator, the observation and the reward
    are those of the wrapped ``HingeProbeEnv`` (``tactile_gym/envs/hinge_probe.py``;
    ``env.unwrapped`` is it, with its ``measurements``): a primitive is a short closed-loop
    motion (``tactile_gym.envs.skills``) that sends 6-D actions to it until done. The
    primitives read observations only.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``; ``a[0] < 0`` selects ``probe``, ``a[0] >= 0`` ``turn``:

    | primitive | a[1] at 1                              | a[2] at 1                           |
    |-----------|----------------------------------------|-------------------------------------|
    | probe     | across offset ``probe_across`` (3 mm), | along offset ``probe_along`` (10 mm)|
    |           | positive beyond the last edge          | in the edge's direction             |
    | turn      | drag ``turn_distance`` (20 mm),        | along offset before the drag, as    |
    |           | positive toward the face's interior    | for probe                           |

    On v2 both primitives tare the F/T sensor right after the lift, once the finger is 1 mm
    clear of where the reading let go, and before moving on (``skills.TareSensor``,
    ``docs/design.md`` 5.1); the action space stays ``(3,)``.

    * ``probe``: lift off, move by the offsets in the plane of the probed face (relative to
      the last contact, along and across the last measured edge), press along the face normal
      to 5 N and hold still for the gate's dwell: a pure press, measured when the edge
      truncates the patch.
    * ``turn``: lift, move by the along offset, press to 5.5 N, and drag across the edge by the
      distance: the sticking skin carries the link round its hinge (toward the interior it
      sticks; outward the skin partly slides). Before the first edge is known, ``turn`` only
      presses.

    ## Observation Space, Rewards

    ``HingeProbeEnv``'s observation after the primitive, plus ``primitive``
    (``tactile_gym.envs.observation.PrimitiveObs``): the kind of the last primitive (-1 probe,
    +1 turn, 0 none yet), whether it produced a measurement (0 or 1) and the fraction of the
    episode's control steps it took. ``observation_mode="flat"`` flattens it like the 6-D
    env's (the keys in sorted order). The reward is the sum of the 6-D
    env's rewards during the primitive (so the return still telescopes to the error removed
    from the prior). ``info`` adds ``primitive`` and ``steps`` (6-D steps the primitive took).

    ## Episode End

    When the 6-D env terminates or runs out of its ``max_steps`` (the budget is in control
    steps, so a primitive's cost is its duration), or after ``max_primitives`` primitives.

    ## Arguments

    ``env``, the ``HingeProbeEnv`` to wrap, then ``max_primitives``, ``probe_across``,
    ``probe_along`` and ``turn_distance``. Through ``gym.make`` every keyword of
    ``HingeProbeEnv`` is accepted too (``make_primitive_env``).

    ## Version History

    * v2: wraps the v2 6-D env (the realistic F/T sensor); both primitives tare before their
      press.
    * v1: initial release.
    """

    def __init__(
        self,
        env: gym.Env,
        max_primitives: int = 64,
        probe_across: float = PrimitiveScales.probe_across,
        probe_along: float = PrimitiveScales.probe_along,
        turn_distance: float = PrimitiveScales.turn_distance,
    ) -> None:
        super().__init__(env)
        self.max_primitives = check_int("max_primitives", max_primitives, 1, 10_000)
        self.scales = PrimitiveScales(
            probe_across=check_number("probe_across", probe_across, 0.0, 0.01, low_open=True),
            probe_along=check_number("probe_along", probe_along, 0.0, 0.05),
            turn_distance=check_number("turn_distance", turn_distance, 0.0, 0.1, low_open=True),
        )
        base = env.unwrapped
        self._mode = base.config.observation_mode
        self._inner_codec = base.codec
        self.codec = base.codec.with_group(PrimitiveObs)
        self.dict_observation_space = self.codec.dict_space
        self.observation_space = self.codec.space(self._mode)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self._guard = StepGuard(self.action_space)
        self._executor = PrimitiveExecutor.for_env(base, self.scales)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._obs = self._inner_codec.as_dict(obs)
        self._executor.reset()
        self._primitives = 0
        self._guard.begin()
        return self._observation(), info

    def step(self, action):
        action = self._guard.check(action)
        name = self._executor.start(action, self._obs)
        total, terms, steps = 0.0, dict.fromkeys(REWARD_TERMS, 0.0), 0
        terminated = truncated = False
        info: dict = {}
        while not (terminated or truncated):
            low = self._executor.act(self._obs)
            if low is None:
                break
            obs, reward, terminated, truncated, info = self.env.step(low.astype(np.float32))
            self._obs = self._inner_codec.as_dict(obs)
            steps += 1
            total += reward
            for key in REWARD_TERMS:
                terms[key] += info[key]
        self._executor.finish(self._obs)  # also when the episode's end cut it short
        self._primitives += 1
        truncated = truncated or (self._primitives >= self.max_primitives and not terminated)
        self._guard.end(terminated or truncated)
        info = {**info, **terms, "primitive": name, "steps": steps}
        return self._observation(), total, terminated, truncated, info

    def close(self):
        self._guard.stop()
        super().close()

    def _observation(self):
        """The 6-D env's observation plus what the last primitive was and did."""
        parts = {**self._obs, PrimitiveObs.key: self._executor.summary}
        return self.codec.encode(parts, self._mode)
