"""Scripted baselines for every v1 id: the paper's probing protocol, with the fingertip turning
the link itself.

The paper presses the edge at 5 N, reads, lifts, has the grip turned 30 deg by hand, and
repeats. Here the fingertip turns the link: pressing on the face near the edge and dragging
across it toward the face's interior, the sticking skin carries the link round its hinge
(``tactile_gym.envs.skills.Drag``). One cycle is:

1. ``probe``: a pure press along the face normal to 5 N, held still so the gate averages the
   readings into one measurement. If the gate refuses it because the edge barely truncates
   the contact patch (a small tilt: the fingertip is over the face) the next probe moves
   outward, toward the edge, by what the tilt says is missing (about 4 deg per mm near the
   edge, aiming at 10 deg); if the press found nothing, it searches around.
2. ``turn``: drag across the edge by a distance that should turn the link by ``step_angle``,
   from the lever estimated from the turns measured so far.

Once the link stops following (two drags in a row that turn it less than ``stalled_angle``: a
joint limit), the policy keeps probing at the last angle.
The policy reads only observations; it never reads the simulator.

``PrimitiveProber`` chooses primitives (the action of the ``...Primitive-v2`` ids);
``SkillProber`` runs the same choices through the same skills step by step for the 6-D ids.
``scripted_policy(env)`` returns the right one for any id. It notices a new episode from the
observation (:func:`episode_started`), so one policy plays any number of episodes, with or
without ``reset()``; ``python -m agents.evaluate --policies scripted`` plays it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.envs.observation import (
    ContactObs,
    JointTypeObs,
    LastMeasurementObs,
    ObservationCodec,
    PrimitiveObs,
    ProgressObs,
)
from tactile_gym.envs.skills import PrimitiveExecutor, PrimitiveScales, TouchReading

__all__ = [
    "PrimitiveProber",
    "ProberConfig",
    "Policy",
    "SkillProber",
    "episode_started",
    "scripted_policy",
]


@dataclass(frozen=True)
class ProberConfig:
    """Parameters of the scripted protocol (SI units).

    Attributes:
        target_tilt: force tilt aimed at by moving across the edge, rad (the patch is then
            cut well by the edge: the centre is about 0.5 mm beyond it).
        tilt_per_metre: how the tilt grows as the centre moves across the edge, rad/m.
        min_tilt: tilt below which the next probe moves outward, rad.
        step_angle: link turn aimed at between measurements, rad.
        nominal_lever: assumed distance from the hinge to the fingertip before a turn has
            been measured, m.
        retries: failed probes in a row after which the policy turns anyway.
        stalled_angle: a turn smaller than this counts as the link not following, rad.
    """

    target_tilt: float = float(np.deg2rad(10.0))
    tilt_per_metre: float = float(np.deg2rad(4.0)) / 0.001
    min_tilt: float = float(np.deg2rad(7.0))
    step_angle: float = float(np.deg2rad(16.0))
    nominal_lever: float = 0.055
    retries: int = 3
    stalled_angle: float = float(np.deg2rad(2.0))


class PrimitiveProber:
    """Chooses probing primitives from observations (module docstring).

    Args:
        scales: what an action of 1 means for the primitives (the env's).
        config: protocol parameters.
    """

    def __init__(self, scales: PrimitiveScales, config: ProberConfig = ProberConfig()) -> None:  # noqa: B008
        self.scales = scales
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Start a new episode."""
        self._last = "turn"
        self._count = 0
        self._failures = 0
        self._edges: list[np.ndarray] = []  # edge of each accepted probe
        self._drags: list[float] = []  # drag before each later probe, m
        self._drag = 0.0
        self._stalls = 0

    def resume(self, edges: list[np.ndarray], levers: list[float], count: int, drag: float):
        """Carry on an episode begun by another protocol as if this one had turned the link
        by a drag of ``drag`` (m) after measuring the edge at ``edges`` (one per link angle,
        with the levers of the turns between them, drag over turn, m/rad), and had counted
        ``count`` measurements: its next ``act`` takes a new measurement as its probe's
        after that turn."""
        self.reset()
        self._edges = [np.asarray(e, dtype=float) for e in edges]
        self._drags = list(levers)
        self._count = int(count)
        self._drag = float(drag)
        self._last = "probe"

    def act(self, obs: dict) -> np.ndarray:
        """The next primitive action (3,) for a dict observation of a v1 env."""
        reading = TouchReading.from_obs(obs)
        measured = reading.measurements > self._count
        self._count = reading.measurements
        if self._last == "probe":
            if measured:
                self._learn_turn(LastMeasurementObs.read(obs).edge)
                self._failures = 0
                return self._turn()
            self._failures += 1
            if self._failures > self.config.retries:
                self._failures = 0
                return self._turn()
            return self._probe(self._correction(obs, reading))
        return self._probe(0.0)

    # ------------------------------------------------------------------ decisions
    def _correction(self, obs: dict, reading: TouchReading) -> float:
        """Across offset (m, positive beyond the edge) for the next probe after a refusal."""
        cfg = self.config
        if not reading.touching:
            # Pressed into nothing (beyond the edge, or beside the link): come back inward.
            return -0.002
        tilt = ContactObs.read(obs).tilt
        if tilt < cfg.min_tilt:
            return float(np.clip((cfg.target_tilt - tilt) / cfg.tilt_per_metre, 0.0, 0.003))
        return 0.0

    def _learn_turn(self, edge: np.ndarray) -> None:
        """Measure the turn the last drag made; two stalls in a row mean a joint limit."""
        if self._edges and self._drag:
            turn = float(np.arccos(np.clip(edge @ self._edges[-1], -1.0, 1.0)))
            if turn < self.config.stalled_angle:
                self._stalls += 1
            else:
                self._stalls = 0
                self._drags.append(self._drag / turn)
        self._edges.append(edge)

    def _lever(self) -> float:
        if not self._drags:
            return self.config.nominal_lever
        return float(np.clip(np.median(self._drags), 0.02, 0.15))

    def _probe(self, across: float) -> np.ndarray:
        self._last = "probe"
        return np.array([-1.0, across / self.scales.probe_across, 0.0])

    def _turn(self) -> np.ndarray:
        self._last = "turn"
        if self._stalls >= 2 or not self._edges:
            self._drag = 0.0
            return self._probe(0.0)
        self._drag = min(self._lever() * self.config.step_angle, self.scales.turn_distance)
        return np.array([1.0, self._drag / self.scales.turn_distance, 0.0])


class SkillProber:
    """``PrimitiveProber``'s choices carried out step by step through the skills (6-D ids).

    Args:
        executor: runs the primitives (the 6-D env's scales, dwell and budget).
        config: protocol parameters.
        chooser: what chooses the primitives (``act(obs)`` and ``reset()``) in place of a
            ``PrimitiveProber`` (the joint ids': ``agents.joint_scripted.JointProber``).
    """

    def __init__(
        self,
        executor: PrimitiveExecutor,
        config: ProberConfig = ProberConfig(),  # noqa: B008 - frozen dataclass
        chooser=None,
    ) -> None:
        self.executor = executor
        self.chooser = PrimitiveProber(executor.scales, config) if chooser is None else chooser
        self.reset()

    def reset(self) -> None:
        """Start a new episode."""
        self.chooser.reset()
        self.executor.reset()

    def get_action(self, obs: dict) -> np.ndarray:
        """The next 6-D action (7-D with the tare on v2 ids) for a dict observation."""
        action = self.executor.act(obs)
        while action is None:
            self.executor.start(self.chooser.act(obs), obs)
            action = self.executor.act(obs)
        return action.astype(np.float32)


def episode_started(obs: dict) -> bool:
    """Whether a dict observation is an episode's first: no control step taken yet
    (``progress.time_left`` still 1) and nothing measured, and on the primitive ids no
    primitive yet (``primitive.kind`` 0). Every later observation of an episode has less
    time left, since every action takes at least one control step."""
    progress = ProgressObs.read(obs)
    if progress.time_left < 1.0 or progress.measurements > 0:
        return False
    return PrimitiveObs.key not in obs or PrimitiveObs.read(obs).kind == 0.0


class Policy:
    """A prober with the ``get_action``/``reset`` interface of the other policies, taking dict
    or flat observations (``observation_mode="flat"`` is read with the env's codec), that
    starts over at each episode's first observation (:func:`episode_started`)."""

    def __init__(self, prober, codec: ObservationCodec, primitive: bool) -> None:
        self.prober = prober
        self.codec = codec
        self.primitive = primitive

    def reset(self) -> None:
        self.prober.reset()

    def get_action(self, obs) -> np.ndarray:
        obs = self.codec.as_dict(obs)
        if episode_started(obs):
            self.prober.reset()
        action = self.prober.act(obs) if self.primitive else self.prober.get_action(obs)
        return action.astype(np.float32)


def scripted_policy(env, config: ProberConfig = ProberConfig()):  # noqa: B008
    """The scripted baseline of any hinge id (either action mode, v1 or v2); pass
    ``gym.make(...)`` (and, to vary the protocol, its ``config``). The joint ids' is
    ``agents.joint_scripted.joint_policy`` (``agents.policies.make_policy`` picks either).

    Raises:
        ValueError: a joint id's env.
    """
    codec = env.get_wrapper_attr("codec")
    if JointTypeObs.key in codec.groups:
        raise ValueError(
            "the joint ids' scripted baseline is agents.joint_scripted.joint_policy(env)"
        )
    if env.action_space.shape == (3,):
        return Policy(PrimitiveProber(env.get_wrapper_attr("scales"), config), codec, True)
    return Policy(SkillProber(PrimitiveExecutor.for_env(env.unwrapped), config), codec, False)
