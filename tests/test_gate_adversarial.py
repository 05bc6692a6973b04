"""Attack the measurement gate with adversarial policies; judge what it lets through.

Each policy acts on the 6-D fingertip actions (the primitive ids run the same gate under their
primitives, and are attacked with random primitives). The truth is read only here, after the
episodes: every accepted measurement is compared with the nearest long edge of the links'
top faces (all lie at the one distance from the axis that the fit assumes, so each is a valid
measurement: ``tactile_gym/sensing/probing.py``, ``tactile_gym/perception/gate.py``). Required
(issue "HingeProbe-v1"): P95 edge error <= 5 deg and P95 distance from the edge line <= 3 mm.

The hold-still adversaries (issue 17: a shear, a rock of the finger, a drag or an oblique
approach, then perfectly still, among plain presses at random places on both links) attack
the gate's preload rule (``GateConfig.preload_rule``, ``docs/design.md`` 7.2); honest presses
on a long edge must still get in.

On the joint ids the pipeline holds a press back until a second press along its line agrees
(``docs/design.md`` 7.12): there the hold-still and honest adversaries press in pairs along a
line, an attack counts the presses that passed the gate (held back or not), the hold-still
attack runs 150 episodes and random primitives move with the HingeProbe ids' reach. The v0
joint ids, whose pipeline takes every press, are known failures.

The full attacks (60 episodes per id) are ``slow``; the default run keeps short ones.
``python -m pytest -m slow tests/test_gate_adversarial.py -n 0 -s`` prints the P95 figures.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym
from tactile_gym.envs.joint_probe import JointProbeEnv
from tactile_gym.envs.scenarios import probed_edge
from tactile_gym.envs.skills import PrimitiveScales

P95_EDGE_DEG = 5.0
P95_DISTANCE = 0.003


def _unit(v):
    return v / np.linalg.norm(v)


class Adversary:
    """Base: a seeded generator, a phase counter and the env's action scales."""

    def __init__(self, env, rng: np.random.Generator) -> None:
        self.rng = rng
        self.u = env.unwrapped
        self.t = 0

    def force(self, obs) -> float:
        return float(np.linalg.norm(obs["wrench"][:3]))

    def act(self, obs) -> np.ndarray:
        self.t += 1
        return np.clip(self._act(obs), -1.0, 1.0).astype(np.float32)


class Random(Adversary):
    def _act(self, obs):
        return self.rng.uniform(-1, 1, 6)


class Corners(Adversary):
    """Corner actions (every component +-1), each held for a few steps."""

    def _act(self, obs):
        if self.t % 5 == 1:
            self.a = self.rng.choice([-1.0, 1.0], 6) * np.r_[1, 1, 1, 0.3, 0.3, 0.3]
        return self.a


class PressAndWiggle(Adversary):
    """Press down to about 5 N, then wiggle: tiny translations and turns, some still steps."""

    def _act(self, obs):
        if self.force(obs) < 4.5 and self.t < 40:
            return np.r_[0, 0, -0.2, 0, 0, 0]
        if self.rng.random() < 0.3:
            return np.zeros(6)
        return np.r_[self.rng.normal(0, 0.02, 3), self.rng.normal(0, 0.02, 3)]


class PressCycle(Adversary):
    """Aim, then run ``phases`` in turn (each a method returning an action, or None when it is
    done), and aim again: by default press along ``self.d`` to about 5 N, hold, lift."""

    phases = ("press", "hold", "lift")

    def _act(self, obs):
        f = self.force(obs)
        if getattr(self, "state", "aim") == "aim":
            self.aim()
            self.state, self.n = self.phases[0], 0
        while True:
            self.n += 1
            action = getattr(self, "_" + self.state)(f)
            if action is not None:
                return action
            following = self.phases.index(self.state) + 1
            if following == len(self.phases):
                self.state = "aim"
                return self.after_lift()
            self.state, self.n = self.phases[following], 0

    def _press(self, f):
        if f < 4.8 and self.n < 40:
            return np.r_[self.d * (0.25 if f < 0.1 else 0.08), 0, 0, 0]
        return None

    def _hold(self, f):
        return np.zeros(6) if self.n < 7 else None

    def _lift(self, f):
        return np.r_[0, 0, 0.5, 0, 0, 0] if f > 0.05 or self.n < 3 else None

    def after_lift(self):
        return np.zeros(6)


class ObliqueRetouch(PressCycle):
    """Press along a random direction off vertical (half of the presses within 2 deg, where
    the gate's thresholds are tested; the rest up to 15 deg) to about 5 N, hold, lift, move a
    little, press again: re-touches and oblique presses."""

    def aim(self):
        small = self.rng.random() < 0.5
        tilt = np.deg2rad(self.rng.uniform(0, 2) if small else self.rng.uniform(2, 15))
        az = self.rng.uniform(-np.pi, np.pi)
        self.d = np.array([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), -np.cos(tilt)])

    def after_lift(self):
        return np.r_[self.rng.normal(0, 0.4, 2), 0, 0, 0, 0]


class PressAndSlide(Adversary):
    """Press to 5 N, then slide in a random horizontal direction (holding the force)."""

    def _act(self, obs):
        if self.t == 1:
            az = self.rng.uniform(-np.pi, np.pi)
            self.d = np.array([np.cos(az), np.sin(az), 0.0]) * self.rng.uniform(0.05, 0.5)
        f = self.force(obs)
        if f < 4.5 and self.t < 30:
            return np.r_[0, 0, -0.2, 0, 0, 0]
        return np.r_[self.d[:2], np.clip(0.05 * (f - 5.0), -0.2, 0.2), 0, 0, 0]


class DragThenPress(Adversary):
    """Drag the link in a random direction, stop, and hold still without lifting (a sheared
    skin), then press deeper: what a careless turning policy does."""

    def _act(self, obs):
        phase = self.t % 20
        f = self.force(obs)
        if phase == 1:
            az = self.rng.uniform(-np.pi, np.pi)
            self.d = np.array([np.cos(az), np.sin(az)]) * 0.6
        if f < 4.5 and phase < 6:
            return np.r_[0, 0, -0.2, 0, 0, 0]
        if phase < 12:
            return np.r_[self.d, np.clip(0.05 * (f - 5.5), -0.2, 0.2), 0, 0, 0]
        if phase < 17:
            return np.zeros(6)
        return np.r_[0, 0, -0.05, 0, 0, 0]


class ShearThenPress(PressCycle):
    """Touch lightly, drag the barely loaded skin sideways (loading its sticking springs),
    then press straight down to about 5 N and hold: a pre-sheared skin under a clean-looking
    press. Then lift and do it again."""

    phases = ("touch", "shear", "press", "hold", "lift")

    def aim(self):
        az = self.rng.uniform(-np.pi, np.pi)
        self.shear = np.array([np.cos(az), np.sin(az)]) * self.rng.uniform(0.02, 0.15)
        self.light = self.rng.uniform(0.03, 0.3)
        self.d = np.array([0.0, 0.0, -1.0])

    def _touch(self, f):
        return np.r_[0, 0, -0.03, 0, 0, 0] if f < self.light and self.n < 40 else None

    def _shear(self, f):
        return np.r_[self.shear, 0, 0, 0, 0] if self.n < 5 else None


class HoldStill(PressCycle):
    """Go to a random place (a point on either link's top face, its ends and sides included,
    or, half of the time, on a long edge), press there to a random 3-7.5 N, ``disturb`` the
    press, then hold perfectly still and lift (issue 17, "A gate that sees a preloaded
    skin"). The truth aims the presses (an adversary may know the scene); the gate never
    reads it. Subclasses disturb; this one does not (an honest press at a random place)."""

    phases = ("rise", "travel", "press", "disturb", "hold", "lift")
    on_edge = False

    def aim(self):
        u, rng = self.u, self.rng
        # The hinge ids: both links' long edges. The joint ids: every edge of both links'
        # top faces (their links are plates, rails, drawers and panels, whose long edges the
        # hinge's frame does not give: aimed so, the drawers' presses went into the air).
        edges = _top_edges(u) if _joint(u) else _long_edges(u)
        pair = getattr(self, "pair", None)
        k = pair[0] if pair else int(rng.integers(len(edges)))
        start, direction, length = edges[k]
        self.normal = (
            _top_normal(u, k) if _joint(u) else u.scene.object_config.hinge_rotation()[:, 2]
        )
        # Across the face: from this long edge toward the link's other one.
        across_face = edges[k ^ 1][0] - start
        across_face -= (across_face @ direction) * direction
        width = float(np.linalg.norm(across_face))
        if pair:  # the pair's second press: on the first's line, 6-15 mm along it
            along = pair[1] + rng.choice([-1.0, 1.0]) * rng.uniform(0.006, 0.015)
            across = pair[2]
            self.pair = None
        elif self.on_edge or rng.random() < 0.5:  # on a long edge, within 1 mm of it
            along, across = rng.uniform(0.15, 0.85) * length, rng.uniform(-1e-3, 1e-3)
        else:  # anywhere on or just off a top face: flat face, ends, sides, corners
            along, across = rng.uniform(-0.1, 1.1) * length, rng.uniform(-0.1, 1.1) * width
        if _joint(u) and not pair:
            # The joint ids' pipeline takes a press once a second press along its line
            # agrees with it (docs/design.md 7.12): each press is followed by one on its line.
            self.pair = (k, along, across)
        self.target = start + along * direction + across * across_face / width
        self.force_target = rng.uniform(3.0, 7.5)
        self.d = np.array([0.0, 0.0, -1.0])
        self.prepare()

    def prepare(self):
        """Draw the disturbance (subclasses)."""

    def tip(self):
        """The centre of the fingertip's sphere and its lowest point's height, world."""
        scene, geometry = self.u.scene, self.u.geometry
        centre = scene.fingertip_rotation @ geometry.sphere_center + scene.fingertip_position
        return centre, centre[2] - geometry.outer_radius

    def _rise(self, f):
        return np.r_[0, 0, 1, 0, 0, 0] if self.tip()[1] < self.target[2] + 0.004 else None

    def _travel(self, f):
        # To 3 mm short of the target, back along the press direction.
        goal = self.target - self.d * (self.u.geometry.outer_radius + 0.003)
        offset = (goal - self.tip()[0]) / self.u.config.max_translation
        return np.r_[offset, 0, 0, 0] if np.linalg.norm(offset) > 0.05 else None

    def _press(self, f):
        if self.n > 80 or f >= self.force_target:
            return None
        gap = self.tip()[1] - self.target[2]
        if f < 0.1:  # approach: fast while clear of the face, slowly near it
            step = 0.5 if gap > 0.002 else 0.05
        else:  # about 6000 N/m once touching
            step = min(0.08, (self.force_target - f) / 6000.0 / self.u.config.max_translation)
        return np.r_[self.d * max(step, 0.005), 0, 0, 0]

    def _disturb(self, f):
        return None

    def _hold(self, f):
        if self.n == 1:
            self.presses += 1
        return np.zeros(6) if self.n < 10 else None

    presses = 0  # presses held (counted when the hold begins)


class OnEdge(HoldStill):
    """Honest presses on a long edge (on the joint ids, any edge of a top face) within 1 mm
    of it, to 4.5-7 N along the top face's normal (straight down on a level face), held
    still."""

    on_edge = True

    def prepare(self):
        self.force_target = self.rng.uniform(4.5, 7.0)
        self.d = -self.normal


class ShearHold(HoldStill):
    """Shear the pressed skin by 0.1-0.6 mm in a random level direction (half of the time
    back again, so that the net path is nil), then hold still."""

    def prepare(self):
        az = self.rng.uniform(-np.pi, np.pi)
        self.move = np.array([np.cos(az), np.sin(az), 0.0]) * self.rng.uniform(1e-4, 6e-4)
        self.back = self.rng.random() < 0.5

    def _disturb(self, f):
        scale = self.u.config.max_translation
        if self.n == 1:
            return np.r_[self.move / scale, 0, 0, 0]
        return np.r_[-self.move / scale, 0, 0, 0] if self.n == 2 and self.back else None


class RockHold(HoldStill):
    """Rock the pressed finger by 1-3 deg about a random level axis (half of the time back
    again, so that it ends as it began), then hold still."""

    def prepare(self):
        az = self.rng.uniform(-np.pi, np.pi)
        angle = np.deg2rad(self.rng.uniform(1.0, 3.0))
        self.turn = np.array([np.cos(az), np.sin(az), 0.0]) * angle / self.u.config.max_rotation
        self.back = self.rng.random() < 0.5

    def _disturb(self, f):
        if self.n == 1:
            return np.r_[0, 0, 0, self.turn]
        return np.r_[0, 0, 0, -self.turn] if self.n == 2 and self.back else None


class DragHold(HoldStill):
    """Drag the pressed finger 0.5-3 mm in a random level direction over a few steps,
    holding the force, then hold still."""

    def prepare(self):
        az = self.rng.uniform(-np.pi, np.pi)
        self.steps = int(self.rng.integers(2, 6))
        per_step = self.rng.uniform(5e-4, 3e-3) / self.steps / self.u.config.max_translation
        self.move = np.array([np.cos(az), np.sin(az)]) * per_step

    def _disturb(self, f):
        if self.n > self.steps:
            return None
        return np.r_[self.move, np.clip(0.05 * (f - self.force_target), -0.2, 0.2), 0, 0, 0]


class ObliqueHold(HoldStill):
    """Approach and press along a direction 3-30 deg off vertical, then hold still."""

    def prepare(self):
        tilt = np.deg2rad(self.rng.uniform(3.0, 30.0))
        az = self.rng.uniform(-np.pi, np.pi)
        self.d = np.array([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), -np.cos(tilt)])


#: The hold-still adversaries (issue 17), and honest presses at random places.
HOLD_STILL = (HoldStill, ShearHold, RockHold, DragHold, ObliqueHold)


ADVERSARIES = (
    Random,
    Corners,
    PressAndWiggle,
    ObliqueRetouch,
    PressAndSlide,
    DragThenPress,
    ShearThenPress,
)


def _long_edges(u):
    """The long top edges of both links as segments (start, unit direction, length), world."""
    cfg = u.scene.object_config
    origin, direction, side, _ = probed_edge(cfg, u.scene.joint_angle)
    hinge = cfg.hinge_rotation()
    pin = np.asarray(cfg.joint_position)
    free_start = origin - cfg.pin_overlap * direction
    segments = [
        (free_start, direction, cfg.free_link_size[0]),
        (free_start - side * cfg.free_link_size[1], direction, cfg.free_link_size[0]),
    ]
    length = cfg.fixed_link_size[0]
    top = pin + hinge[:, 2] * cfg.fixed_link_size[2] / 2 - hinge[:, 0] * (length - cfg.pin_overlap)
    for sign in (1.0, -1.0):
        segments.append(
            (top + sign * hinge[:, 1] * cfg.fixed_link_size[1] / 2, hinge[:, 0], length)
        )
    return segments


def _joint(u) -> bool:
    """Whether ``u`` (an env's ``unwrapped``) is a joint id's env (a primitive env's too)."""
    return isinstance(getattr(u, "control_env", u), JointProbeEnv)


def _top_boxes(u):
    """Both links' boxes (the free link's first)."""
    return (u.scene.object.free_box, u.scene.object.fixed_box)


def _top_normal(u, k: int) -> np.ndarray:
    """The unit normal of the top face that ``_top_edges(u)[k]`` bounds, world."""
    r = _top_boxes(u)[k // 4].rotation
    up = int(np.argmax(np.abs(r[2])))
    return np.sign(r[2, up]) * r[:, up]


def _top_edges(u):
    """Every edge of both links' faces that look up, as segments (start, unit direction,
    length), world, four per box (``_top_boxes``), opposite edges of a face paired (k and
    k ^ 1): on the joint ids each line of the link is a valid measurement (the pipeline
    labels it, docs/design.md 7.12); ends are edges, corners are not."""
    segments = []
    for box in _top_boxes(u):
        r, c, h = box.rotation, box.center, box.half_extents
        up = int(np.argmax(np.abs(r[2])))  # the box axis nearest world z
        top = c + np.sign(r[2, up]) * h[up] * r[:, up]
        a, b = [i for i in range(3) if i != up]
        for along, across in ((a, b), (b, a)):
            for sign in (1.0, -1.0):
                start = top + sign * h[across] * r[:, across] - h[along] * r[:, along]
                segments.append((start, r[:, along], 2.0 * h[along]))
    return segments


def _errors_against_both_long_edges(u, m):
    """Edge angle (deg) and distance (m) to the nearest long top edge of either link (on
    the joint ids, to the edge of either link's top face, ``_top_edges``, that explains the
    press best within both bounds).

    Both links are centred on the pin, so the long edges of the free link's face, and those
    of the fixed link beside the pin, all lie at the one distance from the axis that the fit
    assumes; a press on any of them is a valid measurement. Ends and corners are not. The
    edges are segments: the fixed link's edge line extended over the free link is no edge.
    """
    best = (np.inf, np.inf, np.inf)
    joint = _joint(u)
    for start, d, length in _top_edges(u) if joint else _long_edges(u):
        t = float(np.clip((m.point - start) @ d, 0.0, length))
        distance = float(np.linalg.norm(m.point - (start + t * d)))
        angle = float(np.degrees(np.arccos(min(1.0, abs(m.edge @ d)))))
        # The hinge ids: the nearest long edge. The joint ids judge against every edge of
        # both faces, and where two lie within a few mm (the scissors' links crossing at the
        # pin, a short end beside a long edge) the nearest need not be the one pressed: the
        # edge that best explains the press within both bounds is.
        score = max(angle / P95_EDGE_DEG, distance / P95_DISTANCE) if joint else distance
        best = min(best, (score, distance, angle))
    return best[2], best[1]


def _padded(action, space) -> np.ndarray:
    """The adversaries move the finger (6-D); on an id with a tare component (v2) they never
    ask for a tare, so it is padded with zeros."""
    action = np.asarray(action, np.float32)
    return np.r_[action, np.zeros(space.shape[0] - action.shape[0], np.float32)]


def _judge(
    env, low, episodes: int, seed: int, policy, on_accept=None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Run ``policy(k)`` (a function of the observation) for episodes ``k``; return the edge
    errors (deg) and line distances (m) of every measurement ``low`` (the 6-D env) accepts
    (each also handed to ``on_accept(low, measurement, angle, distance)`` if given), and how
    many presses passed the gate: accepted, or held back by the joint ids' pipeline until a
    press along its line agrees (rule ``unconfirmed``, ``docs/design.md`` 7.12)."""
    angles, distances, passed = [], [], 0
    pipeline = getattr(low, "control_env", low).pipeline
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        act = policy(k)
        done = False
        while not done:
            before = len(low.measurements)
            obs, _, terminated, truncated, _ = env.step(_padded(act(obs), env.action_space))
            done = terminated or truncated
            # Judge each new measurement against the link as it is when accepted.
            for m in low.measurements[before:]:
                angle, distance = _errors_against_both_long_edges(low, m)
                if on_accept is not None:
                    on_accept(low, m, angle, distance)
                angles.append(angle)
                distances.append(distance)
        passed += sum(p.accepted or p.rule == "unconfirmed" for p in pipeline.presses)
    env.close()
    return np.array(angles), np.array(distances), passed


def attack(env_id: str, episodes: int, steps: int, seed: int = 0):
    """The adversaries in turn on a 6-D id (module docstring)."""
    env = gym.make(env_id, max_steps=steps)
    rng = np.random.default_rng(seed)
    return _judge(env, env.unwrapped, episodes, seed,
                  lambda k: ADVERSARIES[k % len(ADVERSARIES)](env, rng).act)  # fmt: skip


def attack_primitives(env_id: str, episodes: int, seed: int = 0):
    """Random primitives (with their parameters) on a primitive id; same judgement. On the
    joint ids a probe's random move has the HingeProbe ids' reach in metres (their
    ``PrimitiveScales``' defaults): at the joint ids' own, 50 mm across and 80 mm along, it
    leaves the face, and one or two presses in 50 episodes reach the gate."""
    env = gym.make(env_id, max_steps=300)
    env.action_space.seed(seed)
    reach = np.ones(env.action_space.shape[0])
    if _joint(env.unwrapped):
        hinge, joint = PrimitiveScales(), env.get_wrapper_attr("scales")
        reach[1:3] = hinge.probe_across / joint.probe_across, hinge.probe_along / joint.probe_along

    def act(obs):
        action = env.action_space.sample()
        return action * reach if action[0] < 0.0 else action  # a probe, or a drag

    return _judge(env, env.unwrapped, episodes, seed, lambda k: act)


def hold_still_attack(
    env_id: str, episodes: int, steps: int, seed: int = 0, kinds=HOLD_STILL, on_accept=None,
    **make,
):  # fmt: skip
    """The hold-still adversaries (``kinds``) in turn on a 6-D id (``make``: more keywords
    of ``gym.make``, such as ``gate``; ``on_accept`` as ``_judge``'s)."""
    env = gym.make(env_id, max_steps=steps, **make)
    rng = np.random.default_rng(seed)
    return _judge(env, env.unwrapped, episodes, seed,
                  lambda k: kinds[k % len(kinds)](env, rng).act, on_accept)  # fmt: skip


def honest_edge_presses(
    env_id: str, episodes: int, steps: int, seed: int = 0, on_accept=None, **make
):
    """Honest presses on a long edge (``OnEdge``): (presses held, accepted, edge errors
    (deg) and line distances (m) of the accepted)."""
    env = gym.make(env_id, max_steps=steps, **make)
    rng = np.random.default_rng(seed)
    policies = []

    def policy(k):
        policies.append(OnEdge(env, rng))
        return policies[-1].act

    angles, distances, _ = _judge(env, env.unwrapped, episodes, seed, policy, on_accept)
    return sum(p.presses for p in policies), len(angles), angles, distances


def _check(angles, distances, passed: int, at_least: int):
    """The issue's bounds on what the gate let through; ``pytest -s`` prints the figures.

    ``at_least`` presses must have passed the gate, so that the attack tested it: on the
    HingeProbe ids every press that passed entered the estimate (``passed`` is
    ``len(angles)``); the joint ids' pipeline holds a press back until a second press along
    its line agrees, which attackers that do not press pairs seldom give, and the bounds hold
    for what entered (nothing, when nothing did; honest presses must enter:
    ``test_honest_presses_on_an_edge_get_in``)."""
    figures = "none entered"
    if len(angles):
        figures = (
            f"P95 edge error {np.percentile(angles, 95):.2f} deg, P95 distance from the edge"
            f" line {1e3 * np.percentile(distances, 95):.2f} mm"
        )
    print(f"\n{passed} passed the gate, {len(angles)} accepted: {figures}")
    assert passed >= at_least, f"only {passed} presses passed the gate"
    if len(angles):
        assert np.percentile(angles, 95) <= P95_EDGE_DEG, np.sort(angles)[-10:]
        assert np.percentile(distances, 95) <= P95_DISTANCE, np.sort(distances)[-10:]


def test_gate_survives_a_short_attack():
    angles, distances, passed = attack("tactile_gym/HingeProbe-v1", episodes=12, steps=120)
    # Some adversaries do make honest presses; what gets through must be right.
    _check(angles, distances, passed, at_least=3)


_JOINT = tactile_gym.JOINT_ENV_IDS + tactile_gym.LEGACY_JOINT_ENV_IDS
SIX_D = [e for e in tactile_gym.ENV_IDS + _JOINT if "Primitive" not in e]
JOINT_PRIMITIVE = [e for e in _JOINT if "Primitive" in e]
PRIMITIVE = [e for e in tactile_gym.ENV_IDS if "Primitive" in e] + JOINT_PRIMITIVE
#: Known failures, strict (a fix turns them into failures, to be taken off here): on the v0
#: joint ids, presses within a patch's radius of a corner and on faces narrower than the patch
#: get past the gate, and honest presses on those faces are off by more than 5 deg
#: (docs/design.md 7.12, "The gate on the joint ids"); v1 is their fix.
JOINT_GATE_OPEN = pytest.mark.xfail(
    strict=True, reason="the v0 joint ids let corner presses in (docs/design.md 7.12)"
)
_V0 = list(tactile_gym.LEGACY_JOINT_ENV_IDS)


def _known(env_ids: list[str], failing: list[str]) -> list:
    return [pytest.param(e, marks=JOINT_GATE_OPEN) if e in failing else e for e in env_ids]


def test_gate_survives_a_short_attack_on_a_joint_id():
    angles, distances, passed = attack(tactile_gym.JOINT_ENV_IDS[0], episodes=12, steps=120)
    _check(angles, distances, passed, at_least=3)


def test_gate_refuses_a_short_hold_still_attack():
    angles, distances, passed = hold_still_attack(
        "tactile_gym/HingeProbe-v1", episodes=20, steps=300
    )
    # Honest presses (``HoldStill`` itself) are among them: some get in, and are right.
    _check(angles, distances, passed, at_least=3)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", _known(SIX_D, _V0))
def test_gate_refuses_the_hold_still_attack(env_id):
    # The joint ids' faces are smaller, and some tilted: fewer random presses cut one edge
    # along the face's normal, and the attack needs more episodes to test the gate.
    episodes = 150 if env_id in _JOINT else 60
    angles, distances, passed = hold_still_attack(env_id, episodes, steps=400, seed=100)
    _check(angles, distances, passed, at_least=10)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", _known(SIX_D, _V0))
def test_honest_presses_on_an_edge_get_in(env_id):
    pressed, accepted, angles, distances = honest_edge_presses(env_id, 30, 400, seed=200)
    print(f"\n{accepted} of {pressed} honest presses on an edge accepted")
    # The gate refuses honest presses whose tilt or force is too small (a 3-4 N press, the
    # contact 1 mm inside the face); the rest must get in and be right.
    assert accepted >= 0.3 * pressed
    _check(angles, distances, accepted, at_least=10)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", _known(SIX_D, ["tactile_gym/JointProbe3D-v0"]))
def test_gate_survives_the_full_attack(env_id):
    angles, distances, passed = attack(env_id, episodes=60, steps=250, seed=100)
    # On tilted faces most adversarial presses are oblique and refused: fewer get through.
    _check(angles, distances, passed, at_least=15)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", _known(PRIMITIVE, [e for e in _V0 if "Primitive" in e]))
def test_gate_survives_random_primitives(env_id):
    angles, distances, passed = attack_primitives(env_id, episodes=50, seed=100)
    _check(angles, distances, passed, at_least=20)


def by_kind(steps: int = 400, seed: int = 100) -> None:
    """Print, per 6-D id and gate (with and without ``preload_rule``), what the hold-still
    attack of ``test_gate_refuses_the_hold_still_attack`` lets in (60 episodes), then each
    disturbing kind alone (20 episodes): presses accepted, and how many of them are more than
    5 deg or 3 mm off."""
    for env_id in SIX_D:
        for rule in (False, True):
            runs = [("all", HOLD_STILL, 60)] + [(k.__name__, (k,), 20) for k in HOLD_STILL[1:]]
            for name, kinds, episodes in runs:
                angles, distances, _ = hold_still_attack(
                    env_id, episodes, steps, seed, kinds, gate={"preload_rule": rule}
                )
                print(
                    f"{env_id} preload_rule={rule} {name} ({episodes} episodes):"
                    f" {len(angles)} accepted, {int((angles > P95_EDGE_DEG).sum())} > 5 deg,"
                    f" {int((distances > P95_DISTANCE).sum())} > 3 mm",
                    flush=True,
                )


def _where_on_a_face(u, point) -> tuple[str, float, float]:
    """The link whose top face a contact lies on (within 3.5 mm of it, else "off"), the
    face's width (its smaller side) and the contact's distance from its nearest corner, m."""
    for name, box in zip(("free", "fixed"), _top_boxes(u), strict=True):
        local = box.rotation.T @ (point - box.center)
        up = int(np.argmax(np.abs(box.rotation[2])))
        sides = [i for i in range(3) if i != up]
        if np.all(np.abs(local) <= box.half_extents + 0.0035):
            half, at = box.half_extents[sides], np.abs(local[sides])
            return name, float(2.0 * half.min()), float(np.linalg.norm(half - at))
    return "off", np.nan, np.nan


def where(env_id: str, steps: int = 400) -> None:
    """Print where the presses that the slow tests' hold-still attack (seed 100) and honest
    edge presses (seed 200) get in lie: per family and link (the top face the contact lies
    on), how many get in and how many of them are more than 5 deg off, and each of those with
    its face's width and its distance from the face's nearest corner (truth, for the
    diagnosis only: ``docs/design.md`` 7.12)."""
    for name, run, episodes, seed in (
        ("hold-still", hold_still_attack, 60, 100),
        ("honest edge presses", honest_edge_presses, 30, 200),
    ):
        counts, off = {}, []

        def on_accept(u, m, angle, distance, counts=counts, off=off):
            link, width, corner = _where_on_a_face(u, m.point)
            key = (u.scene.object_config.family, link)
            counts[key] = counts.get(key, 0) + 1
            if angle > P95_EDGE_DEG:
                off.append((key, angle, distance, width, corner))

        run(env_id, episodes, steps, seed, on_accept=on_accept)
        print(f"{env_id} {name} ({episodes} episodes): {sum(counts.values())} accepted")
        for key, n in sorted(counts.items()):
            bad = [o for o in off if o[0] == key]
            print(f"  {key[0]} {key[1]} link: {n} accepted, {len(bad)} > 5 deg")
            for _, angle, distance, width, corner in bad:
                print(
                    f"    {angle:5.1f} deg, {1e3 * distance:.1f} mm from the line; face"
                    f" {1e3 * width:.0f} mm wide, contact {1e3 * corner:.1f} mm from a corner"
                )


if __name__ == "__main__":
    import sys

    if sys.argv[1:2] == ["where"]:
        for env_id in sys.argv[2:] or tactile_gym.JOINT_ENV_IDS[:2]:
            where(env_id)
    else:
        by_kind()
