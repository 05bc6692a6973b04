"""Scripted baseline: the paper's probing protocol, adapted to what the physics allows.

The paper presses the fingertip on the free link's edge at 5 N, measures, lifts, turns the
link by 30 degrees by hand, and repeats. In simulation the fingertip must turn the link
itself, and the physics sets two rules (DESIGN.md 2.1-2.2, confirmed in ``ProbeScene``):

* a plain press says nothing about the edge; a small *sticking shear across the edge* tilts
  the force and makes the edge observable (about 1-2 deg of error);
* while the link is being pushed round, the contact slides *along* the edge and the wrench
  gives a confidently wrong edge (75-90 deg). The env's gate rejects contacts that move that
  fast, so only the shear probes become measurements.

Each stop is therefore:

1. ``approach``: move straight down until the skin touches (a vertical approach adds no
   tilt of its own to the force);
2. ``press``: advance to ``press_force``;
3. ``shear``: slide the fingertip ``shear_distance`` across the edge (away from the link)
   while holding the force; the env's gate takes the measurement here;
4. ``lift``, ``backoff``, ``descend``: rise, step back off the link and come down beside it;
5. ``push``: push the link round by about ``stop_angle`` (the push distance comes from the
   lever arm estimated from the turns measured so far);
6. ``retreat``, ``reposition``: back off, rise, and return above the edge where the push
   left it, then start the next stop.

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
from scipy.spatial.transform import Rotation

__all__ = ["ScriptedConfig", "ScriptedProbePolicy"]

Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ScriptedConfig:
    """Parameters of the scripted protocol (SI units).

    Attributes:
        press_force: force of a measuring press, N (the paper's 5 N).
        contact_force: force that ends the approach, N.
        push_force: force above which the push waits for the link to move, N; below the
            gate's force band, so a push that stalls gives no measurement.
        force_gain: advance along the finger axis per newton of force error, m/N.
        shear_distance: sideways slide across the edge during a measuring press, m.
        shear_steps: control steps over which the shear is spread.
        stop_angle: turn of the link between stops, rad (the paper's 30 deg).
        n_stops: number of measuring presses.
        nominal_lever: assumed distance from the hinge to the contact before a turn has been
            measured, m.
        lift_height: rise after a measuring press, m.
        clearance: gap kept between the skin and the link when moving round it, m.
        table_clearance: least height of the skin above the table, m.
        hinge_direction: horizontal direction from the free link toward its hinge in the
            documented layout (world).
    """

    press_force: float = 5.0
    contact_force: float = 1.0
    push_force: float = 2.8
    force_gain: float = 0.0003
    shear_distance: float = 0.0008
    shear_steps: int = 4
    stop_angle: float = float(np.deg2rad(30.0))
    n_stops: int = 4
    nominal_lever: float = 0.055
    lift_height: float = 0.006
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
        self._edges: list[np.ndarray] = []  # edge measured at each stop (horizontal)
        self._pushes: list[float] = []  # push distance before each later stop, m
        self._shear_edges: list[np.ndarray] = []
        self._counter = 0
        self._rim = np.zeros(3)
        self._target = np.zeros(3)
        self._pushed = 0.0
        self._push_goal = 0.0

    # ------------------------------------------------------------------ main loop
    def get_action(self, obs: dict) -> np.ndarray:
        """The normalised action for a dict observation of ``HingeProbeEnv``."""
        cfg = self.config
        pose = np.asarray(obs["fingertip_pose"], dtype=float)
        rotation = Rotation.from_quat(pose[3:7]).as_matrix()
        axis = rotation[:, 2]
        tip = pose[:3] + rotation @ self.tip_center
        force = float(np.linalg.norm(obs["wrench"][:3]))
        contact = np.asarray(obs["contact"], dtype=float)
        if self._heading is None:
            self._heading = _horizontal(axis)
        h = self._heading
        step = self.max_translation
        move = np.zeros(3)
        rotvec = np.zeros(3)

        if self.state == "approach":
            move = -Z * min(step, 0.001)
            if force > cfg.contact_force:
                self.state = "press"
        elif self.state == "press":
            move = -Z * self._force_step(force)
            if abs(force - cfg.press_force) < 0.5:
                self.state, self._counter, self._shear_edges = "shear", 0, []
        elif self.state == "shear":
            move = -h * cfg.shear_distance / cfg.shear_steps - Z * self._force_step(force)
            self._collect_edge(contact)
            self._counter += 1
            if contact[0] > 0.5:
                self._rim = contact[1:4].copy()
            if self._counter >= cfg.shear_steps:
                self._finish_stop()
        elif self.state == "lift":
            move = Z * step
            if tip[2] >= self._target[2]:
                self.state = "backoff"
        elif self.state == "backoff":
            move = -h * step
            if (self._rim - tip) @ h >= self.outer_radius + cfg.clearance:
                self.state = "descend"
        elif self.state == "descend":
            low = self.outer_radius + cfg.table_clearance
            move = -Z * min(step, tip[2] - low)
            if tip[2] - low < 2e-4:
                self.state, self._pushed = "push", 0.0
        elif self.state == "push":
            speed = step if force < 0.3 else (0.0015 if force < cfg.push_force else 0.0)
            move = h * speed
            if force >= 0.3:
                self._pushed += speed
                if contact[0] > 0.5:
                    self._rim = contact[1:4].copy()
            if self._pushed >= self._push_goal or (self._rim - tip) @ h < -0.01:
                self.state, self._counter = "retreat", 0
                self._pushes.append(self._pushed)
        elif self.state == "retreat":
            move = -h * step + Z * step
            self._counter += 1
            if self._counter >= 3:
                self.state = "reposition"
                self._heading = self._predict_heading()
                h = self._heading
                tilt = np.arccos(np.clip(-axis @ Z, -1.0, 1.0))
                finger = -np.cos(tilt) * Z + np.sin(tilt) * h
                self._target = self._rim - finger * (self.outer_radius + 0.003)
        elif self.state == "reposition":
            error = self._target - tip
            move = error * min(1.0, step / max(np.linalg.norm(error), 1e-9))
            turn = _signed_angle(_horizontal(axis), h)
            rotvec = Z * float(np.clip(turn, -self.max_rotation, self.max_rotation))
            if np.linalg.norm(error) < 5e-4 and abs(turn) < np.deg2rad(0.5):
                self.state = "approach"
        if self.state != "done":
            low = self.outer_radius + cfg.table_clearance
            if tip[2] + move[2] < low:
                move[2] = low - tip[2]
        action = np.r_[move / self.max_translation, rotvec / self.max_rotation]
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    # ------------------------------------------------------------------ helpers
    def _force_step(self, force: float) -> float:
        return float(
            np.clip(self.config.force_gain * (self.config.press_force - force), -1e-3, 1e-3)
        )

    def _collect_edge(self, contact: np.ndarray) -> None:
        if contact[0] > 0.5 and contact[10] < np.deg2rad(6.0):
            edge = _horizontal(contact[7:10])
            if self._shear_edges and edge @ self._shear_edges[0] < 0:
                edge = -edge
            self._shear_edges.append(edge)

    def _finish_stop(self) -> None:
        cfg = self.config
        if self._shear_edges:
            edge = _horizontal(np.mean(self._shear_edges, axis=0))
            hinge = np.asarray(cfg.hinge_direction)
            if edge @ hinge > 0:
                edge = -edge  # point away from the hinge
            self._edges.append(edge)
            across = np.cross(Z, edge)
            self._heading = across if across @ self._heading >= 0 else -across
        self.stops_done += 1
        if self.stops_done >= cfg.n_stops:
            self.state = "done"
            return
        self._push_goal = self._lever() * cfg.stop_angle
        self.state = "lift"
        self._target = self._rim + Z * (cfg.lift_height + self.outer_radius)

    def _lever(self) -> float:
        """Distance from the hinge to the pushed point, from the turns measured so far."""
        turns = [np.arccos(np.clip(a @ b, -1.0, 1.0)) for a, b in zip(self._edges, self._edges[1:])]
        levers = [p / t for p, t in zip(self._pushes, turns) if t > np.deg2rad(3.0)]
        if not levers:
            return self.config.nominal_lever
        return float(np.clip(np.median(levers), 0.02, 0.12))

    def _predict_heading(self) -> np.ndarray:
        """Heading after the last push: the link turned by push / lever about its hinge."""
        h = self._heading
        if not self._edges:
            return h
        away = self._edges[-1]
        # Pushing along h at a point on the link turns it so that the point moves along h.
        sign = np.sign(np.cross(away, h) @ Z) or 1.0
        angle = sign * self._pushes[-1] / self._lever()
        return Rotation.from_rotvec(Z * angle).apply(h)


def _signed_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle from horizontal unit vector a to b about world z, rad."""
    return float(np.arctan2(np.cross(a, b) @ Z, a @ b))


def _horizontal(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float) - (np.asarray(v, dtype=float) @ Z) * Z
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
