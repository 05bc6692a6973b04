"""The world of Table I's reproduction (``agents.reproduce_paper``): the scene under each
condition and what the operator knows of it.

The operator knows only the nominal layout (:class:`NominalLayout`), read off the grip's
documented configuration; the conditions change the world (the shipped env presets), never
the protocol; the F/T sensor is one of ``SENSORS``. The sensing is told the condition's skin
and sensor (:func:`configured`); the world factors (``WORLD_FACTORS``, ``--world``) change the
world only, untold: the skin's stiffness and the sensor's noise and drift a real robot meets
are known to a factor of two at best.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from tactile_gym.presets import load_preset, preset_names
from tactile_gym.sim import ObjectConfig, ProbeScene, SensorConfig, SkinConfig

END_CLEARANCE = 0.012  # m, the first search keeps this far from the grip's free end
START_INSET = 0.005  # m inside the nominal edge, the first search
HAND_HOLD_TORQUE = 2.0  # N m, the hand steadying the grip (the loose hinge: 0.1 N m)

#: The F/T sensors of ``--sensor``: the env's default (realistic), the v1 ids' ideal one, and
#: the ideal one with a constant offset that only a tare removes.
SENSORS = {
    "realistic": SensorConfig(),
    "ideal": SensorConfig.ideal(),
    "offset": SensorConfig.ideal(force_bias=(0.1, 0.1, 0.1), moment_bias=(2e-3, 2e-3, 2e-3)),
}

#: Held-out conditions: a change of the world, the protocol unchanged; the shipped env presets
#: (``configs/env``: the ideal sensor, sensor noise x2, friction 0.3 and 0.8, links of 60 and
#: 150 mm). With another grip the operator's nominal layout is that grip's (it is in plain
#: sight).
CONDITIONS = {"nominal": {}, **{name: load_preset("env", name) for name in preset_names("env")}}


def condition_object(condition: str) -> ObjectConfig:
    """The grip of a condition as documented (its nominal configuration), the hand holding
    it. The joint angle of each trial, the truth, is drawn apart and never told."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {sorted(CONDITIONS)}, got {condition!r}")
    change = CONDITIONS[condition].get("object", {})
    return ObjectConfig.scissors(**{**change, "holding_torque": HAND_HOLD_TORQUE})


@dataclass(frozen=True)
class NominalLayout:
    """What the operator knows of the layout: the documented, not the episode's, geometry.

    Attributes:
        hinge: (2,) hinge pin near here, world x-y, m.
        heading: direction of the free grip at joint angle 0, rad from world +x.
        width: width of the grip, m.
        thickness: thickness of the grip (its top face over the table), m.
        reach: how far the grip reaches past the hinge pin, m.
        side: which side of the grip is probed: +1 its left edge (toward +y at heading 0),
            -1 its right edge.
    """

    hinge: tuple[float, float]
    heading: float
    width: float
    thickness: float
    reach: float
    side: int

    @classmethod
    def of(cls, config: ObjectConfig) -> NominalLayout:
        """The layout an operator reads off an object's documented configuration."""
        x, y, _ = config.link_direction
        return cls(
            hinge=(config.joint_position[0], config.joint_position[1]),
            heading=math.atan2(y, x),
            width=config.free_link_size[1],
            thickness=config.joint_position[2] + config.free_link_size[2] / 2,
            reach=config.free_link_size[0] - config.pin_overlap,
            side=config.edge_side,
        )

    def first_search(self, along: float) -> tuple[np.ndarray, np.ndarray]:
        """Start point (2,) and outward direction (2,) of the first edge search, world x-y.

        The start is ``along`` (m) out along the nominal grip, at most ``END_CLEARANCE``
        short of its end, and ``START_INSET`` inside its nominal probed edge; outward points
        across that edge, away from the grip.
        """
        along = min(along, self.reach - END_CLEARANCE)
        heading = np.array([math.cos(self.heading), math.sin(self.heading)])
        outward = self.side * np.array([-heading[1], heading[0]])
        start = (
            np.asarray(self.hinge) + along * heading + (0.5 * self.width - START_INSET) * outward
        )
        return start, outward


#: What ``--world`` may change, untold to the sensing, each as a factor of the configured
#: value: the skin's normal stiffness (its tangential one follows), the sensor's noise (force
#: and moment) and its drift (force and moment).
WORLD_FACTORS = ("skin_stiffness", "noise", "drift")


def parse_world(text: str) -> dict[str, float]:
    """``--world``'s ``name=factor`` pairs (space- or comma-separated) of ``WORLD_FACTORS``.

    Raises:
        ValueError: an unknown name, or a factor that is not a number in (0, 100].
    """
    world = {}
    for pair in text.replace(",", " ").split():
        name, _, value = pair.partition("=")
        if name not in WORLD_FACTORS:
            raise ValueError(
                f"--world takes name=factor pairs of {', '.join(WORLD_FACTORS)}, got {pair!r}"
            )
        try:
            factor = float(value)
        except ValueError:
            factor = math.nan
        if not 0.0 < factor <= 100.0:
            raise ValueError(f"--world {name} must be a factor in (0, 100], got {value!r}")
        world[name] = factor
    return world


def configured(condition: str, sensor: str = "realistic") -> tuple[SkinConfig, SensorConfig]:
    """The skin and the F/T sensor of a condition of ``CONDITIONS`` with a sensor of
    ``SENSORS`` (a condition's ``sensor_model`` and ``sensor`` fields change it): what the
    sensing is told."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {sorted(CONDITIONS)}, got {condition!r}")
    change = CONDITIONS[condition]
    base = SENSORS[change.get("sensor_model", sensor)]
    return SkinConfig(**change.get("skin", {})), replace(base, **change.get("sensor", {}))


def make_scene(
    condition: str,
    sensor: str = "realistic",
    world: dict[str, float] | None = None,
    physics: str = "v2",
) -> ProbeScene:
    """The paper's scene under a condition of ``CONDITIONS``, the hand holding the grip,
    with a sensor of ``SENSORS`` (:func:`configured`), the world factors of ``world``
    (``WORLD_FACTORS``; :func:`parse_world`) applied to the scene alone, and the contact step
    ``physics`` (``tactile_gym.sim.scene.PHYSICS``)."""
    skin, sensor_config = configured(condition, sensor)
    world = world or {}
    unknown = set(world) - set(WORLD_FACTORS)
    if unknown:
        raise ValueError(f"world factors must be from {WORLD_FACTORS}, got {sorted(unknown)}")
    skin = replace(skin, normal_stiffness=skin.normal_stiffness * world.get("skin_stiffness", 1.0))
    scaled = {
        "noise": ("force_noise_std", "moment_noise_std"),
        "drift": ("force_drift", "moment_drift"),
    }
    changes = {
        name: getattr(sensor_config, name) * world.get(factor, 1.0)
        for factor, names in scaled.items()
        for name in names
    }
    return ProbeScene(
        condition_object(condition), skin, replace(sensor_config, **changes), physics=physics
    )
