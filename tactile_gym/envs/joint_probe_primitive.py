"""JointProbePrimitive: the joint task acted on with probing primitives.

``JointProbePrimitiveEnv`` is ``HingeProbePrimitiveEnv`` driving a ``JointProbeEnv``, its
turn made a drag in any direction of the face plane (``Slide``: across or along the last
edge), so that it can slide a drawer as well as turn a link. ``make_primitive_env`` and
``make_primitive_vector_env`` are the ids' entry points.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tactile_gym.envs.hinge_probe_primitive import PRIMITIVE_KEYWORDS, HingeProbePrimitiveEnv
from tactile_gym.envs.joint_probe import JointProbeEnv
from tactile_gym.envs.skills import (
    Drag,
    Lift,
    Press,
    PressSettings,
    PrimitiveExecutor,
    PrimitiveScales,
    ProbeFrame,
    Skill,
    TareSensor,
    TouchReading,
    primitive_skills,
)
from tactile_gym.envs.vector import HingeProbeVectorEnv
from tactile_gym.estimation import JointTypeEstimate
from tactile_gym.vec3 import norm

__all__ = [
    "JOINT_SCALES",
    "LIFT_SLOPE",
    "NORMAL_UPDATE_ANGLE",
    "JointPrimitiveExecutor",
    "JointProbeFrame",
    "JointProbePrimitiveEnv",
    "Slide",
    "joint_primitive_skills",
    "make_primitive_env",
    "make_primitive_vector_env",
]


#: What an action of 1 means for the joint ids' primitives, m: a probe moves up to 50 mm
#: across and 80 mm along the last edge (to come back after a push that left the link where
#: it was, and to reach the face's other edges), a drag 20 mm.
JOINT_SCALES = PrimitiveScales(probe_across=0.05, probe_along=0.08, turn_distance=0.02)
#: A probe lifts this much more per metre it moves (tan 20 deg): the face's normal as the
#: frame has it may be as far off as an edge press's tilt, and a long move at the usual 1 mm
#: clearance would run into the face.
LIFT_SLOPE = math.tan(math.radians(20.0))
#: Largest angle between a press's force and the probing frame's normal at which the press
#: still sets the normal, rad: beyond it the finger pressed on an edge or a corner from
#: beyond (the force leans asin(b / R) at b beyond an edge), not on the face.
NORMAL_UPDATE_ANGLE = math.radians(20.0)


@dataclass
class JointProbeFrame(ProbeFrame):
    """``ProbeFrame`` whose normal follows only presses on the face: the first press, and
    then those whose force lies within ``NORMAL_UPDATE_ANGLE`` of the normal so far. The
    joint ids' probes look for edges and ends beyond the probed face, where a press that
    lands beyond an edge would otherwise tilt every later press by tens of degrees. Before
    an edge is measured, its edge is world x (made square to the normal at each update), so
    that the primitives can move the finger before they know any edge."""

    def __post_init__(self) -> None:
        if self.edge is None:
            self.edge = np.array([1.0, 0.0, 0.0])

    def update(self, reading: TouchReading) -> None:
        if not reading.touching or reading.magnitude < 1.0:
            return
        normal = self.normal
        force = reading.force / reading.magnitude
        keep = self.point is not None and force @ normal < math.cos(NORMAL_UPDATE_ANGLE)
        super().update(reading)
        if keep:
            self.normal = normal
        edge = self.edge - (self.edge @ self.normal) * self.normal
        self.edge = edge / norm(edge)


class Slide(Drag):
    """A drag in any direction of the face plane: ``across`` the last edge (positive toward
    the face's interior) and ``along`` it (positive in the edge's direction), m; the sticking
    skin carries a hinged link round or a sliding one along (``Drag``)."""

    def __init__(
        self,
        max_translation: float,
        frame: ProbeFrame,
        across: float,
        along: float,
        force: float = 5.5,
        abort_force: float = 7.0,
    ) -> None:
        super().__init__(max_translation, frame, math.hypot(across, along), force, abort_force)
        self.across, self.along = float(across), float(along)

    def _direction(self) -> np.ndarray:
        v = self.across * self.frame.interior + self.along * self.frame.edge
        return v / norm(v)


def joint_primitive_skills(
    action: np.ndarray,
    frame: ProbeFrame,
    max_translation: float,
    presses: PressSettings,
    scales: PrimitiveScales,
    tare: bool = False,
) -> tuple[str, list[Skill]]:
    """The primitive a normalised action (3,) asks for, as the skills that carry it out.

    ``action[0] < 0``: ``probe``, as on the hinge ids (``primitive_skills``), lifting higher
    before a long move (``LIFT_SLOPE``). ``action[0] >=
    0``: ``drag`` -- lift, press to 5.5 N where the finger is, and drag by ``action[1]``
    across the last edge (positive toward the face's interior) and ``action[2]`` along it,
    each times ``scales.turn_distance``; the press does not change the probing frame, which
    follows the probes alone. Before the first edge is known, the frame's edge is
    world x (``JointProbeFrame``). With ``tare`` the sensor is tared right after the lift
    (``TareSensor``).
    """
    if action[0] < 0.0:
        return primitive_skills(action, frame, max_translation, presses, scales, tare, LIFT_SLOPE)
    lift = Lift(max_translation, frame)
    skills: list[Skill] = [lift]
    if tare:
        skills.append(TareSensor(max_translation, frame, lift))
    # The press before the drag does not update the frame (it presses on a copy): the frame
    # follows the probes alone, whose last readings the policy observes.
    skills.append(Press(max_translation, dataclasses.replace(frame), presses.turn(max_translation)))
    distance = scales.turn_distance
    skills.append(Slide(max_translation, frame, action[1] * distance, action[2] * distance))
    return "drag", skills


class JointPrimitiveExecutor(PrimitiveExecutor):
    """``PrimitiveExecutor`` with the joint ids' primitives (``joint_primitive_skills``) and
    probing frame (``JointProbeFrame``)."""

    def reset(self) -> None:
        super().reset()
        self.frame = JointProbeFrame()

    def skills_for(self, action: np.ndarray) -> tuple[str, list[Skill]]:
        return joint_primitive_skills(
            action, self.frame, self.max_translation, self.presses, self.scales, self.tare
        )


def make_primitive_env(render_mode: str | None = None, **kwargs: Any) -> JointProbePrimitiveEnv:
    """The entry point of the joint primitive ids: the primitive env (its
    ``PRIMITIVE_KEYWORDS``) driving a ``JointProbeEnv`` of the other keywords."""
    own = {key: kwargs.pop(key) for key in PRIMITIVE_KEYWORDS if key in kwargs}
    inner = "rgb_array" if render_mode == "rgb_array_list" else render_mode
    control_env = JointProbeEnv(render_mode=inner, **kwargs)
    return JointProbePrimitiveEnv(control_env, render_mode=render_mode, **own)


def make_primitive_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the joint primitive ids: ``num_envs`` primitive sub-envs."""
    return HingeProbeVectorEnv(make_primitive_env, num_envs, **kwargs)


class JointProbePrimitiveEnv(HingeProbePrimitiveEnv):
    """``JointProbe`` with probing primitives as actions; each runs the 6-D env underneath.

    ## Description

    ``HingeProbePrimitive``'s env (``tactile_gym/envs/hinge_probe_primitive.py``) driving a
    ``JointProbeEnv``, its ``control_env``: the task, the physics, the pipeline, the joint-type
    estimator, the observation and the reward are the 6-D env's
    (``tactile_gym/envs/joint_probe.py``). Its turn is a drag in any direction of the face
    plane, so that it can slide a drawer as well as turn a link.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``; ``a[0] < 0`` selects ``probe``, ``a[0] >= 0`` ``drag``:

    | primitive | a[1] at 1                              | a[2] at 1                           |
    |-----------|----------------------------------------|-------------------------------------|
    | probe     | across offset ``probe_across`` (50 mm),| along offset ``probe_along`` (80 mm)|
    |           | positive beyond the last edge          | in the edge's direction             |
    | drag      | ``turn_distance`` (20 mm) across the   | ``turn_distance`` along the last    |
    |           | last edge, positive toward the face's  | edge, in its direction              |
    |           | interior                               |                                     |

    * ``probe``: ``HingeProbePrimitive``'s: lift off, move by the offsets in the plane of the
      probed face, press along the face normal to 5 N and hold still for the gate's dwell.
    * ``drag``: lift, press to 5.5 N where the finger is, and drag by
      ``(a[1], a[2]) turn_distance`` in the face plane (``Slide``): the sticking skin carries
      a hinged link round, a sliding one along its travel, and slides over a fixed one.

    Before the first edge is measured, "the last edge" of both is world x, made square to
    the face's normal (``JointProbeFrame``).

    Both tare the F/T sensor right after the lift (``skills.TareSensor``).

    ## Observation Space, Rewards

    ``JointProbeEnv``'s observation after the primitive, plus ``primitive`` (the kind of the
    last primitive: -1 probe, +1 drag, 0 none yet; whether it produced a measurement; the
    fraction of the episode's control steps it took). The reward is the sum of the 6-D
    env's rewards during the primitive; ``info`` is the 6-D env's after it, the reward terms
    summed, plus ``primitive_kind`` and ``steps``.

    ## Episode End

    ``HingeProbePrimitive``'s: when the 6-D env ends, or after ``max_primitives``.

    ## Arguments

    ``control_env``, the ``JointProbeEnv`` to drive, then ``max_primitives``,
    ``probe_across``, ``probe_along``, ``turn_distance`` (the drag's length at 1) and
    ``render_mode``. Through ``gym.make`` every keyword of ``JointProbeEnv`` is accepted too
    (``make_primitive_env``).

    ## Version History

    * v0: initial release, on the v3 ids' contact step and calibrated covariance.
    * v1: every face that looks up at least 17 mm wide (a door and its frame 20 mm thick, a
      slider's rail and a drawer's panel 20 mm wide); a press enters the estimate once a
      second press at least 6 mm along its line agrees with it (or it keeps its line's
      direction, or its distance from a likely hinge); model fits held in a wrong minimum
      refitted from scratch (``docs/design.md`` 7.12).
    """

    executor_class = JointPrimitiveExecutor

    def __init__(
        self,
        control_env: JointProbeEnv,
        max_primitives: int = 64,
        probe_across: float = JOINT_SCALES.probe_across,
        probe_along: float = JOINT_SCALES.probe_along,
        turn_distance: float = JOINT_SCALES.turn_distance,
        render_mode: str | None = None,
    ) -> None:
        if not isinstance(control_env, JointProbeEnv):
            raise TypeError(f"control_env must be a JointProbeEnv, got {type(control_env)}")
        super().__init__(
            control_env, max_primitives, probe_across, probe_along, turn_distance, render_mode
        )

    @property
    def joint_estimate(self) -> JointTypeEstimate:
        """The control env's joint-type estimate (``JointProbeEnv.joint_estimate``)."""
        return self.control_env.joint_estimate
