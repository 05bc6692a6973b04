"""Reset randomisation: the object, its joint angle and the fingertip's start pose.

Frames and units: world frame (z up, table at z = 0), metres, radians. Every draw comes from the
generator handed in (the env's ``np_random``).

The fingertip starts a few millimetres off the free link's probed edge, its finger axis
pointing at the edge: mostly down onto the top face, tilted ``approach_tilt`` toward the probed
side. That is where the paper's protocol starts ("the fingertip touches the right grip"); it
reveals one edge line but nothing about the hinge. A press from there holds the link still
(the joint's holding torque resists it), and a small shear across the edge makes the edge
observable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing import FingertipGeometry
from tactile_gym.sim import ObjectConfig
from tactile_gym.sim.config import FAMILIES
from tactile_gym.spatial import matrix_to_quaternion, z_to

__all__ = [
    "FAMILIES",
    "Scenario",
    "ScenarioConfig",
    "probed_edge",
    "quaternion_z_to",
    "sample_scenario",
]


@dataclass(frozen=True)
class ScenarioConfig:
    """Ranges of the reset randomisation (uniform draws).

    Attributes:
        joint_angle_range: initial joint angle, rad (clipped to the joint limits).
        size_scale_range: factor on the free link's length and width.
        position_jitter: largest horizontal offset of the hinge from the family default, m.
        yaw_range: rotation of the whole layout about world z, rad (scissors keep the paper's
            layout at 0).
        tilt_range: tilt of the ``tilted`` family's axis from vertical, rad.
        start_along_range: where along the free link the fingertip starts, as a fraction of
            the link's length from the hinge.
        standoff_range: gap between the skin and the edge at the start, m.
        approach_tilt: angle of the finger axis from the top face's normal, toward the
            probed side face, rad.
        approach_jitter: largest random change of ``approach_tilt``, rad.
        holding_torque: the joint's holding friction, N m: enough that a 5 N press does not
            turn the link, little enough that a push of a few newtons does.
    """

    joint_angle_range: tuple[float, float] = (-0.35, 0.35)
    size_scale_range: tuple[float, float] = (0.85, 1.15)
    position_jitter: float = 0.01
    yaw_range: tuple[float, float] = (-np.pi, np.pi)
    tilt_range: tuple[float, float] = (np.deg2rad(10.0), np.deg2rad(30.0))
    start_along_range: tuple[float, float] = (0.45, 0.75)
    standoff_range: tuple[float, float] = (0.002, 0.005)
    approach_tilt: float = float(np.deg2rad(10.0))
    approach_jitter: float = float(np.deg2rad(3.0))
    holding_torque: float = 0.1

    def __post_init__(self) -> None:
        for name in (
            "joint_angle_range",
            "size_scale_range",
            "yaw_range",
            "tilt_range",
            "start_along_range",
            "standoff_range",
        ):
            lo, hi = getattr(self, name)
            if not lo <= hi:
                raise ValueError(f"{name} must be (low, high) with low <= high, got {(lo, hi)}")
        if not (0 < self.size_scale_range[0]):
            raise ValueError(f"size_scale_range must be > 0, got {self.size_scale_range}")
        if not (0 < self.start_along_range[0] and self.start_along_range[1] <= 1):
            raise ValueError(f"start_along_range must lie in (0, 1], got {self.start_along_range}")
        if not 0 <= self.approach_tilt < np.pi / 2:
            raise ValueError(f"approach_tilt must be in [0, pi/2) rad, got {self.approach_tilt}")
        if not (self.standoff_range[0] >= 0):
            raise ValueError(f"standoff_range must be >= 0 m, got {self.standoff_range}")
        for name in ("position_jitter", "approach_jitter", "holding_torque"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class Scenario:
    """One episode's start: the object, its joint angle and the fingertip pose (world)."""

    object_config: ObjectConfig
    joint_angle: float
    fingertip_position: np.ndarray
    fingertip_orientation: np.ndarray


def probed_edge(config: ObjectConfig, joint_angle: float) -> tuple[np.ndarray, ...]:
    """Geometry of the free link's probed edge at a joint angle, world frame.

    Returns:
        (origin, direction, side_normal, top_normal): the point of the edge line level with
        the hinge pin, the unit edge direction pointing away from the hinge, and the outward
        unit normals of the two faces that meet at the edge (the side face and the top face).
    """
    rotation = config.hinge_rotation()
    x_h, y_h, z_h = rotation.T
    c, s = np.cos(joint_angle), np.sin(joint_angle)
    x_r = c * x_h + s * y_h
    y_r = -s * x_h + c * y_h
    size = np.asarray(config.free_link_size)
    side = config.edge_side
    origin = np.asarray(config.joint_position) + side * 0.5 * size[1] * y_r + 0.5 * size[2] * z_h
    return origin, x_r, side * y_r, z_h


def quaternion_z_to(direction: np.ndarray) -> np.ndarray:
    """The xyzw quaternion that turns +z onto ``direction`` (a unit vector)."""
    return matrix_to_quaternion(z_to(direction))


def _sample_object(family: str, rng: np.random.Generator, cfg: ScenarioConfig) -> ObjectConfig:
    nominal = ObjectConfig.family_default(family)
    size = np.asarray(nominal.free_link_size, dtype=float)
    size[:2] *= rng.uniform(*cfg.size_scale_range, size=2)
    position = np.asarray(nominal.joint_position, dtype=float)
    position[:2] += rng.uniform(-cfg.position_jitter, cfg.position_jitter, size=2)
    overrides = {
        "free_link_size": tuple(size),
        "joint_position": tuple(position),
        "holding_torque": cfg.holding_torque,
    }
    if family != "scissors":
        yaw = rng.uniform(*cfg.yaw_range)
        turn = np.array(
            [[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]]
        )
        axis = np.asarray(nominal.axis, dtype=float)
        link = np.asarray(nominal.link_direction, dtype=float)
        if family == "tilted":
            tilt = rng.uniform(*cfg.tilt_range)
            axis = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
            link = np.array([0.0, 1.0, 0.0])
        overrides["axis"] = tuple(turn @ axis)
        overrides["link_direction"] = tuple(turn @ link)
    return ObjectConfig.family_default(family, **overrides)


def sample_scenario(
    rng: np.random.Generator,
    families: tuple[str, ...],
    cfg: ScenarioConfig,
    geometry: FingertipGeometry,
    randomize: bool = True,
) -> Scenario:
    """Draw one episode's start; with ``randomize=False`` return the nominal one."""
    if randomize:
        family = families[int(rng.integers(len(families)))]
        object_config = _sample_object(family, rng, cfg)
        angle = rng.uniform(*cfg.joint_angle_range)
        along = rng.uniform(*cfg.start_along_range)
        standoff = rng.uniform(*cfg.standoff_range)
    else:
        object_config = ObjectConfig.family_default(families[0], holding_torque=cfg.holding_torque)
        angle = 0.0
        along = float(np.mean(cfg.start_along_range))
        standoff = float(np.mean(cfg.standoff_range))
    angle = float(np.clip(angle, object_config.lower_limit, object_config.upper_limit))
    origin, direction, side_normal, top_normal = probed_edge(object_config, angle)
    length = object_config.free_link_size[0] - object_config.pin_overlap
    tilt = cfg.approach_tilt
    if randomize and cfg.approach_jitter > 0:
        tilt += rng.uniform(-cfg.approach_jitter, cfg.approach_jitter)
    # Mostly onto the face that looks up, tilted toward the other face: a press that does not
    # turn the link, and where a small shear across the edge makes the edge observable.
    if side_normal[2] > top_normal[2]:
        top_normal, side_normal = side_normal, top_normal
    outward = np.cos(tilt) * top_normal + np.sin(tilt) * side_normal
    edge_point = origin + along * length * direction
    centre = edge_point + outward * (geometry.outer_radius + standoff)
    finger_axis = -outward
    position = centre - geometry.cylinder_length * finger_axis
    return Scenario(object_config, angle, position, quaternion_z_to(finger_axis))
