"""Configuration dataclasses of the simulator: the skin and the jointed objects.

The F/T sensor's ``SensorConfig`` lives in ``tactile_gym.sensing`` (real robots need it too).

One source for every default: the dataclass fields hold them, and the object families are
presets that hold only what differs from ``ObjectConfig``'s defaults (the paper's scissors):
``configs/objects/<family>.yml``, loaded by name through :mod:`tactile_gym.presets`. Every
field is type- and range-checked with :mod:`tactile_gym.validation`.

All values are SI: metres, newtons, radians, seconds. Frames: ``ObjectConfig.joint_position``,
``axis`` and ``link_direction`` are in the world frame (z up, table top at z = 0). A joint's
coordinate, limits, damping and holding friction are in its own units: radians, N m s/rad and
N m for a revolute joint; metres, N s/m and N for a prismatic one.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np

from tactile_gym.presets import load_preset
from tactile_gym.validation import (
    build_config,
    check_choice,
    check_int,
    check_number,
    check_vector,
)

__all__ = ["FAMILIES", "JOINT_TYPES", "ObjectConfig", "SkinConfig", "family_joint_type"]


@dataclass(frozen=True)
class SkinConfig:
    """Elastic-foundation (Winkler) skin (``docs/design.md``, "The skin").

    Attributes:
        node_spacing: distance between skin nodes, m. 0.65 mm keeps the edge-direction
            discretisation error below 1 degree.
        normal_stiffness: k_n = E / h, N/m^3 (E ~ 0.44 MPa silicone, h = 5 mm).
        tangential_stiffness: k_t, N/m^3; None means k_n / 3.
        damping: normal damping per unit area, N s/m^3.
        friction: Coulomb coefficient mu between skin and object (silicone on metal or
            plastic: 0.3-0.6).
        margin: broad-phase margin added to the motion bound when pre-selecting nodes, m.
        z_min: lowest sensor-frame z of the cylinder part covered by nodes, m.
    """

    node_spacing: float = 0.00065
    normal_stiffness: float = 8.8e7
    tangential_stiffness: float | None = None
    damping: float = 2.0e5
    friction: float = 0.5
    margin: float = 0.002
    z_min: float = 0.0

    def __post_init__(self) -> None:
        check_number("skin.node_spacing", self.node_spacing, 2e-4, 3e-3)
        check_number("skin.normal_stiffness", self.normal_stiffness, 1e6, 1e10)
        if self.tangential_stiffness is not None:
            check_number("skin.tangential_stiffness", self.tangential_stiffness, 1e5, 1e10)
        check_number("skin.damping", self.damping, 0.0, 1e7)
        check_number("skin.friction", self.friction, 0.0, 3.0)
        check_number("skin.margin", self.margin, 0.0, 0.02, low_open=True)
        check_number("skin.z_min", self.z_min, 0.0, 0.02)

    @property
    def k_t(self) -> float:
        """Tangential stiffness actually used, N/m^3."""
        if self.tangential_stiffness is None:
            return self.normal_stiffness / 3.0
        return float(self.tangential_stiffness)


#: The object families, each a preset ``configs/objects/<family>.yml``: the revolute ones
#: (the ``HingeProbe`` ids'), then the prismatic and the fixed ones (``docs/design.md`` 3.7).
FAMILIES = ("scissors", "door", "lid", "tilted", "slider", "drawer", "tilted_drawer", "block")
#: The joints an object may have: a hinge, a slide, or none (the free link is fixed).
JOINT_TYPES = ("revolute", "prismatic", "fixed")


@dataclass(frozen=True)
class ObjectConfig:
    """A two-link object with one joint: revolute (a hinge), prismatic (a slide) or fixed.

    Geometry is given in the *hinge frame* H: origin at the joint's reference point
    (``joint_position``, world: a revolute joint's pin centre), z_H along ``axis`` (a revolute
    joint's axis, a prismatic joint's direction of travel), x_H along ``link_direction`` made
    perpendicular to the axis (where the free link points at joint coordinate 0), y_H =
    z_H x x_H. Each link is a box with rounded edges whose size is (along x_H, along y_H,
    along z_H). The free link extends along +x_H from the pin, the fixed link along -x_H;
    each overlaps the pin by ``pin_overlap``. A revolute joint turns the free link about z_H
    by its angle; a prismatic one moves it along z_H by its travel; a fixed one never moves
    it.

    The probed edge of the free link is the edge line along x_H at
    y_H = ``edge_side`` * size_y / 2, z_H = +size_z / 2 (the sharp corner of the two faces).
    On a prismatic object it is square to the travel (a drawer's front edge).

    Attributes:
        family: one of ``FAMILIES`` (informational).
        joint_type: one of ``JOINT_TYPES``; the units of the joint's fields below follow it
            (module docstring).
        free_link_size: (x, y, z) size of the free link, hinge frame, m.
        fixed_link_size: (x, y, z) size of the fixed link, hinge frame, m.
        pin_overlap: how far each link extends past the pin centre, m.
        edge_radius: rounding of every box edge, m.
        joint_position: hinge pin centre, world frame, m.
        axis: joint axis direction, world frame (normalised on use).
        link_direction: direction of the free link at joint angle 0, world frame.
        lower_limit, upper_limit: joint limits, rad (prismatic: m). The default +-150 deg
            stops the free link before it folds onto the fixed one (the object's own
            collisions are off). A fixed joint has none.
        damping: viscous joint damping, N m s/rad (prismatic: N s/m).
        holding_torque: max force of the zero-velocity motor that gives the joint its
            holding (Coulomb-like) friction, N m (prismatic: N).
        free_link_mass: mass of the free link, kg.
        edge_side: +1 or -1, which y_H side of the free link is probed.
    """

    family: str = "scissors"
    joint_type: str = "revolute"
    free_link_size: tuple[float, float, float] = (0.10, 0.02, 0.008)
    fixed_link_size: tuple[float, float, float] = (0.10, 0.02, 0.008)
    pin_overlap: float = 0.01
    edge_radius: float = 0.0003
    joint_position: tuple[float, float, float] = (0.017, 0.105, 0.004)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    link_direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower_limit: float = float(np.deg2rad(-150.0))
    upper_limit: float = float(np.deg2rad(150.0))
    damping: float = 0.002
    holding_torque: float = 0.1
    free_link_mass: float = 0.05
    edge_side: int = -1

    def __post_init__(self) -> None:
        check_choice("object.family", self.family, FAMILIES)
        check_choice("object.joint_type", self.joint_type, JOINT_TYPES)
        check_number("object.edge_radius", self.edge_radius, 0.0, 0.01)
        for name in ("free_link_size", "fixed_link_size"):
            size = check_vector(f"object.{name}", getattr(self, name), bound=0.5)
            if min(size) < 1e-3:
                raise ValueError(f"object.{name} must be 3 sizes >= 0.001 m, got {list(size)}")
            if 2 * self.edge_radius >= min(size):
                raise ValueError(
                    f"object.edge_radius must be < half the smallest size of {name} "
                    f"({min(size) / 2} m), got {self.edge_radius!r}"
                )
            object.__setattr__(self, name, size)
        check_number("object.pin_overlap", self.pin_overlap, 0.0, 0.1)
        check_number("object.damping", self.damping, 0.0, 10.0)
        check_number("object.holding_torque", self.holding_torque, 0.0, 10.0)
        check_number("object.free_link_mass", self.free_link_mass, 1e-3, 10.0)
        position = check_vector("object.joint_position", self.joint_position, bound=1.0)
        # Directions are normalised on use; the bound keeps their norms finite.
        axis = check_vector("object.axis", self.axis, bound=1e6, nonzero=True)
        link = check_vector("object.link_direction", self.link_direction, bound=1e6, nonzero=True)
        for name, value in (("joint_position", position), ("axis", axis), ("link_direction", link)):
            object.__setattr__(self, name, value)
        a = np.asarray(axis) / np.linalg.norm(axis)
        if np.linalg.norm(np.cross(a, np.asarray(link) / np.linalg.norm(link))) < 1e-6:
            raise ValueError(f"object.link_direction must not be parallel to axis, got {link}")
        check_number("object.lower_limit", self.lower_limit, -np.pi, np.pi)
        check_number("object.upper_limit", self.upper_limit, -np.pi, np.pi)
        if not self.lower_limit < self.upper_limit:
            raise ValueError(
                "object.lower_limit must be < upper_limit, got"
                f" {self.lower_limit!r} >= {self.upper_limit!r}"
            )
        check_int("object.edge_side", self.edge_side, -1, 1)
        if self.edge_side == 0:
            raise ValueError("object.edge_side must be +1 or -1, got 0")

    def hinge_rotation(self) -> np.ndarray:
        """3x3 rotation whose columns are x_H, y_H, z_H in the world frame."""
        z = np.asarray(self.axis, float)
        z = z / np.linalg.norm(z)
        x = np.asarray(self.link_direction, float)
        x = x - (x @ z) * z
        x = x / np.linalg.norm(x)
        return np.column_stack([x, np.cross(z, x), z])

    @classmethod
    def family_default(cls, family: str, /, **overrides: Any) -> ObjectConfig:
        """A family's object: its preset ``configs/objects/<family>.yml`` with ``overrides``.

        ``overrides`` are ``ObjectConfig`` fields, or, under a family's name, a dict of them
        for that family alone (the joint ids' v1 objects: ``tactile_gym/__init__.py``): the
        family's own entry applies over its preset, then the fields given for every family
        (a reset's drawn sizes among them); other families' entries are ignored.
        """
        check_choice("family", family, FAMILIES)
        own = overrides.get(family, {})
        if not isinstance(own, dict):
            raise ValueError(
                f"object.{family} must be a dict of ObjectConfig fields for that family,"
                f" got {own!r}"
            )
        overrides = {k: v for k, v in overrides.items() if k not in FAMILIES}
        if "family" in own or "joint_type" in own:
            raise ValueError(
                f"object.{family} cannot set the family or its joint type, got {own!r}"
            )
        if "family" in overrides:
            raise ValueError(
                f"object.family is the name of the family drawn ({family!r}) and cannot be"
                f" overridden, got {overrides['family']!r}; choose the families instead"
            )
        preset = _family_preset(family)
        joint = preset.get("joint_type", "revolute")
        if overrides.get("joint_type", joint) != joint:
            raise ValueError(
                f"object.joint_type belongs to the family drawn ({family!r}: {joint!r}) and"
                f" cannot be overridden, got {overrides['joint_type']!r}; choose the families"
                " instead"
            )
        return build_config(cls, {**preset, **own, **overrides}, "object")

    @classmethod
    def scissors(cls, **overrides: Any) -> ObjectConfig:
        """The paper's object: two flat grips on the table, vertical axis at (17, 105) mm."""
        return cls.family_default("scissors", **overrides)

    @classmethod
    def door(cls, **overrides: Any) -> ObjectConfig:
        """An upright plate hinged on a vertical axis; probed on its top edge."""
        return cls.family_default("door", **overrides)

    @classmethod
    def lid(cls, **overrides: Any) -> ObjectConfig:
        """A plate on a horizontal axis (world -y): a positive angle opens it."""
        return cls.family_default("lid", **overrides)

    @classmethod
    def tilted(cls, **overrides: Any) -> ObjectConfig:
        """Scissors-like links on an axis tilted 20 degrees from vertical, above the table."""
        return cls.family_default("tilted", **overrides)

    @classmethod
    def slider(cls, **overrides: Any) -> ObjectConfig:
        """A plate on the table that slides along the table beside a fixed rail."""
        return cls.family_default("slider", **overrides)

    @classmethod
    def drawer(cls, **overrides: Any) -> ObjectConfig:
        """A box whose top face is probed, sliding horizontally out of its cabinet's side."""
        return cls.family_default("drawer", **overrides)

    @classmethod
    def tilted_drawer(cls, **overrides: Any) -> ObjectConfig:
        """A drawer sliding 20 degrees up from horizontal, above the table."""
        return cls.family_default("tilted_drawer", **overrides)

    @classmethod
    def block(cls, **overrides: Any) -> ObjectConfig:
        """A plate fixed to the table: no joint moves it."""
        return cls.family_default("block", **overrides)


def family_joint_type(family: str) -> str:
    """The joint type of a family's preset (one of ``JOINT_TYPES``).

    Raises:
        ValueError: an unknown family, naming the allowed ones.
    """
    check_choice("family", family, FAMILIES)
    return str(_family_preset(family).get("joint_type", "revolute"))


@cache
def _family_preset_cached(family: str) -> tuple:
    return tuple(sorted(load_preset("objects", family).items()))


def _family_preset(family: str) -> dict[str, Any]:
    """A family's preset (read once per process), with ``family`` set."""
    return {"family": family, **dict(_family_preset_cached(family))}
