"""Configuration dataclasses of the simulator: skin and hinged objects.

The F/T sensor's ``SensorConfig`` lives in ``tactile_gym.sensing`` (real robots need it too).

All values are SI: metres, newtons, radians, seconds. The YAML files under ``configs/sim`` and
``configs/objects`` mirror these defaults, with units in comments; ``from_yaml`` reads them and
``to_dict`` writes back what ``from_yaml`` accepts.

Frames: ``ObjectConfig.joint_position`` and ``ObjectConfig.axis`` / ``link_direction`` are in
the world frame (z up, table top at z = 0).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

__all__ = [
    "CONFIG_DIR",
    "ObjectConfig",
    "SkinConfig",
]

#: Repository folder that holds ``sim/*.yml`` and ``objects/*.yml``.
CONFIG_DIR = Path(__file__).resolve().parents[2] / "configs"


def _load_yaml(path: str | Path) -> dict[str, Any]:
    with open(path) as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


def _check_keys(cls: type, data: dict[str, Any], source: str) -> None:
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"{source}: unknown keys {unknown}; allowed: {sorted(known)}")


def _to_builtin(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_to_builtin(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _positive(obj: Any, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")


def _non_negative(obj: Any, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if not np.isfinite(value) or value < 0:
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


class _YamlMixin:
    @classmethod
    def from_yaml(cls, path: str | Path, **overrides: Any):
        """Read a config from a YAML mapping; ``overrides`` replace file values."""
        data = _load_yaml(path)
        data.update(overrides)
        return cls.from_dict(data, source=str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "config"):
        """Build a config from a plain mapping (lists become tuples)."""
        _check_keys(cls, data, source)
        clean = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**clean)

    def to_dict(self) -> dict[str, Any]:
        """Plain mapping of the fields (tuples as lists), as ``from_dict`` accepts."""
        return {f.name: _to_builtin(getattr(self, f.name)) for f in dataclasses.fields(self)}


@dataclass(frozen=True)
class SkinConfig(_YamlMixin):
    """Elastic-foundation (Winkler) skin, defaults from DESIGN.md section 2.4.

    Attributes:
        node_spacing: distance between skin nodes, m. 0.65 mm keeps the edge-direction
            discretisation error below 1 degree (DESIGN 2.4: ~1 deg at 0.7 mm).
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
        _positive(self, "node_spacing", "normal_stiffness", "margin")
        _non_negative(self, "damping", "friction", "z_min")
        if self.tangential_stiffness is not None:
            _positive(self, "tangential_stiffness")

    @property
    def k_t(self) -> float:
        """Tangential stiffness actually used, N/m^3."""
        if self.tangential_stiffness is None:
            return self.normal_stiffness / 3.0
        return float(self.tangential_stiffness)

    @classmethod
    def default_yaml(cls) -> SkinConfig:
        """The repository's ``configs/sim/skin.yml``."""
        return cls.from_yaml(CONFIG_DIR / "sim" / "skin.yml")


FAMILIES = ("scissors", "door", "lid", "tilted")


@dataclass(frozen=True)
class ObjectConfig(_YamlMixin):
    """A two-link object with one revolute joint.

    Geometry is given in the *hinge frame* H: origin at the hinge pin centre
    (``joint_position``, world), z_H along ``axis``, x_H along ``link_direction`` made
    perpendicular to the axis (where the free link points at joint angle 0), y_H = z_H x x_H.
    Each link is a box with rounded edges whose size is (along x_H, along y_H, along z_H).
    The free link extends along +x_H from the pin, the fixed link along -x_H; each overlaps
    the pin by ``pin_overlap``.

    The probed edge of the free link is the edge line along x_H at
    y_H = ``edge_side`` * size_y / 2, z_H = +size_z / 2 (the sharp corner of the two faces).

    Attributes:
        family: "scissors", "door", "lid" or "tilted" (informational).
        free_link_size: (x, y, z) size of the free link, hinge frame, m.
        fixed_link_size: (x, y, z) size of the fixed link, hinge frame, m.
        pin_overlap: how far each link extends past the pin centre, m.
        edge_radius: rounding of every box edge, m.
        joint_position: hinge pin centre, world frame, m.
        axis: joint axis direction, world frame (normalised on use).
        link_direction: direction of the free link at joint angle 0, world frame.
        lower_limit, upper_limit: joint limits, rad.
        damping: viscous joint damping, N m s/rad.
        holding_torque: max force of the zero-velocity motor that gives the joint its
            holding (Coulomb-like) friction, N m.
        free_link_mass: mass of the free link, kg.
        edge_side: +1 or -1, which y_H side of the free link is probed.
    """

    family: str = "scissors"
    free_link_size: tuple[float, float, float] = (0.10, 0.02, 0.008)
    fixed_link_size: tuple[float, float, float] = (0.10, 0.02, 0.008)
    pin_overlap: float = 0.01
    edge_radius: float = 0.0003
    joint_position: tuple[float, float, float] = (0.017, 0.105, 0.004)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    link_direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower_limit: float = -np.pi
    upper_limit: float = np.pi
    damping: float = 0.002
    holding_torque: float = 0.1
    free_link_mass: float = 0.05
    edge_side: int = -1

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ValueError(f"family must be one of {FAMILIES}, got {self.family!r}")
        for name in ("free_link_size", "fixed_link_size"):
            s = np.asarray(getattr(self, name), dtype=float)
            if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
                raise ValueError(f"{name} must be 3 finite sizes > 0 m, got {s.tolist()}")
            if 2 * self.edge_radius >= s.min():
                raise ValueError(
                    f"edge_radius must be < half the smallest size of {name} "
                    f"({s.min() / 2} m), got {self.edge_radius}"
                )
        _non_negative(self, "pin_overlap", "edge_radius", "damping", "holding_torque")
        _positive(self, "free_link_mass")
        for name in ("joint_position", "axis", "link_direction"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be 3 finite numbers, got {getattr(self, name)!r}")
        a = np.asarray(self.axis, float)
        d = np.asarray(self.link_direction, float)
        if np.linalg.norm(a) < 1e-9:
            raise ValueError("axis must be a non-zero vector")
        if np.linalg.norm(np.cross(a / np.linalg.norm(a), d)) < 1e-6:
            raise ValueError("link_direction must not be parallel to axis")
        if not self.lower_limit < self.upper_limit:
            raise ValueError(
                f"lower_limit must be < upper_limit, got {self.lower_limit} >= {self.upper_limit}"
            )
        if self.edge_side not in (-1, 1):
            raise ValueError(f"edge_side must be +1 or -1, got {self.edge_side!r}")

    def hinge_rotation(self) -> np.ndarray:
        """3x3 rotation whose columns are x_H, y_H, z_H in the world frame."""
        z = np.asarray(self.axis, float)
        z = z / np.linalg.norm(z)
        x = np.asarray(self.link_direction, float)
        x = x - (x @ z) * z
        x = x / np.linalg.norm(x)
        return np.column_stack([x, np.cross(z, x), z])

    @classmethod
    def scissors(cls, **overrides: Any) -> ObjectConfig:
        """The paper's object: two flat grips on the table, vertical axis at (17, 105) mm."""
        return cls(**{"family": "scissors", **overrides})

    @classmethod
    def door(cls, **overrides: Any) -> ObjectConfig:
        """An upright plate hinged on a vertical axis; probed on its top edge."""
        base = dict(
            family="door",
            free_link_size=(0.12, 0.008, 0.10),
            fixed_link_size=(0.04, 0.008, 0.10),
            joint_position=(0.0, 0.10, 0.05),
            axis=(0.0, 0.0, 1.0),
            link_direction=(1.0, 0.0, 0.0),
            free_link_mass=0.1,
        )
        return cls(**{**base, **overrides})

    @classmethod
    def lid(cls, **overrides: Any) -> ObjectConfig:
        """A flat plate hinged on a horizontal axis (along world -y), lying closed.

        With the axis along -y, y_H points up, so a positive joint angle opens the lid and
        ``edge_side=+1`` probes the edge of its top face.
        """
        base = dict(
            family="lid",
            free_link_size=(0.10, 0.008, 0.06),
            fixed_link_size=(0.04, 0.008, 0.06),
            joint_position=(0.0, 0.10, 0.004),
            axis=(0.0, -1.0, 0.0),
            edge_side=1,
            link_direction=(1.0, 0.0, 0.0),
            lower_limit=-0.01,
            upper_limit=2.0,
        )
        return cls(**{**base, **overrides})

    @classmethod
    def tilted(cls, **overrides: Any) -> ObjectConfig:
        """Scissors-like links on an axis tilted 20 degrees from vertical, above the table."""
        t = np.deg2rad(20.0)
        base = dict(
            family="tilted",
            joint_position=(0.0, 0.10, 0.05),
            axis=(float(np.sin(t)), 0.0, float(np.cos(t))),
            link_direction=(0.0, 1.0, 0.0),
        )
        return cls(**{**base, **overrides})

    @classmethod
    def family_default(cls, family: str, **overrides: Any) -> ObjectConfig:
        """Default config of a family by name."""
        if family not in FAMILIES:
            raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
        return getattr(cls, family)(**overrides)

    @classmethod
    def from_yaml(cls, path: str | Path, **overrides: Any) -> ObjectConfig:
        """Read an object config; the file's ``family`` key selects the defaults it edits."""
        data = _load_yaml(path)
        data.update(overrides)
        _check_keys(cls, data, str(path))
        clean = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        family = clean.pop("family", "scissors")
        return cls.family_default(family, **clean)

    @classmethod
    def load_family(cls, family: str, **overrides: Any) -> ObjectConfig:
        """The repository's ``configs/objects/<family>.yml``."""
        return cls.from_yaml(CONFIG_DIR / "objects" / f"{family}.yml", **overrides)
