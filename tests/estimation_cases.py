"""Ground truth for the estimation tests: an edge line of a link rotating about a known axis,
with the contact point sliding along the edge between measurements, and checks they share.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation import (
    AxisEstimate,
    axis_error,
    axis_nees,
)

PAPER_AXIS = np.array([0.017, 0.105, 0.0])  # m, Table I


SIGMA_X = 1e-3  # m


SIGMA_E = math.radians(1.0)  # rad


def rot(u: np.ndarray, angle: float) -> np.ndarray:
    u = u / np.linalg.norm(u)
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def perturb_edge(rng: np.random.Generator, e: np.ndarray, sigma: float) -> np.ndarray:
    """Isotropic edge noise of total RMS angle sigma (sigma / sqrt(2) per normal direction)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(e[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = np.cross(e, a)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(e, b1)
    out = e + rng.normal(0, sigma / math.sqrt(2), 2) @ np.array([b1, b2])
    return out / np.linalg.norm(out)


def make_edges_3d(
    rng: np.random.Generator,
    axis_point: np.ndarray,
    axis_dir: np.ndarray,
    edge_dir: np.ndarray,
    distance: float,
    n: int = 8,
    sweep: float = math.pi / 2,
    start: float = 0.05,
    slide: float = 0.01,
    sigma_x: float = 0.0,
    sigma_e: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Contact points and edges of a link edge rotating about an axis (3D noise)."""
    u = axis_dir / np.linalg.norm(axis_dir)
    e0 = edge_dir / np.linalg.norm(edge_dir)
    normal = np.cross(u, e0)
    if np.linalg.norm(normal) < 1e-9:  # edge parallel to the axis
        normal = np.cross(u, [1.0, 0.0, 0.0])
        if np.linalg.norm(normal) < 1e-9:
            normal = np.cross(u, [0.0, 1.0, 0.0])
    normal /= np.linalg.norm(normal)
    foot = axis_point + distance * normal
    pts, eds = [], []
    for i, angle in enumerate(np.linspace(0.0, sweep, n)):
        r = rot(u, angle)
        x = axis_point + r @ (foot - axis_point + (start + slide * i) * e0)
        e = r @ e0
        pts.append(x + rng.normal(0, sigma_x, 3) if sigma_x else x)
        eds.append(perturb_edge(rng, e, sigma_e) if sigma_e else e)
    return np.array(pts), np.array(eds)


def make_planar(
    rng: np.random.Generator,
    n: int = 4,
    sweep: float = math.pi / 2,
    slide: float = 0.02,
    sigma_x: float = SIGMA_X,
    sigma_e: float = SIGMA_E,
    distance: float = 0.01,
    start: float = 0.03,
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's setting: a grip edge on the table turning about (17, 105) mm."""
    phi = np.linspace(0.0, sweep, n)
    t = start + slide * np.arange(n)
    c, s = np.cos(phi), np.sin(phi)
    # edge along (cos phi, sin phi), offset by distance along its normal (-sin, cos)
    x = PAPER_AXIS[0] + t * c - distance * s + rng.normal(0, sigma_x, n)
    y = PAPER_AXIS[1] + t * s + distance * c + rng.normal(0, sigma_x, n)
    ang = phi + rng.normal(0, sigma_e, n)
    return np.column_stack([x, y]), np.column_stack([np.cos(ang), np.sin(ang)])


def position_error(est: AxisEstimate) -> float:
    return axis_error(est, PAPER_AXIS, [0, 0, 1])[0]


def tilted_case(rng, sigma_x=SIGMA_X, sigma_e=SIGMA_E, n=12):
    u = np.array([0.3, -0.2, 1.0])
    u /= np.linalg.norm(u)
    p = np.array([0.017, 0.105, 0.03])
    e0 = np.cross(u, [0.3, 0.9, 0.1])
    e0 /= np.linalg.norm(e0)
    pts, eds = make_edges_3d(
        rng,
        p,
        u,
        e0,
        0.02,
        n=n,
        sweep=math.radians(120),
        start=0.03,
        slide=0.005,
        sigma_x=sigma_x,
        sigma_e=sigma_e,
    )
    return p, u, pts, eds


def nees_3d(est: AxisEstimate, p: np.ndarray, u: np.ndarray) -> np.ndarray:
    """NEES of (point, direction) normal to the axis (4 dof) and of each alone (2 dof each)."""
    return np.array(axis_nees(est, p, u))


def planar_nees(est: AxisEstimate, p: np.ndarray) -> float:
    """NEES of the (x, y) position of a vertical axis (2 dof)."""
    err = est.point[:2] - p[:2]
    return float(err @ np.linalg.solve(est.covariance[:2, :2], err))


def calibrated(mean_nees: np.ndarray, dof: list[float]) -> bool:
    return bool(np.allclose(mean_nees, dof, rtol=0.3, atol=0.0))
