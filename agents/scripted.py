"""Scripted baseline: the paper's probing protocol, adapted to what the physics allows.

The paper presses the fingertip on the free link's edge at 5 N, measures, lifts, turns the
link by 30 degrees by hand, and repeats. In simulation the fingertip must turn the link
itself, and the physics sets the rules (DESIGN.md 2.1-2.2, confirmed in ``ProbeScene``):

* a plain press says nothing about the edge;
* a sticking shear tilts the force, and the wrench then gives the direction perpendicular
  to the *shear* (a shear 5 deg off the across-edge direction gives an edge about 10 deg
  off), so a shear only measures the edge well when it is made across the edge, and not
  straight after a slide along it (the skin is still loaded along the edge);
* a slide along the edge keeps the contact on the edge whatever the slide's own direction,
  so a line through the contact points measures the edge independently (the env's ``trace``
  measurements);
* while the link is being pushed round, the contact slides along the edge and the wrench
  gives a confidently wrong edge; the env's gate rejects such moving contacts.

Each stop is therefore:

1. ``approach``: move straight down until the skin touches;
2. ``press``: advance to ``press_force``;
3. ``slide``: slide ``slide_distance`` along the edge while holding the force (alternately
   toward and away from the hinge), and fit a line through the contact points: the edge as
   this stop sees it, and the env's ``trace`` measurements;
4. move round to the link's side (``goto``) and ``push`` it round by about ``stop_angle``,
   steering the push with the turn; the push distance comes from the lever arm estimated
   from the turns measured so far. Where the link holds, the push is a sticking press
   across the edge, which gives wrench measurements;
5. move back above the edge where the push left it, and start the next stop.

The policy reads only the observation (wrench, fingertip pose, contact estimate) and the
documented layout of ``HingeProbe-v0``: the fingertip starts a few millimetres above the free
link's edge, pointing at it, and the free link points from its hinge toward world +x
(within +-20 deg). It never reads the true axis or the simulator.

    python -m agents.scripted --episodes 5
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing import edge_from_trace
from tactile_gym.spatial import quaternion_to_matrix, rotvec_to_matrix

__all__ = ["ScriptedConfig", "ScriptedProbePolicy"]

Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ScriptedConfig:
    """Parameters of the scripted protocol (SI units).

    Attributes:
        press_force: force of a measuring press, N (the paper's 5 N).
        contact_force: force that ends the approach, N.
        push_force: force above which the push waits for the link to move, N. A push that
            waits is a sticking press across the edge, which the env measures; a push that
            turns the link is not measured (the contact moves).
        stall_steps: control steps a push may wait before it is cut short.
        force_gain: advance per newton of force error, m/N.
        slide_distance: slide along the edge at each stop, m.
        slide_step: slide per control step, m.
        stop_angle: turn of the link between stops, rad (the paper's 30 deg).
        n_stops: number of measuring stops.
        nominal_lever: assumed distance from the hinge to the pushed point before a turn has
            been measured, m.
        lift_height: rise above the edge when moving round the link, m.
        clearance: gap kept between the skin and the link when moving round it, m.
        table_clearance: least height of the skin above the table, m.
        hinge_direction: horizontal direction from the free link toward its hinge in the
            documented layout (world).
    """

    press_force: float = 5.0
    contact_force: float = 1.0
    push_force: float = 6.5
    stall_steps: int = 6
    force_gain: float = 0.0003
    slide_distance: float = 0.012
    slide_step: float = 0.001
    stop_angle: float = float(np.deg2rad(30.0))
    n_stops: int = 4
    nominal_lever: float = 0.055
    lift_height: float = 0.004
    clearance: float = 0.002
    table_clearance: float = 0.0015
    hinge_direction: tuple[float, float, float] = (-1.0, 0.0, 0.0)


class ScriptedProbePolicy:
    """A state machine from observations to normalised actions.

    Args:
        max_translation: the env's translation for an action of 1, m.
        max_rotation: the env's rotation for an action of 1, rad.
        tip_center: hemisphere centre in the sensor frame, m.
        outer_radius: outer skin radius, m.
        config: protocol parameters.
    """

    def __init__(
        self,
        max_translation: float,
        max_rotation: float,
        tip_center: np.ndarray,
        outer_radius: float,
        config: ScriptedConfig = ScriptedConfig(),  # noqa: B008 - frozen dataclass
    ) -> None:
        self.max_translation = float(max_translation)
        self.max_rotation = float(max_rotation)
        self.tip_center = np.asarray(tip_center, dtype=float)
        self.outer_radius = float(outer_radius)
        self.config = config
        self.reset()

    @classmethod
    def for_env(cls, env, config: ScriptedConfig = ScriptedConfig()):  # noqa: B008
        """A policy scaled to a ``HingeProbeEnv`` (pass ``env.unwrapped``)."""
        return cls(
            env.config.max_translation,
            env.config.max_rotation,
            env.geometry.sphere_center,
            env.geometry.outer_radius,
            config,
        )

    def reset(self) -> None:
        """Start a new episode."""
        self.state = "approach"
        self.stops_done = 0
        self._heading: np.ndarray | None = None  # horizontal, across the edge, into the link
        self._tilt = 0.0  # finger axis from straight down, rad
        self._edges: list[np.ndarray] = []  # edge of each stop, horizontal, away from hinge
        self._pushes: list[float] = []  # push distance before each later stop, m
        self._trace: list[np.ndarray] = []
        self._waypoints: list[np.ndarray] = []
        self._after_waypoints = "approach"
        self._counter = 0
        self._rim = np.zeros(3)
        self._pushed = 0.0
        self._push_goal = 0.0
        self._push_heading = np.zeros(3)
        self._tip = np.zeros(3)

    # ------------------------------------------------------------------ main loop
    def get_action(self, obs: dict) -> np.ndarray:
        """The normalised action for a dict observation of ``HingeProbeEnv``."""
        cfg = self.config
        pose = np.asarray(obs["fingertip_pose"], dtype=float)
        rotation = quaternion_to_matrix(pose[3:7])
        axis = rotation[:, 2]
        tip = pose[:3] + rotation @ self.tip_center
        force = float(np.linalg.norm(obs["wrench"][:3]))
        contact = np.asarray(obs["contact"], dtype=float)
        touching = contact[0] > 0.5
        self._tip = tip
        if self._heading is None:
            self._heading = _horizontal(axis)
            self._tilt = float(np.arccos(np.clip(-axis @ Z, -1.0, 1.0)))
        h = self._heading
        move = np.zeros(3)
        rotvec = np.zeros(3)

        if self.state == "approach":
            move = -Z * 0.001
            if force > cfg.contact_force:
                self.state = "press"
        elif self.state == "press":
            move = -Z * self._force_step(force)
            if abs(force - cfg.press_force) < 0.5:
                self.state, self._counter, self._trace = "slide", 0, []
        elif self.state == "slide":
            move = self._slide_direction() * cfg.slide_step - Z * self._force_step(force)
            if touching:
                self._trace.append(contact[1:4].copy())
                self._rim = contact[1:4].copy()
            self._counter += 1
            if self._counter * cfg.slide_step >= cfg.slide_distance:
                self._finish_slide()
                self._finish_stop()
        elif self.state == "goto":
            move, done = self._follow_waypoints(tip)
            turn = _signed_angle(_horizontal(axis), h)
            rotvec = Z * float(np.clip(turn, -self.max_rotation, self.max_rotation))
            if done and abs(turn) < np.deg2rad(0.5):
                self.state = self._after_waypoints
        elif self.state == "push":
            move = self._push_step(force, touching, contact, tip)

        if self.state != "done":
            low = self.outer_radius + cfg.table_clearance
            if tip[2] + move[2] < low:
                move[2] = low - tip[2]
        action = np.r_[move / self.max_translation, rotvec / self.max_rotation]
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    # ------------------------------------------------------------------ phases
    def _force_step(self, force: float) -> float:
        error = self.config.press_force - force
        return float(np.clip(self.config.force_gain * error, -1e-3, 1e-3))

    def _slide_direction(self) -> np.ndarray:
        """Along the edge, alternately toward and away from the hinge (stays mid-link)."""
        along = np.cross(Z, self._heading)
        toward_hinge = -self._edges[-1] if self._edges else np.asarray(self.config.hinge_direction)
        if self.stops_done % 2:
            toward_hinge = -toward_hinge
        return along if along @ toward_hinge >= 0 else -along

    def _finish_slide(self) -> None:
        """Fit the edge through the slide's contact points and face across it."""
        if len(self._trace) < 3:
            return
        direction, _ = edge_from_trace(np.asarray(self._trace), point_std=2e-4)
        if not np.all(np.isfinite(direction)):
            return
        edge = _horizontal(direction)
        across = np.cross(Z, edge)
        self._heading = across if across @ self._heading >= 0 else -across
        away = -np.asarray(self.config.hinge_direction) if not self._edges else self._edges[-1]
        self._edges.append(edge if edge @ away >= 0 else -edge)

    def _finish_stop(self) -> None:
        cfg = self.config
        self.stops_done += 1
        if self.stops_done >= cfg.n_stops:
            self.state = "done"
            return
        self._push_goal = self._lever() * cfg.stop_angle
        self._push_heading = self._heading
        h = self._heading
        low = self.outer_radius + cfg.table_clearance
        above = self._tip + Z * cfg.lift_height
        outside = np.r_[(self._rim - h * (self.outer_radius + cfg.clearance))[:2], above[2]]
        self._waypoints = [above, outside, np.r_[outside[:2], low]]
        self._after_waypoints = "push"
        self.state, self._pushed, self._counter = "goto", 0.0, 0

    def _push_step(self, force: float, touching: bool, contact: np.ndarray, tip: np.ndarray):
        cfg = self.config
        speed = self.max_translation if force < 0.3 else (0.0015 if force < cfg.push_force else 0.0)
        self._counter = self._counter + 1 if speed == 0.0 else 0
        if force >= 0.3:
            self._pushed += speed
            if touching:
                self._rim = contact[1:4].copy()
        heading = self._turned_heading(self._pushed)
        stalled = self._counter >= cfg.stall_steps
        missed = (self._rim - tip) @ heading < -0.01
        if stalled or missed or self._pushed >= self._push_goal:
            self._pushes.append(self._pushed)
            self._heading = heading
            above = self._rim + Z * (self.outer_radius + cfg.lift_height)
            finger = -np.cos(self._tilt) * Z + np.sin(self._tilt) * heading
            ready = self._rim - finger * (self.outer_radius + 0.003)
            self._waypoints = [tip - heading * 0.003, above - heading * 0.003, ready]
            self._after_waypoints = "approach"
            self.state = "goto"
        return heading * speed

    def _follow_waypoints(self, tip: np.ndarray) -> tuple[np.ndarray, bool]:
        while self._waypoints and np.linalg.norm(self._waypoints[0] - tip) < 3e-4:
            self._waypoints.pop(0)
        if not self._waypoints:
            return np.zeros(3), True
        error = self._waypoints[0] - tip
        return error * min(1.0, self.max_translation / np.linalg.norm(error)), False

    # ------------------------------------------------------------------ geometry
    def _lever(self) -> float:
        """Distance from the hinge to the pushed point, from the turns measured so far."""
        turns = [np.arccos(np.clip(a @ b, -1.0, 1.0)) for a, b in zip(self._edges, self._edges[1:])]
        levers = [p / t for p, t in zip(self._pushes, turns) if t > np.deg2rad(3.0)]
        if not levers:
            return self.config.nominal_lever
        return float(np.clip(np.median(levers), 0.02, 0.12))

    def _turned_heading(self, pushed: float) -> np.ndarray:
        """The push heading once a push of ``pushed`` metres has turned the link."""
        h = self._push_heading
        if not self._edges:
            return h
        # Pushing along h at a point on the link turns it so that the point moves along h.
        sign = np.sign(np.cross(self._edges[-1], h) @ Z) or 1.0
        return rotvec_to_matrix(Z * sign * pushed / self._lever()) @ h


def _signed_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle from horizontal unit vector a to b about world z, rad."""
    return float(np.arctan2(np.cross(a, b) @ Z, a @ b))


def _horizontal(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    v = v - (v @ Z) * Z
    return v / max(np.linalg.norm(v), 1e-12)


def main(argv: list[str] | None = None) -> None:
    import gymnasium as gym

    import tactile_gym  # noqa: F401 - registers the envs

    parser = argparse.ArgumentParser(description="Run the scripted baseline and print errors.")
    parser.add_argument("--env", default="tactile_gym/HingeProbe-v0")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    env = gym.make(args.env)
    policy = ScriptedProbePolicy.for_env(env.unwrapped)
    for k in range(args.episodes):
        obs, info = env.reset(seed=args.seed + k)
        policy.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
            done = terminated or truncated
        print(
            f"seed {args.seed + k}: position error {info['position_error'] * 1e3:.1f} mm, "
            f"angle error {np.degrees(info['angle_error']):.2f} deg, "
            f"{info['n_measurements']} measurements, joint angle "
            f"{np.degrees(info['joint_angle']):.0f} deg, success {info['is_success']}"
        )
    env.close()


if __name__ == "__main__":
    main()
