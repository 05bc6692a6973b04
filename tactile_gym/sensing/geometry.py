"""Geometry of the soft fingertip: a cylinder capped by a hemisphere, covered by a skin.

Conventions (see docs/design.md 2):

* SI units: metres.
* Sensor frame: origin at the force/torque sensor, z along the finger axis. The rigid shell is
  a cylinder of radius ``shell_radius`` from z = 0 to z = ``cylinder_length``, capped by a
  hemisphere centred at (0, 0, ``cylinder_length``). The skin of constant ``skin_thickness``
  covers it, so the outer surface has radius ``outer_radius``.
* Every point and normal taken or returned here is in the sensor frame.

The outer surface is treated as the union of two pieces: the hemisphere (z >= L) and the
cylinder side (z < L, extended below z = 0 where the sensor body sits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FingertipGeometry", "SurfaceSamples"]


@dataclass(frozen=True)
class SurfaceSamples:
    """Points spread over the outer skin surface, in the sensor frame.

    Attributes:
        points: (N, 3) positions on the outer surface, m.
        normals: (N, 3) outward unit normals.
        areas: (N,) surface area each point stands for, m^2.
    """

    points: np.ndarray
    normals: np.ndarray
    areas: np.ndarray


def _as_points(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim not in (1, 2) or p.shape[-1] != 3:
        raise ValueError(f"points must have shape (3,) or (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    return p


@dataclass(frozen=True)
class FingertipGeometry:
    """The fingertip of Matsuo et al. (2010): aluminium shell plus silicone skin.

    Attributes:
        shell_radius: radius of the rigid shell, m (paper: 0.011).
        skin_thickness: thickness of the skin, m (paper: 0.005).
        cylinder_length: length of the cylindrical part from the sensor origin to the
            hemisphere centre, m.
    """

    shell_radius: float = 0.011
    skin_thickness: float = 0.005
    cylinder_length: float = 0.020

    def __post_init__(self) -> None:
        for name in ("shell_radius", "skin_thickness", "cylinder_length"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a finite number > 0 m, got {value!r}")

    @property
    def outer_radius(self) -> float:
        """Radius of the outer skin surface, m."""
        return self.shell_radius + self.skin_thickness

    @property
    def sphere_center(self) -> np.ndarray:
        """Centre of the hemisphere, sensor frame, m."""
        return np.array([0.0, 0.0, self.cylinder_length])

    def _on_sphere(self, p: np.ndarray) -> np.ndarray:
        return p[..., 2] >= self.cylinder_length

    def signed_distance(self, points: np.ndarray, radius: float | None = None) -> np.ndarray:
        """Signed distance from points to the outer surface (negative inside), m.

        Args:
            points: (3,) or (N, 3) points, sensor frame, m.
            radius: surface radius to measure against; defaults to ``outer_radius``. Pass
                ``shell_radius`` for the rigid shell.
        """
        p = _as_points(points)
        r = self.outer_radius if radius is None else float(radius)
        d_sphere = np.linalg.norm(p - self.sphere_center, axis=-1) - r
        d_cyl = np.linalg.norm(p[..., :2], axis=-1) - r
        return np.where(self._on_sphere(p), d_sphere, d_cyl)

    def surface_normal(self, points: np.ndarray) -> np.ndarray:
        """Outward unit normal of the outer surface nearest each point (sensor frame).

        Points on the finger axis have no unique normal; they get +z on the hemisphere side
        and +x on the cylinder side.
        """
        p = _as_points(points)
        v = np.where(
            self._on_sphere(p)[..., None],
            p - self.sphere_center,
            p * np.array([1.0, 1.0, 0.0]),
        )
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        fallback = np.where(self._on_sphere(p)[..., None], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
        safe = np.where(norm > 1e-12, norm, 1.0)
        return np.where(norm > 1e-12, v / safe, fallback)

    def sample_surface(self, spacing: float, z_min: float) -> SurfaceSamples:
        """Spread points over the outer surface at roughly ``spacing`` apart.

        The hemisphere is covered by a Fibonacci spiral (near-uniform area per point) and the
        cylinder side by rings. Each point carries the area it stands for, so sums over
        points approximate surface integrals.

        Args:
            spacing: target distance between neighbouring points, m; > 0.
            z_min: lowest z of the cylinder part to cover, m; in [0, cylinder_length].

        Returns:
            SurfaceSamples in the sensor frame.
        """
        if not np.isfinite(spacing) or spacing <= 0:
            raise ValueError(f"spacing must be > 0 m, got {spacing!r}")
        if not (0.0 <= z_min <= self.cylinder_length):
            raise ValueError(f"z_min must be in [0, {self.cylinder_length}] m, got {z_min!r}")
        r = self.outer_radius
        c = self.sphere_center

        # Hemisphere: Fibonacci spiral over z in (0, 1], equal area per point.
        hemi_area = 2.0 * np.pi * r**2
        n_h = max(int(np.ceil(hemi_area / spacing**2)), 1)
        k = np.arange(n_h)
        cos_polar = 1.0 - (k + 0.5) / n_h
        sin_polar = np.sqrt(1.0 - cos_polar**2)
        azim = k * np.pi * (3.0 - np.sqrt(5.0))
        n_hemi = np.stack([sin_polar * np.cos(azim), sin_polar * np.sin(azim), cos_polar], axis=-1)
        p_hemi = c + r * n_hemi
        a_hemi = np.full(n_h, hemi_area / n_h)

        # Cylinder: rings from z_min up to the hemisphere's equator.
        height = self.cylinder_length - z_min
        n_rings = int(np.ceil(height / spacing))
        if n_rings > 0:
            n_around = max(int(np.ceil(2.0 * np.pi * r / spacing)), 3)
            dz = height / n_rings
            z = z_min + (np.arange(n_rings) + 0.5) * dz
            theta = 2.0 * np.pi * np.arange(n_around) / n_around
            zz, tt = np.meshgrid(z, theta, indexing="ij")
            # Stagger alternate rings to avoid aligned rows of nodes.
            tt = tt + (np.arange(n_rings)[:, None] % 2) * (np.pi / n_around)
            n_cyl = np.stack([np.cos(tt), np.sin(tt), np.zeros_like(tt)], -1).reshape(-1, 3)
            p_cyl = n_cyl * r + np.column_stack([np.zeros(zz.size), np.zeros(zz.size), zz.ravel()])
            a_cyl = np.full(len(p_cyl), 2.0 * np.pi * r * dz / n_around)
        else:
            n_cyl = np.zeros((0, 3))
            p_cyl = np.zeros((0, 3))
            a_cyl = np.zeros(0)

        return SurfaceSamples(
            points=np.vstack([p_hemi, p_cyl]),
            normals=np.vstack([n_hemi, n_cyl]),
            areas=np.concatenate([a_hemi, a_cyl]),
        )
