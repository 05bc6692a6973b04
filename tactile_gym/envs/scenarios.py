"""Reset randomisation: the object, its joint coordinate and the fingertip's start pose.

Frames and units: world frame (z up, table at z = 0), metres, radians. Every draw comes from the
generator handed in (the env's ``np_random``).

What the start reveals, and what it must not (the brief's "ground truth stays out"): the
fingertip starts a few millimetres above the face of the free link that looks up, near its
probed edge, like the paper's operator who brings the fingertip near the grip. Everything else
is drawn so that the first observation does not encode the edge: where along the link, how far
across the edge (over the face or beyond it), the height, and the direction in which the
finger leans (uniform in azimuth). The policy finds the edge by touch (``docs/design.md`` 7.7,
8).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from tactile_gym.estimation import AxisPrior
from tactile_gym.perception.gate import line_distance
from tactile_gym.sensing import FingertipGeometry
from tactile_gym.sim import ObjectConfig
from tactile_gym.sim.config import FAMILIES
from tactile_gym.spatial import matrix_to_quaternion, rotvec_to_matrix, z_to
from tactile_gym.validation import check_choice, check_number, check_range

__all__ = [
    "FAMILIES",
    "PRIOR_SAMPLES",
    "Scenario",
    "ScenarioConfig",
    "probed_edge",
    "reset_distribution_prior",
    "sample_scenario",
]

_DEG = np.pi / 180.0
#: Scenario draws behind the prior (the reset distribution's), from a fixed seed.
PRIOR_SAMPLES = 512


@dataclass(frozen=True)
class ScenarioConfig:
    """Ranges of the reset randomisation (uniform draws).

    Attributes:
        joint_angle_range: initial joint angle of a revolute joint, rad (clipped to the
            object's joint limits).
        travel_range: initial travel of a prismatic joint, m (clipped likewise).
        size_scale_range: factor on the sizes of the free link's probed face (a hinged
            link's length and width, a slide's front edge and depth).
        position_jitter: largest horizontal offset of the hinge from the family default, m.
        yaw_range: rotation of the whole layout about world z, rad, except for the families
            of ``fixed_layouts``.
        fixed_layouts: families that keep their preset's layout (the scissors: the paper's,
            their free link pointing from the hinge toward world +x).
        tilt_range: tilt of the ``tilted`` family's axis from vertical, and of the
            ``tilted_drawer``'s travel from horizontal, rad.
        face_height_range: None, or the height of the probed edge above the table at the
            start's joint coordinate 0, m: the object is then lifted or lowered to a height
            drawn from it, whatever its family's preset says (so that the start's height
            does not tell the families apart).
        start_along_range: where along the free link the fingertip starts, as a fraction of
            the link's length from the hinge.
        start_across_range: signed distance of the hemisphere centre from the probed edge,
            across it, in the plane of the face that looks up, m: negative over the face,
            positive beyond the edge.
        start_height_range: gap between the skin and the face's plane at the start, m.
        lean_range: angle of the finger axis from straight down onto the face, rad; the
            direction of the lean is uniform in azimuth.
    """

    joint_angle_range: tuple[float, float] = (-20 * _DEG, 20 * _DEG)
    travel_range: tuple[float, float] = (-0.01, 0.01)
    size_scale_range: tuple[float, float] = (0.85, 1.15)
    position_jitter: float = 0.01
    yaw_range: tuple[float, float] = (-np.pi, np.pi)
    fixed_layouts: tuple[str, ...] = ("scissors",)
    tilt_range: tuple[float, float] = (10 * _DEG, 30 * _DEG)
    face_height_range: tuple[float, float] | None = None
    start_along_range: tuple[float, float] = (0.45, 0.75)
    start_across_range: tuple[float, float] = (-0.004, 0.003)
    start_height_range: tuple[float, float] = (0.002, 0.005)
    lean_range: tuple[float, float] = (0.0, 15 * _DEG)

    def __post_init__(self) -> None:
        check_range("scenario.joint_angle_range", self.joint_angle_range, -np.pi, np.pi)
        check_range("scenario.travel_range", self.travel_range, -0.2, 0.2)
        layouts = self.fixed_layouts
        layouts = (layouts,) if isinstance(layouts, str) else layouts
        if not isinstance(layouts, (tuple, list)):
            raise ValueError(f"scenario.fixed_layouts must be a list of families, got {layouts!r}")
        for family in layouts:
            check_choice("scenario.fixed_layouts[...]", family, FAMILIES)
        object.__setattr__(self, "fixed_layouts", tuple(layouts))
        if self.face_height_range is not None:
            check_range("scenario.face_height_range", self.face_height_range, 0.0, 0.5)
        check_range("scenario.size_scale_range", self.size_scale_range, 0.5, 2.0)
        check_number("scenario.position_jitter", self.position_jitter, 0.0, 0.05)
        check_range("scenario.yaw_range", self.yaw_range, -np.pi, np.pi)
        check_range("scenario.tilt_range", self.tilt_range, 0.0, 60 * _DEG)
        check_range("scenario.start_along_range", self.start_along_range, 0.1, 0.95)
        check_range("scenario.start_across_range", self.start_across_range, -0.01, 0.006)
        check_range("scenario.start_height_range", self.start_height_range, 0.0005, 0.02)
        check_range("scenario.lean_range", self.lean_range, 0.0, 45 * _DEG)


@dataclass(frozen=True)
class Scenario:
    """One episode's start: the object, its joint angle and the fingertip pose (world)."""

    object_config: ObjectConfig
    joint_angle: float
    fingertip_position: np.ndarray
    fingertip_orientation: np.ndarray


def probed_edge(config: ObjectConfig, joint_angle: float) -> tuple[np.ndarray, ...]:
    """Geometry of the free link's probed edge at a joint coordinate (rad, or m for a slide),
    world frame (ground truth).

    Returns:
        (origin, direction, side_normal, top_normal): the point of the edge line level with
        the hinge pin, the unit edge direction pointing away from the hinge, and the outward
        unit normals of the two faces that meet at the edge (the side face and the top face).
    """
    rotation = config.hinge_rotation()
    x_h, y_h, z_h = rotation.T
    origin = np.asarray(config.joint_position, dtype=float)
    if config.joint_type == "revolute":
        c, s = np.cos(joint_angle), np.sin(joint_angle)
        x_h, y_h = c * x_h + s * y_h, -s * x_h + c * y_h
    elif config.joint_type == "prismatic":
        origin = origin + joint_angle * z_h
    size = np.asarray(config.free_link_size)
    side = config.edge_side
    origin = origin + side * 0.5 * size[1] * y_h + 0.5 * size[2] * z_h
    return origin, x_h, side * y_h, z_h


def _sample_object(
    family: str, rng: np.random.Generator, cfg: ScenarioConfig, overrides: dict
) -> ObjectConfig:
    nominal = ObjectConfig.family_default(family, **overrides)
    size = np.asarray(nominal.free_link_size, dtype=float)
    # The probed face's two sizes: a slide's face spans x_H and its travel, z_H.
    face = [0, 2] if nominal.joint_type == "prismatic" else [0, 1]
    size[face] *= rng.uniform(*cfg.size_scale_range, size=2)
    position = np.asarray(nominal.joint_position, dtype=float)
    position[:2] += rng.uniform(-cfg.position_jitter, cfg.position_jitter, size=2)
    drawn = {"free_link_size": tuple(size), "joint_position": tuple(position)}
    if family not in cfg.fixed_layouts:
        turn = rotvec_to_matrix([0.0, 0.0, rng.uniform(*cfg.yaw_range)])
        axis = np.asarray(nominal.axis, dtype=float)
        link = np.asarray(nominal.link_direction, dtype=float)
        if family == "tilted":
            tilt = rng.uniform(*cfg.tilt_range)
            axis = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
            link = np.array([0.0, 1.0, 0.0])
        elif family == "tilted_drawer":
            tilt = rng.uniform(*cfg.tilt_range)
            axis = np.array([0.0, np.cos(tilt), np.sin(tilt)])
        drawn["axis"] = tuple(turn @ axis)
        drawn["link_direction"] = tuple(turn @ link)
    config = ObjectConfig.family_default(family, **{**overrides, **drawn})
    if cfg.face_height_range is None:
        return config
    origin = probed_edge(config, 0.0)[0]
    position[2] += rng.uniform(*cfg.face_height_range) - origin[2]
    return dataclasses.replace(config, joint_position=tuple(position))


def _start_pose(
    config: ObjectConfig,
    angle: float,
    along: float,
    across: float,
    height: float,
    lean: float,
    azimuth: float,
    geometry: FingertipGeometry,
) -> tuple[np.ndarray, np.ndarray]:
    """Sensor origin and orientation (xyzw quaternion, as ``ProbeScene.reset`` takes it) for a
    hemisphere centre above the face that looks up; the finger axis is the sensor's +z."""
    origin, direction, side_normal, top_normal = probed_edge(config, angle)
    # The face that looks up is the one the finger starts above; "across" is measured
    # toward the other face's outward normal, i.e. beyond the edge.
    if side_normal[2] > top_normal[2]:
        top_normal, side_normal = side_normal, top_normal
    length = config.free_link_size[0] - config.pin_overlap
    edge_point = origin + along * length * direction
    centre = edge_point + across * side_normal + (geometry.outer_radius + height) * top_normal
    tilt = rotvec_to_matrix(lean * (np.cos(azimuth) * direction + np.sin(azimuth) * side_normal))
    finger_axis = tilt @ -top_normal
    position = centre - geometry.cylinder_length * finger_axis
    return position, matrix_to_quaternion(z_to(finger_axis))


def sample_scenario(
    rng: np.random.Generator,
    families: tuple[str, ...],
    cfg: ScenarioConfig,
    geometry: FingertipGeometry,
    randomize: bool = True,
    object_overrides: dict | None = None,
) -> Scenario:
    """Draw one episode's start; with ``randomize=False`` return the nominal one.

    Args:
        rng: the only source of randomness.
        families: object families to draw from.
        cfg: the ranges.
        geometry: the fingertip.
        randomize: draw (True) or take the middle of every range and the first family.
        object_overrides: ``ObjectConfig`` fields applied to every family before the draws.
    """
    overrides = dict(object_overrides or {})
    if randomize:
        family = families[int(rng.integers(len(families)))]
        object_config = _sample_object(family, rng, cfg, overrides)
        joint_range = {
            "revolute": cfg.joint_angle_range,
            "prismatic": cfg.travel_range,
            "fixed": (0.0, 0.0),
        }[object_config.joint_type]
        draws = [rng.uniform(*r) for r in (joint_range, cfg.start_along_range)]
        draws += [rng.uniform(*r) for r in (cfg.start_across_range, cfg.start_height_range)]
        draws += [rng.uniform(*cfg.lean_range), rng.uniform(-np.pi, np.pi)]
    else:
        object_config = ObjectConfig.family_default(families[0], **overrides)
        draws = [0.0, float(np.mean(cfg.start_along_range))]
        draws += [float(np.mean(r)) for r in (cfg.start_across_range, cfg.start_height_range)]
        draws += [float(np.mean(cfg.lean_range)), 0.0]
    angle = float(np.clip(draws[0], object_config.lower_limit, object_config.upper_limit))
    if object_config.joint_type == "fixed":
        angle = 0.0
    position, orientation = _start_pose(object_config, angle, *draws[1:], geometry)
    return Scenario(object_config, angle, position, orientation)


def reset_distribution_prior(
    families: tuple[str, ...],
    scenario: ScenarioConfig,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: dict,
) -> tuple[AxisPrior, tuple[float, float]]:
    """What is known before touching: the axis prior of a reset distribution, and the
    distance of the probed edge from the axis (mean, std, m; ``MeasurementGate.same_edge``).

    Drawn from ``PRIOR_SAMPLES`` scenarios (one without ``randomize``) of a fixed seed, never
    from an episode. Every env made with the same families, ranges and overrides draws the
    same scenarios, so the result is drawn once per process and shared (its arrays are
    read-only): the draws are most of a ``gym.make``'s time.
    """
    return _drawn_prior(
        tuple(families),
        _frozen(dataclasses.asdict(scenario)),
        geometry,
        bool(randomize),
        _frozen(object_overrides),
    )


@functools.lru_cache(maxsize=64)
def _drawn_prior(
    families: tuple[str, ...],
    scenario: tuple,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: tuple,
) -> tuple[AxisPrior, tuple[float, float]]:
    """``reset_distribution_prior`` of hashable (``_frozen``) arguments."""
    scenario_config = ScenarioConfig(**dict(scenario))
    # A family's own entry (ObjectConfig.family_default) was frozen into item pairs too.
    overrides = {k: dict(v) if k in FAMILIES else v for k, v in object_overrides}
    rng = np.random.default_rng(0)
    pins, directions, distances = [], [], []
    for _ in range(PRIOR_SAMPLES if randomize else 1):
        drawn = sample_scenario(rng, families, scenario_config, geometry, randomize, overrides)
        config = drawn.object_config
        pins.append(config.joint_position)
        directions.append(config.axis)
        origin, edge, _, _ = probed_edge(config, 0.0)
        distances.append(
            line_distance(origin, edge, np.asarray(config.joint_position), config.axis)
        )
    prior = AxisPrior.from_samples(np.array(pins), np.array(directions))
    for array in (prior.pin, prior.pin_cov, prior.direction):
        array.flags.writeable = False
    return prior, (float(np.mean(distances)), float(np.std(distances)))


def _frozen(value: Any) -> Any:
    """A hashable copy of a config value: dicts as sorted item pairs, sequences as tuples."""
    if isinstance(value, dict):
        return tuple(sorted((key, _frozen(item)) for key, item in value.items()))
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_frozen(item) for item in value)
    return value
