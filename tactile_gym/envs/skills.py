"""Probing skills: short closed-loop fingertip motions over ``HingeProbe``'s 6-D actions.

Each skill turns observations into normalised actions until it is done. They read only the
observation (the F/T reading, the fingertip pose, the contact estimate), never the simulator,
and they serve both the probing-primitive envs (one primitive runs one or a few skills) and
the scripted baselines of every id. They read observations by name
(``tactile_gym.envs.observation``). World frame, metres, newtons, radians.

A :class:`ProbeFrame` carries what probing has revealed so far: where the last contact was,
the normal of the face being probed (the line of the force of a pure press, which pushes
along the face normal), and the edge (oriented physically, ``docs/design.md`` 7.3), from
which the face's interior side follows. Until the first press the face normal is taken as
world +z: the fingertip starts above the face that looks up.

The physics each skill relies on (``docs/design.md`` 4.1, 4.2, 7.6):

* :class:`Press` moves only along the face normal once touching, so the skin is not dragged and
  the press is *pure*; it holds still until the gate's hold rule is met (its dwell, or the
  predicted edge error of the mean reaching the gate's target: ``HoldRule``), and one step
  more, so the readings are averaged into one measurement.
* :class:`Drag` turns the link: pressing on the face near the edge and moving across the edge
  toward the face's interior, the sticking skin carries the link along.
* :class:`Lift` ends a touch, so that the next press starts with an unloaded skin.
* :class:`TareSensor` zeroes the F/T sensor in free air before each press, on the ids with a
  tare action (v2): only right after a :class:`Lift` that moved the finger a clearance away
  from the last touch, never while the reading says touching (``docs/design.md`` 5.1).

Skills return 7-D actions (the 6-D motion and the tare request, ``ACTION_SIZE``); the
executor hands the env as many components as its action space has.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from tactile_gym.envs.observation import (
    ContactObs,
    FingertipPoseObs,
    PrimitiveObs,
    ProgressObs,
    WrenchObs,
)
from tactile_gym.sensing import (
    RELEASE_FORCE,
    HoldRule,
    PressConfig,
    PressController,
    TouchSensor,
)
from tactile_gym.spatial import quaternion_to_matrix
from tactile_gym.vec3 import cross, norm

__all__ = [
    "ACTION_SIZE",
    "HOLD_MARGIN",
    "PRIMITIVES",
    "PRIMITIVE_KIND",
    "Drag",
    "Lift",
    "Move",
    "PrimitiveExecutor",
    "PrimitiveScales",
    "Press",
    "PressSettings",
    "TareSensor",
    "ProbeFrame",
    "Skill",
    "TouchReading",
    "primitive_skills",
]

#: The probing primitives, chosen by the sign of action[0] (``primitive_skills``).
PRIMITIVES = ("probe", "turn")
#: Each primitive's code in the observation (``PrimitiveObs.kind``; 0: none yet) and in
#: ``info["primitive_kind"]`` of the primitive ids; the joint ids' ``drag`` is their turn.
PRIMITIVE_KIND = {"probe": -1, "turn": 1, "drag": 1}

UP = np.array([0.0, 0.0, 1.0])
#: A skill's action: the 6-D motion and the tare request (``HingeProbeEnv``'s Action Space).
ACTION_SIZE = 7
#: Still steps a probe holds beyond its hold rule: the skill reads the observation (float32)
#: and the gate the reading itself, so the gate's rule may be met one reading later.
HOLD_MARGIN = 1


@functools.lru_cache(maxsize=16)
def _rotation_of(quaternion: bytes) -> np.ndarray:
    """The rotation (read-only) of an observed quaternion, given as its float64 bytes: the
    skills read one every control step, and most steps do not turn the fingertip."""
    rotation = quaternion_to_matrix(np.frombuffer(quaternion))
    rotation.flags.writeable = False
    return rotation


@dataclass(frozen=True)
class TouchReading:
    """The parts of one observation the skills use (world frame)."""

    force: np.ndarray  # (3,) force on the fingertip, N
    wrench: np.ndarray  # (6,) force (N) and moment (N m), sensor frame
    position: np.ndarray  # (3,) sensor origin, m
    rotation: np.ndarray  # (3, 3) sensor to world
    touching: bool
    point: np.ndarray  # (3,) contact point (valid when touching), m
    edge: np.ndarray | None  # (3,) physically oriented edge, when observable
    measurements: int

    @classmethod
    def from_obs(cls, obs: dict) -> TouchReading:
        """The reading of a dict observation (``tactile_gym.envs.observation``)."""
        pose = FingertipPoseObs.read(obs)
        contact = ContactObs.read(obs)
        rotation = _rotation_of(pose.quaternion.tobytes())
        edge = contact.edge
        wrench = WrenchObs.read(obs)
        return cls(
            force=rotation @ wrench.force,
            wrench=np.r_[wrench.force, wrench.moment],
            position=pose.position,
            rotation=rotation,
            touching=bool(contact.touching > 0.5),
            point=contact.point,
            edge=edge / norm(edge) if contact.has_edge else None,
            measurements=int(round(ProgressObs.read(obs).measurements)),
        )

    @property
    def magnitude(self) -> float:
        return norm(self.force)


@dataclass
class ProbeFrame:
    """What probing has revealed so far (module docstring), world frame.

    Attributes:
        normal: outward normal of the probed face (unit).
        point: last contact point, m; None before the first touch.
        edge: last measured edge, oriented physically (unit); None before the first one.
    """

    normal: np.ndarray = field(default_factory=lambda: UP.copy())
    point: np.ndarray | None = None
    edge: np.ndarray | None = None

    @property
    def interior(self) -> np.ndarray | None:
        """Unit vector in the face plane from the edge toward the face's interior."""
        if self.edge is None:
            return None
        v = np.array(cross(self.normal.tolist(), self.edge.tolist()))
        return v / norm(v)

    def update(self, reading: TouchReading) -> None:
        """Take in the reading at the end of a still press.

        A press pushes along the face normal, or, if it was oblique, closer to it than its
        path was, so the force line improves the normal press by press. The edge is taken
        from the reading whether or not the gate accepted it: it only steers the probing.
        """
        if not reading.touching or reading.magnitude < 1.0:
            return
        self.point = reading.point.copy()
        self.normal = reading.force / reading.magnitude
        if reading.edge is not None:
            edge = reading.edge - (reading.edge @ self.normal) * self.normal
            self.edge = edge / np.linalg.norm(edge)


class Skill:
    """A closed-loop motion: ``act(reading)`` returns an action, or None when done.

    Args:
        max_translation: the env's translation for an action of 1, m.
        frame: the shared probing frame (read, and updated by the caller).
        budget: control steps after which the skill gives up.
    """

    def __init__(self, max_translation: float, frame: ProbeFrame, budget: int) -> None:
        self.max_translation = float(max_translation)
        self.frame = frame
        self.budget = int(budget)
        self.steps = 0
        self.failed = False

    def act(self, reading: TouchReading) -> np.ndarray | None:
        if self.steps >= self.budget:
            self.failed = True
            return None
        move = self._move(reading)
        if move is None:
            return None
        self.steps += 1
        action = np.zeros(ACTION_SIZE)
        action[:3] = np.clip(move / self.max_translation, -1.0, 1.0)
        return action

    def _move(self, reading: TouchReading) -> np.ndarray | None:
        raise NotImplementedError

    def _limited(self, move: np.ndarray) -> np.ndarray:
        norm = float(np.linalg.norm(move))
        return move if norm <= self.max_translation else move * (self.max_translation / norm)


class Press(Skill):
    """Press along the face normal to the force of ``config``, then hold still until its hold
    rule is met, and ``hold_margin`` steps more.

    The press is ``tactile_gym.sensing.PressController``'s, one env action per reading;
    moving only along the normal keeps it pure (module docstring). It reads the sensor-frame
    wrench of the observation (its hold rule, with a target, predicts the edge error of their
    mean with ``sensor``, the sensing the env is configured with). Ends after the hold, or
    failed when no contact comes within the press's ``reach`` of travel.

    Args:
        max_translation: the env's translation for an action of 1, m (the press's
            ``max_step``).
        frame: the shared probing frame.
        config: the press.
        sensor: the touch sensing (needed with an ``edge_std_target``).
        hold_margin: still steps after the hold rule is met (``HOLD_MARGIN``).
    """

    def __init__(
        self,
        max_translation: float,
        frame: ProbeFrame,
        config: PressConfig,
        sensor: TouchSensor | None = None,
        hold_margin: int = 0,
    ) -> None:
        hold = config.hold_rule
        steps = int(config.reach / max_translation) + 30 + hold.most - hold.least
        super().__init__(max_translation, frame, budget=steps)
        self.press = PressController(config, sensor)
        self.hold_margin = int(hold_margin)
        self._still: int | None = None  # margin steps held after the rule was met

    def _move(self, reading: TouchReading) -> np.ndarray | None:
        if self._still is None:
            step = self.press.step(reading.wrench)
            if step is not None:
                return -self.frame.normal * step
            if self.press.phase != "done":
                self.failed = True
                return None
            self._still = 0
        if self._still < self.hold_margin:
            self._still += 1
            return np.zeros(3)
        self.frame.update(reading)
        return None


class Lift(Skill):
    """Move back along the face normal until the skin is free, then ``clearance`` more."""

    def __init__(self, max_translation: float, frame: ProbeFrame, clearance: float = 0.001):
        super().__init__(max_translation, frame, budget=20)
        self.clearance = float(clearance)
        self._free_travel = 0.0

    @property
    def cleared(self) -> bool:
        """Whether the finger moved ``clearance`` away after the reading let go."""
        return self._free_travel >= self.clearance

    def _move(self, reading: TouchReading) -> np.ndarray | None:
        if reading.magnitude < RELEASE_FORCE:
            if self.cleared:
                return None
            step = min(self.max_translation, self.clearance - self._free_travel)
            self._free_travel += step
            return self.frame.normal * step
        self._free_travel = 0.0
        return self.frame.normal * self.max_translation


class TareSensor(Skill):
    """Hold still for one step and ask the env to tare, if the lift before it ended clear.

    Args:
        max_translation: the env's translation for an action of 1, m.
        frame: the shared probing frame.
        lift: the :class:`Lift` that ran just before; no tare unless it cleared.
    """

    def __init__(self, max_translation: float, frame: ProbeFrame, lift: Lift) -> None:
        super().__init__(max_translation, frame, budget=1)
        self.lift = lift

    def act(self, reading: TouchReading) -> np.ndarray | None:
        if self.steps or not self.lift.cleared or reading.magnitude >= RELEASE_FORCE:
            return None
        self.steps += 1
        action = np.zeros(ACTION_SIZE)
        action[6] = 1.0
        return action


class Move(Skill):
    """Translate by ``offset`` (world) while free of contact."""

    def __init__(self, max_translation: float, frame: ProbeFrame, offset: np.ndarray):
        offset = np.asarray(offset, dtype=float)
        steps = int(np.ceil(np.linalg.norm(offset) / max_translation)) + 2
        super().__init__(max_translation, frame, budget=steps)
        self._left = offset.copy()

    def _move(self, reading: TouchReading) -> np.ndarray | None:
        if np.linalg.norm(self._left) < 1e-9:
            return None
        step = self._limited(self._left)
        self._left = self._left - step
        return step


class Drag(Skill):
    """Hold ``force`` on the face and move ``distance`` across the edge (positive: toward the
    face's interior, where the sticking skin carries the link along).

    It stops early when the force climbs past ``abort_force``: the link no longer follows
    (a joint limit), and pressing on would push the skin through to the shell.
    """

    def __init__(
        self,
        max_translation: float,
        frame: ProbeFrame,
        distance: float,
        force: float = 5.5,
        abort_force: float = 7.0,
    ) -> None:
        steps = int(np.ceil(abs(distance) / max_translation)) + 30
        super().__init__(max_translation, frame, budget=steps)
        self.distance = float(distance)
        self.force = float(force)
        self.abort_force = float(abort_force)
        self._done = 0.0

    def _direction(self) -> np.ndarray:
        """The drag's unit direction in the face plane: across the edge."""
        return np.sign(self.distance) * self.frame.interior

    def _move(self, reading: TouchReading) -> np.ndarray | None:
        n = self.frame.normal
        interior = self.frame.interior
        if interior is None or abs(self._done) >= abs(self.distance):
            return None
        if reading.magnitude > self.abort_force:
            self.failed = True
            return None
        if not reading.touching or reading.magnitude < 0.5 * self.force:
            # Not (yet) loaded: press first, do not slide over the face.
            step = float(
                np.clip((self.force - reading.magnitude) / PressConfig.stiffness, 0.0, 0.0005)
            )
            return -n * max(step, 0.0002)
        across = self._direction()
        left = abs(self.distance) - abs(self._done)
        sideways = min(self.max_translation * 0.9, left)
        self._done += sideways
        press = float(
            np.clip((self.force - reading.magnitude) / PressConfig.stiffness, -2e-4, 2e-4)
        )
        return across * sideways - n * press


@dataclass(frozen=True)
class PrimitiveScales:
    """What an action component of 1 means for the primitives, m."""

    probe_across: float = 0.003
    probe_along: float = 0.01
    turn_distance: float = 0.02


@dataclass(frozen=True, eq=False)
class PressSettings:
    """How the skills press (``tactile_gym.sensing.probing``): the probe's hold and the force
    gradient, the same for every press of an env.

    Attributes:
        hold: the probe's hold rule, the gate's (``GateConfig.hold_rule``); the probe holds
            ``HOLD_MARGIN`` steps more.
        sensor: the touch sensing the env is configured with, which predicts the edge error
            of a hold's mean (needed when ``hold`` has a target).
        measure_gradient: step by the force gradient measured while pressing
            (``PressConfig.measure_gradient``) rather than the assumed one.
    """

    hold: HoldRule
    sensor: TouchSensor | None = None
    measure_gradient: bool = False

    def probe(self, max_translation: float) -> PressConfig:
        """A probe's press: to 5 N, then hold."""
        hold = self.hold
        return PressConfig(
            target_force=5.0,
            max_step=max_translation,
            measure_gradient=self.measure_gradient,
            dwell=hold.least,
            edge_std_target=hold.target,
            dwell_budget=hold.budget,
        )

    def turn(self, max_translation: float) -> PressConfig:
        """A turn's press: to 5.5 N, no hold (the drag follows)."""
        return PressConfig(
            target_force=5.5, max_step=max_translation, measure_gradient=self.measure_gradient
        )


def primitive_skills(
    action: np.ndarray,
    frame: ProbeFrame,
    max_translation: float,
    presses: PressSettings,
    scales: PrimitiveScales,
    tare: bool = False,
    lift_slope: float = 0.0,
) -> tuple[str, list[Skill]]:
    """The primitive a normalised action (3,) asks for, as the skills that carry it out.

    ``action[0] < 0``: ``probe`` -- lift, move by ``action[2]`` along and ``action[1]`` across
    the last edge (positive beyond it), press along the face normal to 5 N and hold until
    ``presses.hold`` is met and ``HOLD_MARGIN`` steps more. ``action[0] >= 0``: ``turn`` --
    lift, move by ``action[2]`` along the edge, press to 5.5 N and drag ``action[1]`` across
    the edge (positive toward the face's interior). Before the first edge is known there are
    no directions to move in: ``probe`` presses where it is, ``turn`` only presses. With
    ``tare`` both tare the sensor right after the lift, before moving on
    (:class:`TareSensor`). The lift clears the skin by 1 mm plus ``lift_slope`` times the
    move's length, so that a long move clears a face whose normal the frame has a little
    wrong.
    """
    name = PRIMITIVES[int(action[0] >= 0.0)]
    offset = np.zeros(3)
    if frame.edge is not None:
        offset = action[2] * scales.probe_along * frame.edge
        if name == "probe":
            offset = offset - action[1] * scales.probe_across * frame.interior
    lift = Lift(max_translation, frame, 0.001 + lift_slope * norm(offset))
    skills: list[Skill] = [lift]
    if tare:
        skills.append(TareSensor(max_translation, frame, lift))
    if np.linalg.norm(offset) > 0.0:
        skills.append(Move(max_translation, frame, offset))
    if name == "probe":
        probe = presses.probe(max_translation)
        skills.append(Press(max_translation, frame, probe, presses.sensor, HOLD_MARGIN))
    else:
        skills.append(Press(max_translation, frame, presses.turn(max_translation)))
        if frame.edge is not None:
            skills.append(Drag(max_translation, frame, action[1] * scales.turn_distance))
    return name, skills


class PrimitiveExecutor:
    """Carries out probing primitives on the 6-D env one control step at a time.

    The primitive ids run each primitive to completion with it; a policy that chooses
    primitives (the scripted prober, or a policy learned on a primitive id) drives a 6-D id
    through it. After a primitive, ``summary`` describes it as the primitive ids observe it
    (the array of a ``PrimitiveObs``).

    Args:
        max_translation: the env's translation for an action of 1, m.
        presses: how the skills press (the probe's hold: the gate's rule).
        max_steps: the episode's control steps, to express a primitive's cost.
        scales: what a primitive action of 1 means.
        tare: the env has a tare action: tare before each press, act with 7-D actions.
    """

    def __init__(
        self,
        max_translation: float,
        presses: PressSettings,
        max_steps: int,
        scales: PrimitiveScales = PrimitiveScales(),  # noqa: B008 - frozen dataclass
        tare: bool = False,
    ) -> None:
        self.max_translation = float(max_translation)
        self.presses = presses
        self.max_steps = int(max_steps)
        self.scales = scales
        self.tare = bool(tare)
        self._size = ACTION_SIZE if self.tare else 6
        self.reset()

    @classmethod
    def for_env(
        cls,
        env,
        scales: PrimitiveScales = PrimitiveScales(),  # noqa: B008 - frozen dataclass
    ) -> PrimitiveExecutor:
        """The executor of a ``HingeProbeEnv`` (``env.unwrapped``): its translation scale and
        budget, probes held by the gate's hold rule and ``HOLD_MARGIN`` steps more (judged
        with the env's configured sensing), the skills' force gradient measured where the
        env says (``measure_gradient``), and a tare before each press where the env has a tare
        action."""
        config = env.config
        presses = PressSettings(
            env.gate.config.hold_rule, env.pipeline.sensor, config.measure_gradient
        )
        return cls(config.max_translation, presses, config.max_steps, scales, config.tare_action)

    def reset(self) -> None:
        """Forget the probing so far (call at every episode start)."""
        self.frame = ProbeFrame()
        self.name: str | None = None
        self.summary = PrimitiveObs(kind=0.0, measured=0.0, duration=0.0).to_array()
        self._skills: list[Skill] = []

    def start(self, action: np.ndarray, obs: dict) -> str:
        """Begin the primitive a normalised action (3,) asks for; returns its name."""
        self.name, self._skills = self.skills_for(np.clip(np.asarray(action, dtype=float), -1, 1))
        self._steps = 0
        self._count = ProgressObs.read(obs).measurements
        return self.name

    def skills_for(self, action: np.ndarray) -> tuple[str, list[Skill]]:
        """The primitive a normalised action (3,) asks for, as its skills
        (``primitive_skills``)."""
        return primitive_skills(
            action, self.frame, self.max_translation, self.presses, self.scales, self.tare
        )

    def act(self, obs: dict) -> np.ndarray | None:
        """The next 6-D action of the running primitive, or None once it is done."""
        if self.name is None:
            return None
        reading = TouchReading.from_obs(obs)
        while self._skills:
            action = self._skills[0].act(reading)
            if action is not None:
                self._steps += 1
                return action[: self._size]
            self._skills.pop(0)
        if not self._steps:
            # Nothing to do (e.g. a turn before any edge is known): one still step, so that
            # every primitive costs time.
            self._steps = 1
            return np.zeros(self._size)
        self.finish(obs)
        return None

    def finish(self, obs: dict) -> None:
        """End the running primitive (done, or cut short by the episode's end): set
        ``summary``."""
        if self.name is None:
            return
        self.summary = PrimitiveObs(
            kind=float(PRIMITIVE_KIND[self.name]),
            measured=float(ProgressObs.read(obs).measurements > self._count),
            duration=self._steps / self.max_steps,
        ).to_array()
        self.name = None
        self._skills = []
