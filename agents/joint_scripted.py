"""The scripted baseline of the joint ids: probe, try to move the object, probe again, and let
the joint-type estimator decide from what moved (``docs/design.md`` 7.12).

One episode, in primitives of the ``JointProbePrimitive`` ids (a ``probe`` presses, a
``drag`` drags the sticking skin across or along the face):

1. **Find the edge** A (the start is near it): probes, each corrected from what the last
   one read (``locate``): beyond the edge the contact sits at the edge, off the finger's
   centre, and tells where the edge is; over the face a small tilt says how far it is.
2. **Push** across A toward the face's interior (``push_distance``), then probe where the
   finger is: a hinged or sliding link came along with the sticking skin, so A is under the
   finger; a fixed one stayed, and the finger slid off A, which the next probe finds again.
3. Once A was measured at two configurations: if the estimator finds a hinge
   (``revolute_confidence``), the hinge ids' protocol carries on (turns sized from the
   lever, ``agents.scripted.PrimitiveProber``). Otherwise the link slid or did not move, and
   one edge cannot tell a slide along it from rigid, nor a slide's direction in the plane
   (``docs/design.md`` 6.10): **find B**, an edge square to A at one end of A (probes
   stepping along A, ``search_step`` apart, 10 mm in from A, until one lands at B), then
   cycle: probe A, probe B, probe A, push. Once a link that came along with a push stops
   coming along (its edge did not move with the finger: the slide is at its stop), the
   pushes end and the cycle only probes.

The policy reads only observations (the contact, the last measurement, the progress and the
joint-type estimate); it never reads the simulator. It mirrors the primitives' probing frame
(``ProbeFrame``, updated from each probe's last reading as the executor does) to turn the
world offsets it wants into the primitives' across and along offsets; a drag's frame update
it cannot see (it happens at the press before the drag) and takes as unchanged.

``JointProber`` chooses primitives (the ``JointProbePrimitive`` ids' action);
``agents.scripted.SkillProber`` carries its choices out step by step on the 6-D joint ids.
``joint_policy(env)`` returns the right one for any joint id (``agents.policies``' scripted
policy picks it or ``agents.scripted.scripted_policy``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Generator
from dataclasses import dataclass

import numpy as np

from tactile_gym.envs.joint_probe_primitive import (
    JOINT_SCALES,
    JointPrimitiveExecutor,
    JointProbeFrame,
)
from tactile_gym.envs.observation import (
    ContactObs,
    FingertipPoseObs,
    JointTypeObs,
    LastMeasurementObs,
    ProgressObs,
)
from tactile_gym.envs.skills import PrimitiveScales, TouchReading
from tactile_gym.estimation import OUTCOMES
from tactile_gym.perception.gate import line_distance
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.spatial import quaternion_to_matrix
from tactile_gym.vec3 import norm

from .scripted import Policy, PrimitiveProber, ProberConfig, SkillProber

__all__ = ["JointProber", "JointProberConfig", "joint_policy"]

_RIGID, _REVOLUTE, _PRISMATIC = (OUTCOMES.index(t) for t in ("rigid", "revolute", "prismatic"))


@dataclass(frozen=True)
class JointProberConfig:
    """Parameters of the joint protocol (SI units).

    Attributes:
        push_distance: each push's drag across A toward the face's interior, m.
        revolute_confidence: the revolute probability above which the hinge protocol takes
            over, once A was measured at two configurations.
        search_step: distance between the probes that look for B along A, m.
        search_probes: probes that look for B on each side before giving up there.
        inset: how far in from A the probes for B press, m.
        beyond: where a probe aims the finger's centre: this far beyond the edge, m.
        retries: probes of an edge that did not measure it, after which the protocol moves
            on.
        moved: an edge whose line moved further than this over a push moved with the
            finger: the next push drags from the edge the finger is at, m.
        oblique: a probe whose force turned the frame's normal by more than this was
            oblique: it is pressed again where it was, rad.
        settled: at the start, probes are pressed again in place (at most
            ``settle_probes`` times) until one turns the normal by less than this, rad: the
            first press follows the finger's axis, which a tilted face's normal may be 30 deg
            off, and each press's force brings the normal about three times closer.
        ring: radius of the first ring of probes around the start that look for the first
            edge (the second ring's is twice that), m.
        edge_tilt: least tilt at which a reading's edge steers the first edge's search,
            rad.
        confirm_step: 0: a probe of an edge that pressed it well but was not measured is
            pressed again where it was. Else (the v1 joint ids' pipeline holds a press back
            until a second one along its line agrees: ``LabelConfig.confirm_spacing``) the
            next probes move this far along the edge and back, in turn (first away from
            the end the protocol knows, if any), m.
        hinge: the hinge protocol's parameters (``ProberConfig``).
    """

    push_distance: float = 0.016
    revolute_confidence: float = 0.9
    search_step: float = 0.006
    search_probes: int = 8
    inset: float = 0.010
    beyond: float = 0.0005
    retries: int = 4
    moved: float = 0.003
    oblique: float = math.radians(5.0)
    settled: float = math.radians(1.5)
    settle_probes: int = 5
    ring: float = 0.005
    edge_tilt: float = math.radians(1.0)
    confirm_step: float = 0.0
    hinge: ProberConfig = ProberConfig()


class _Outcome:
    """What a probe gave: the reading at its end and whether it was measured."""

    def __init__(self, obs: dict, measured: bool, geometry: FingertipGeometry) -> None:
        self.obs = obs
        self.measured = measured
        self.contact = ContactObs.read(obs)
        self.last = LastMeasurementObs.read(obs)
        pose = FingertipPoseObs.read(obs)
        rotation = quaternion_to_matrix(pose.quaternion)
        self.centre = pose.position + rotation @ geometry.sphere_center
        self.touching = bool(self.contact.touching > 0.5)
        self.turned = 0.0
        self.oblique = False
        self.outward: np.ndarray | None = None


class JointProber:
    """Chooses the joint ids' primitives from observations (module docstring).

    Args:
        scales: what an action of 1 means for the primitives (the env's).
        config: protocol parameters.
        geometry: the fingertip (its hemisphere's centre in the sensor frame).
    """

    def __init__(
        self,
        scales: PrimitiveScales,
        config: JointProberConfig = JointProberConfig(),  # noqa: B008 - frozen dataclass
        geometry: FingertipGeometry = FingertipGeometry(),  # noqa: B008
    ) -> None:
        self.scales = scales
        self.config = config
        self.geometry = geometry
        self.reset()

    def reset(self) -> None:
        """Start a new episode."""
        self._protocol: Generator[np.ndarray, dict, None] | None = None
        self.phase = "find A"
        self._shifts = 0  # probes moved along an edge since the last measurement
        self._away: np.ndarray | None = None  # along the edge probed, away from its known end

    def act(self, obs: dict) -> np.ndarray:
        """The next primitive action (3,) for a dict observation."""
        if self._protocol is None:
            self._obs = obs
            self._frame = JointProbeFrame()
            self._count = int(round(ProgressObs.read(obs).measurements))
            self._protocol = self._episode()
            return next(self._protocol)
        return self._protocol.send(obs)

    # ------------------------------------------------------------------ primitives
    def _probe(self, offset: np.ndarray) -> Generator[np.ndarray, dict, _Outcome]:
        """Probe after moving the finger by ``offset`` (world, in the face plane)."""
        frame = self._frame
        along = across = 0.0
        if frame.edge is not None:
            along = float(offset @ frame.edge) / self.scales.probe_along
            across = -float(offset @ frame.interior) / self.scales.probe_across
        normal = frame.normal.copy()
        obs = yield np.array([-1.0, np.clip(across, -1, 1), np.clip(along, -1, 1)])
        frame.update(TouchReading.from_obs(obs))  # as the executor's Press did
        out = self._outcome(obs)
        # A press along a normal that its force then moved by more than a few degrees was
        # oblique: the skin was dragged, and its tilt (and the edge's sign) is friction's.
        out.turned = math.acos(min(1.0, float(frame.normal @ normal)))
        out.oblique = out.turned > self.config.oblique
        return out

    def _drag(self, across: float, along: float = 0.0) -> Generator[np.ndarray, dict, _Outcome]:
        """Drag by ``across`` (toward the interior) and ``along`` the frame's edge, m."""
        d = self.scales.turn_distance
        obs = yield np.array([1.0, np.clip(across / d, -1, 1), np.clip(along / d, -1, 1)])
        return self._outcome(obs)

    def _outcome(self, obs: dict) -> _Outcome:
        count = int(round(ProgressObs.read(obs).measurements))
        measured = count > self._count
        if measured:
            self._shifts = 0
        self._count = count
        self._obs = obs
        return _Outcome(obs, measured, self.geometry)

    # ------------------------------------------------------------------ edges
    def _measure(
        self, edge: np.ndarray | None, outward: np.ndarray | None, first: np.ndarray
    ) -> Generator[np.ndarray, dict, _Outcome | None]:
        """Probe after moving by ``first`` until a measurement of an edge within 45 deg of
        ``edge`` (any, if None) is taken; corrections toward ``outward`` (the unit direction
        beyond the edge, in the face plane; the frame's when None). None after
        ``retries`` probes without it."""
        offset = first
        # A press held back until a second one along its line agrees takes two probes more.
        for _ in range(self.config.retries + (2 if self.config.confirm_step else 0)):
            out = yield from self._probe(offset)
            if out.measured and (edge is None or out.last.edge @ edge > math.cos(math.pi / 4)):
                return out
            offset = self._correction(out, outward)
        return None

    def _correction(self, out: _Outcome, outward: np.ndarray | None) -> np.ndarray:
        """Where to probe next after a probe that did not measure the edge (``locate``)."""
        cfg, hinge = self.config, self.config.hinge
        frame = self._frame
        if outward is None:
            outward = -frame.interior if frame.edge is not None else np.zeros(3)
        if out.oblique:
            return np.zeros(3)  # press again, along the normal its force gave
        if not out.touching:
            return -0.003 * outward  # pressed into nothing: beyond the edge, come back
        normal = frame.normal
        tilt = out.contact.tilt
        if cfg.confirm_step and ContactObs.read(out.obs).has_edge and tilt >= hinge.min_tilt:
            # Cut by an edge as a measurement must be, but not measured: most likely held
            # back until a press along its line agrees (or refused for another reason).
            # Press along the edge and back in turn, first away from a known end of it.
            along = np.cross(normal, outward)
            along /= norm(along)
            if self._away is not None and float(along @ self._away) < 0.0:
                along = -along
            self._shifts += 1
            return (cfg.confirm_step if self._shifts % 2 else -cfg.confirm_step) * along
        centre = out.centre - ((out.centre - out.contact.point) @ normal) * normal
        off = out.contact.point - centre
        if float(off @ outward) < -0.0025:
            # The contact sits at the edge, inside the finger's centre: the finger is beyond
            # the edge, which the contact locates.
            return float(off @ outward) * outward + cfg.beyond * outward
        if tilt < hinge.min_tilt:
            step = (hinge.target_tilt - tilt) / hinge.tilt_per_metre
            return float(np.clip(step, 0.0005, 0.003)) * outward
        return np.zeros(3)  # refused for another reason: press again where it was

    # ------------------------------------------------------------------ the episode
    def _find_edge(self) -> Generator[np.ndarray, dict, _Outcome]:
        """Measure the first edge, near the start. Until a press along the face's normal
        shows an edge (a press along another direction drags the skin, and its tilt, and its
        edge's sign, are friction's), probe in place, then around the start: 5 mm away in
        six directions 60 deg apart (opposite ones in turn), then 10 mm."""
        cfg = self.config
        out = yield from self._probe(np.zeros(3))
        for _ in range(cfg.settle_probes):
            if out.measured or out.turned < cfg.settled:
                break
            out = yield from self._probe(np.zeros(3))  # until the normal settles
        frame = self._frame
        start = out.centre
        ring = [0, 3, 1, 4, 2, 5]
        tries = 0
        while not out.measured:
            edge = out.contact.edge
            tilted = out.contact.tilt > cfg.edge_tilt
            if not out.oblique and ContactObs.read(out.obs).has_edge and tilted:
                outward = np.cross(edge, frame.normal)
                found = yield from self._measure(None, outward, self._correction(out, outward))
                if found is not None:
                    return found
            if out.oblique:
                target = out.centre  # press again where it was, along the new normal
            else:
                angle = math.pi / 3 * ring[tries % 6]
                radius = cfg.ring * (1 + (tries // 6) % 2)
                target = start + radius * (
                    math.cos(angle) * frame.edge + math.sin(angle) * frame.interior
                )
                tries += 1
            offset = target - out.centre
            offset -= (offset @ frame.normal) * frame.normal
            out = yield from self._probe(offset)
        return out

    def _episode(self) -> Generator[np.ndarray, dict, None]:
        cfg = self.config
        a = first = yield from self._find_edge()
        a_edge, a_point = a.last.edge.copy(), a.last.point.copy()
        a_configs = {self._configurations()}
        edges = [a_edge]
        while True:
            self.phase = "push"
            outward = -self._frame.interior
            yield from self._drag(cfg.push_distance)
            self.phase = "find A"
            moved = yield from self._measure(a_edge, outward, np.zeros(3))
            if moved is None:
                # Not found near the finger: back to where A was.
                back = self._to_line(a_point, a_edge, outward)
                moved = yield from self._measure(a_edge, outward, back)
            if moved is None:
                continue
            edges.append(moved.last.edge.copy())
            a_edge, a_point = moved.last.edge.copy(), moved.last.point.copy()
            a_configs.add(self._configurations())
            if len(a_configs) >= 2:
                break
        if self._probability(_REVOLUTE) > cfg.revolute_confidence:
            yield from self._hinge(edges)
        else:
            yield from self._slide_or_fixed(first, moved)

    def _configurations(self) -> int:
        return int(round(JointTypeObs.read(self._obs).configurations))

    def _probability(self, index: int) -> float:
        return float(JointTypeObs.read(self._obs).probabilities[index])

    def _to_line(self, point: np.ndarray, edge: np.ndarray, outward: np.ndarray) -> np.ndarray:
        """The offset, along ``outward``, that brings the finger's centre ``beyond`` past the
        line (``point``, ``edge``)."""
        out = _Outcome(self._obs, False, self.geometry)
        gap = float((point - out.centre) @ outward)
        return (gap + self.config.beyond) * outward

    def _hinge(self, edges: list[np.ndarray]):
        """The hinge protocol from here on (``PrimitiveProber``): told the edges measured
        before the last push and the levers of their turns, it takes the last measurement as
        its own probe's after its own turn."""
        self.phase = "hinge"
        push = self.config.push_distance
        turns = [math.acos(min(1.0, float(a @ b))) for a, b in zip(edges[:-2], edges[1:-1])]
        levers = [push / t for t in turns if t > self.config.hinge.stalled_angle]
        hinge = PrimitiveProber(self.scales, self.config.hinge)
        hinge.resume(edges[:-1], levers, self._count - 1, push)
        obs = self._obs
        while True:
            obs = yield hinge.act(obs)

    def _slide_or_fixed(self, first: _Outcome, a: _Outcome) -> Generator[np.ndarray, dict, None]:
        """Find B square to A, then push and press both, in turn (module docstring).

        Each edge's probe aims where the finger was when it last measured it, moved with the
        link when the link slides (the estimator finds a slide likelier than no motion: the
        finger carried it), else where it was. Each push drags toward A's face interior from
        the edge the finger is at, across A or along B, and the edge is then measured again
        where the finger is, the other one after it."""
        cfg = self.config
        edges = {"A": [a.last.edge.copy(), -self._frame.interior, a.centre.copy()]}
        self._last_of = {"A": a.last}
        push = self._frame.interior.copy()
        self.phase = "find B"
        found = None
        for side in (-1.0, 1.0):
            found = yield from self._search(a, side)
            if found is not None:
                break
        if found is None:
            # No end of A within reach: keep pushing and measuring A alone.
            self.phase = "A alone"
            edges["B"] = None
            at = "A"
        else:
            edges["B"] = [found.last.edge.copy(), found.outward, found.centre.copy()]
            self._last_of["B"] = found.last
            at = "B"
        self.phase = "cycle"
        # Whether the last push moved the link: A's line after the first push against before.
        carried = self._shift(first.last, a.last) > cfg.moved
        # A link that came along with a push and then stops coming along is at its joint's
        # stop: pushing on drags the finger over the face until its shell touches, so from
        # then on the edges are only probed (what the probes measure, never the truth).
        came_along, at_stop = carried, False
        while True:
            if at != "A" and not carried:
                # A link that did not come along: push across A, not along B, whose far end a
                # finger sliding along it could run into.
                edge, outward, target = edges["A"]
                out = yield from self._measure(edge, outward, self._offset_to(target))
                if out is not None:
                    edges["A"] = [out.last.edge.copy(), outward, out.centre.copy()]
                    at = "A"
            dragged = at
            if not at_stop:
                yield from self._drag_toward(cfg.push_distance * push)
            if carried:
                for entry in edges.values():
                    if entry is not None:
                        entry[2] = entry[2] + cfg.push_distance * push
                # The edge the finger dragged came along: measure it first, where it is.
                order = [at] + [k for k in edges if k != at and edges[k] is not None]
            else:
                # The finger slid over the face: end at A, to push across it again.
                order = [k for k in edges if k != "A" and edges[k] is not None] + ["A"]
            for name in order:
                edge, outward, target = edges[name]
                first = np.zeros(3) if name == at and carried else self._offset_to(target)
                before = self._last_of.get(name)
                out = yield from self._measure(edge, outward, first)
                if out is not None:
                    edges[name] = [out.last.edge.copy(), outward, out.centre.copy()]
                    at = name
                    if name == dragged and before is not None:
                        carried = self._shift(before, out.last) > cfg.moved
                    self._last_of[name] = out.last
            at_stop = at_stop or (came_along and not carried)
            came_along = came_along or carried

    @staticmethod
    def _shift(before, after) -> float:
        """How far an edge's line moved between two measurements of it, m: the distance of the
        later contact from the earlier line."""
        return line_distance(after.point, before.edge, before.point, before.edge)

    def _offset_to(self, centre: np.ndarray) -> np.ndarray:
        """The offset in the face plane that brings the finger's centre to ``centre``."""
        here = _Outcome(self._obs, False, self.geometry).centre
        offset = centre - here
        normal = self._frame.normal
        return offset - (offset @ normal) * normal

    def _drag_toward(self, drag: np.ndarray) -> Generator[np.ndarray, dict, _Outcome]:
        """A drag by ``drag`` (world, in the face plane), in the frame's coordinates."""
        frame = self._frame
        out = yield from self._drag(float(drag @ frame.interior), float(drag @ frame.edge))
        return out

    def _search(self, a: _Outcome, side: float):
        """Probe along A (``side`` times its direction), ``inset`` in from it, every
        ``search_step``, until a probe lands near an end: the contact sits short of the
        finger's centre (the finger is beyond the end), or an edge square to A cuts the
        patch. Then measure that edge, B. Returns its measurement (its ``outward``: beyond
        B), or None once a probe misses the face."""
        cfg = self.config
        frame = self._frame
        along = side * a.last.edge
        inward = frame.interior.copy()
        start = a.centre
        offset = cfg.inset * inward + cfg.search_step * along
        for _ in range(self.config.search_probes):
            out = yield from self._probe(offset)
            below = float((a.contact.point - out.contact.point) @ frame.normal)
            if not out.touching or below > 0.003:
                return None  # off the face: nothing, or the table below it
            short = float((out.contact.point - out.centre) @ along)
            edge = out.contact.edge
            square = ContactObs.read(out.obs).has_edge and abs(float(edge @ a.last.edge)) < 0.5
            if short < -0.0015 or (square and out.contact.tilt > math.radians(2.0)):
                # B is about at the contact (beyond it the contact sits at the edge, about
                # 1 mm inside it); aim 0.5 mm beyond it.
                place = float((out.contact.point - start) @ along) + 0.001 + cfg.beyond
                to_b = cfg.inset * inward + place * along
                b = np.cross(frame.normal, along)  # oriented physically: interior is -along
                self._away = inward  # B's end at A is known: probe B away from it
                found = yield from self._measure(b, along, to_b - (out.centre - start))
                self._away = None
                if found is not None:
                    found.outward = along
                return found
            offset = cfg.search_step * along
        return None


def joint_policy(env, config: JointProberConfig = JointProberConfig()):  # noqa: B008
    """The joint ids' scripted baseline, either action mode (dict or flat observations; it
    starts over at each episode's first observation, as ``agents.scripted`` does); pass
    ``gym.make(...)``."""
    codec = env.get_wrapper_attr("codec")
    env_config = getattr(env.unwrapped, "control_env", env.unwrapped).config
    spacing = env_config.label_config.confirm_spacing
    if spacing and not config.confirm_step:
        # The env's pipeline holds presses back (its configuration, known before touching):
        # the next probe presses 2 mm beyond the spacing along the edge.
        config = dataclasses.replace(config, confirm_step=spacing + 0.002)
    if env.action_space.shape == (3,):
        return Policy(JointProber(env.get_wrapper_attr("scales"), config), codec, True)
    executor = JointPrimitiveExecutor.for_env(env.unwrapped, JOINT_SCALES)
    chooser = JointProber(executor.scales, config)
    return Policy(SkillProber(executor, chooser=chooser), codec, False)
