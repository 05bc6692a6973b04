"""HingeProbePrimitive: the same task and physics, acted on with probing primitives.

``HingeProbePrimitiveEnv`` is an env of its own (``env.unwrapped`` is it, so tools that check
or introspect ``unwrapped`` see the interface a user acts on) that drives a ``HingeProbeEnv``,
its ``control_env``: each primitive runs the probing skills (``skills.py``) on it until done
(``docs/design.md`` 7.6). The registered ids are made by ``make_primitive_env``, which splits
the primitive env's keywords from the 6-D env's; each version drives the 6-D env of its own.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.hinge_probe import HingeProbeEnv
from tactile_gym.envs.observation import PrimitiveObs
from tactile_gym.envs.skills import PRIMITIVE_KIND, PrimitiveExecutor, PrimitiveScales
from tactile_gym.envs.step_guard import EnvSpecOwnHorizon, StepGuard, check_render_mode
from tactile_gym.envs.task import REWARD_TERMS
from tactile_gym.validation import check_int, check_number

__all__ = ["PRIMITIVE_KEYWORDS", "HingeProbePrimitiveEnv", "make_primitive_env"]

#: The wrapper's own keywords of ``gym.make``; the others go to ``HingeProbeEnv``.
PRIMITIVE_KEYWORDS = ("max_primitives", "probe_across", "probe_along", "turn_distance")


def make_primitive_env(render_mode: str | None = None, **kwargs: Any) -> HingeProbePrimitiveEnv:
    """The entry point of the primitive ids: the primitive env (its ``PRIMITIVE_KEYWORDS``)
    driving a ``HingeProbeEnv`` of the other keywords. ``render_mode="rgb_array_list"``
    renders every control step of each primitive."""
    own = {key: kwargs.pop(key) for key in PRIMITIVE_KEYWORDS if key in kwargs}
    inner = "rgb_array" if render_mode == "rgb_array_list" else render_mode
    control_env = HingeProbeEnv(render_mode=inner, **kwargs)
    return HingeProbePrimitiveEnv(control_env, render_mode=render_mode, **own)


class HingeProbePrimitiveEnv(EnvSpecOwnHorizon, gym.Env):
    """``HingeProbe`` with probing primitives as actions; each runs the 6-D env underneath.

    ## Description

    The task, the physics, the measurement gate, the estimator, the observation and the reward
    are those of the ``HingeProbeEnv`` it drives, its ``control_env``
    (``tactile_gym/envs/hinge_probe.py``): a primitive is a short closed-loop motion
    (``tactile_gym.envs.skills``) that sends 6-D actions to it until done. The primitives read
    observations only. ``env.unwrapped`` is the primitive env itself; its ``scene``,
    ``pipeline``, ``measurements`` and ``axis_estimate`` are the control env's.

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
    from the prior). ``info`` is the 6-D env's after the primitive's last control step, with
    the reward terms summed over the primitive, plus ``primitive_kind`` (the primitive's code,
    as the observation's: -1 probe, +1 turn, 0 at reset) and ``steps`` (the control steps it
    took).

    ## Episode End

    When the 6-D env terminates or runs out of its ``max_steps`` (the budget is in control
    steps, so a primitive's cost is its duration), or after ``max_primitives`` primitives
    (``env.spec.max_episode_steps``).

    ## Rendering

    ``render_mode="rgb_array"``: the frame after the primitive. ``"rgb_array_list"``: every
    control step's frame since the last ``render()`` (a video of it plays at the control rate,
    ``metadata["render_fps"]``), the key naming the primitive running and its number.

    ## Arguments

    ``control_env``, the ``HingeProbeEnv`` to drive, then ``max_primitives``,
    ``probe_across``, ``probe_along``, ``turn_distance`` and ``render_mode``. Through
    ``gym.make`` every keyword of ``HingeProbeEnv`` is accepted too (``make_primitive_env``).

    ## Version History

    * v3: drives the v3 6-D env (its contact step, calibrated covariance and adaptive press:
      a probe holds on the gate's hold rule and steps by the measured force gradient).
    * 0.4 (no new version: observations, rewards and dynamics are unchanged): an env of its
      own rather than a ``gym.Wrapper`` (``env.unwrapped`` is it; the 6-D env is
      ``control_env``); ``info["primitive"]`` (a string, named like the observation key) is
      ``primitive_kind`` (a code); ``render_mode="rgb_array_list"`` renders every control
      step; ``env.spec.max_episode_steps`` is ``max_primitives``.
    * v2: wraps the v2 6-D env (the realistic F/T sensor); both primitives tare before their
      press.
    * v1: initial release.
    """

    #: The executor of the primitives (an env of other ids sets its own).
    executor_class: ClassVar[type[PrimitiveExecutor]] = PrimitiveExecutor

    def __init__(
        self,
        control_env: HingeProbeEnv,
        max_primitives: int = 64,
        probe_across: float = PrimitiveScales.probe_across,
        probe_along: float = PrimitiveScales.probe_along,
        turn_distance: float = PrimitiveScales.turn_distance,
        render_mode: str | None = None,
    ) -> None:
        if not isinstance(control_env, HingeProbeEnv):
            raise TypeError(f"control_env must be a HingeProbeEnv, got {type(control_env)}")
        modes = ["rgb_array", "rgb_array_list"]
        if control_env.render_mode == "human":
            modes.append("human")
        check_render_mode(render_mode, modes)
        self.control_env = control_env
        self.render_mode = render_mode
        self.metadata = {"render_modes": modes, "render_fps": control_env.metadata["render_fps"]}
        self.max_primitives = check_int("max_primitives", max_primitives, 1, 10_000)
        self._horizon = self.max_primitives
        self.scales = PrimitiveScales(
            probe_across=check_number("probe_across", probe_across, 0.0, 0.05, low_open=True),
            probe_along=check_number("probe_along", probe_along, 0.0, 0.1),
            turn_distance=check_number("turn_distance", turn_distance, 0.0, 0.1, low_open=True),
        )
        self._mode = control_env.config.observation_mode
        self._inner_codec = control_env.codec
        self.codec = control_env.codec.with_group(PrimitiveObs)
        self.dict_observation_space = self.codec.dict_space
        self.observation_space = self.codec.space(self._mode)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self._guard = StepGuard(self.action_space)
        self._executor = self.executor_class.for_env(control_env, self.scales)
        self._frames: list[np.ndarray] = []

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs, info = self.control_env.reset(seed=seed, options=options)
        self._obs = self._inner_codec.as_dict(obs)
        self._executor.reset()
        self._primitives = 0
        self._guard.begin()
        self._frames = []
        self._capture("")
        return self._observation(), {**info, "primitive_kind": np.int64(0), "steps": np.int64(0)}

    def step(self, action):
        action = self._guard.check(action)
        name = self._executor.start(action, self._obs)
        caption = f"{name} {self._primitives + 1}"
        total, terms, steps = 0.0, dict.fromkeys(REWARD_TERMS, 0.0), 0
        terminated = truncated = False
        info: dict = {}
        while not (terminated or truncated):
            low = self._executor.act(self._obs)
            if low is None:
                break
            obs, reward, terminated, truncated, info = self.control_env.step(low.astype(np.float32))
            self._obs = self._inner_codec.as_dict(obs)
            self._capture(caption)
            steps += 1
            total += reward
            for key in REWARD_TERMS:
                terms[key] += info[key]
        self._executor.finish(self._obs)  # also when the episode's end cut it short
        self._primitives += 1
        truncated = truncated or (self._primitives >= self.max_primitives and not terminated)
        self._guard.end(terminated or truncated)
        info = {
            **info,
            **{key: np.float64(value) for key, value in terms.items()},
            "primitive_kind": np.int64(PRIMITIVE_KIND[name]),
            "steps": np.int64(steps),
        }
        return self._observation(), total, terminated, truncated, info

    def render(self):
        """``"rgb_array"``: the frame now; ``"rgb_array_list"``: the frames of every control
        step since the last call (or the reset), the key naming the primitive and its number;
        ``"human"``: the control env's GUI shows each step."""
        if self.render_mode == "rgb_array":
            return self.control_env.render()
        if self.render_mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        return None

    def close(self):
        self._guard.stop()
        self.control_env.close()

    # ------------------------------------------------------------------ the episode
    @property
    def scene(self):
        """The control env's simulation (``HingeProbeEnv.scene``)."""
        return self.control_env.scene

    @property
    def pipeline(self):
        """The control env's measurement pipeline."""
        return self.control_env.pipeline

    @property
    def measurements(self):
        """The measurements accepted this episode (``HingeProbeEnv.measurements``)."""
        return self.control_env.measurements

    @property
    def axis_estimate(self):
        """The current estimate (``HingeProbeEnv.axis_estimate``)."""
        return self.control_env.axis_estimate

    def _capture(self, caption: str) -> None:
        if self.render_mode == "rgb_array_list":
            self._frames.append(self.control_env.frame(caption))

    def _observation(self):
        """The 6-D env's observation plus what the last primitive was and did."""
        parts = {**self._obs, PrimitiveObs.key: self._executor.summary}
        return self.codec.encode(parts, self._mode)
