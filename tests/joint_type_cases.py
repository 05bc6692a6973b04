"""Ground truth for the joint-type tests and benchmark: presses on the edges of a link's face,
the link moved by a known joint between configurations.

The link's probed face is a rectangle; its edges are oriented as the sensing orients them
(``e = n x f``: going round the face with its interior on the left, seen from outside), so
the two long edges point opposite ways. Between configurations the joint moves the link:
not at all (rigid), along a direction (prismatic) or about an axis (revolute). At each
configuration some of the edges are pressed, each at a random place along its middle
(the contact slides along the edge between presses), with the noise the estimator is told.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

SIGMA_X = 1e-3  # m, the env's contact-point std
SIGMA_E = math.radians(2.0)  # rad, total RMS edge error, the middle of the env's 1-3 deg

JOINT_TYPES = ("rigid", "revolute", "prismatic")


def rot(u: np.ndarray, angle: float) -> np.ndarray:
    u = np.asarray(u, dtype=float) / np.linalg.norm(u)
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def perturb_edge(rng: np.random.Generator, e: np.ndarray, sigma: float) -> np.ndarray:
    """Isotropic edge noise of total RMS angle sigma (sigma / sqrt(2) per normal direction)."""
    b = np.linalg.svd(e[None])[2][1:]
    out = e + rng.normal(0.0, sigma / math.sqrt(2.0), 2) @ b
    return out / np.linalg.norm(out)


@dataclass
class Face:
    """A rectangular face: centre, in-plane unit axes ``ex``, ``ey`` (normal ``ex x ey``),
    half sizes (m)."""

    centre: np.ndarray
    ex: np.ndarray
    ey: np.ndarray
    half: tuple[float, float]

    def edges(self) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """(direction, midpoint, half length) of the four edges, counter-clockwise about
        the normal: +y side (-ex), -x side (-ey), -y side (+ex), +x side (+ey)."""
        hx, hy = self.half
        c, ex, ey = self.centre, self.ex, self.ey
        return [
            (-ex, c + hy * ey, hx),
            (-ey, c - hx * ex, hy),
            (ex, c - hy * ey, hx),
            (ey, c + hx * ex, hy),
        ]


@dataclass
class Joint:
    """The truth: ``kind`` and its parameters (prismatic ``direction``; revolute ``point``
    and ``direction``)."""

    kind: str
    direction: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def move(self, q: float, x: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point and a direction of the link moved by q (m or rad)."""
        if self.kind == "rigid":
            return x, e
        if self.kind == "prismatic":
            return x + q * self.direction, e
        r = rot(self.direction, q)
        return self.point + r @ (x - self.point), r @ e


@dataclass
class Presses:
    """Measurements and their labels, and the motions and pressed edges behind them."""

    points: np.ndarray
    edges: np.ndarray
    lines: np.ndarray
    configs: np.ndarray
    point_std: float
    edge_std: float
    motions: np.ndarray
    pressed: list[list[int]]

    @property
    def batch(self) -> tuple:
        """The positional arguments of the batch functions: points, edges and their stds."""
        return self.points, self.edges, self.point_std, self.edge_std

    @property
    def labels(self) -> dict:
        """The labels as keyword arguments."""
        return {"lines": self.lines, "configs": self.configs}


def press(
    rng: np.random.Generator,
    face: Face,
    joint: Joint,
    motions: np.ndarray,
    pressed: list[list[int]],
    sigma_x: float = SIGMA_X,
    sigma_e: float = SIGMA_E,
    slide: bool = True,
) -> Presses:
    """Press the face's edges at each configuration.

    Args:
        rng: the generator.
        face: the face at motion 0.
        joint: the joint.
        motions: (K,) the joint's motion at each configuration.
        pressed: for each configuration, the edges pressed there (indices of
            :meth:`Face.edges`).
        sigma_x, sigma_e: the noise (point std per axis, m; total RMS edge angle, rad).
        slide: the contact at a random place along the middle 80 % of the edge at every
            press (the contact slides along the edge); False: always at one place per edge
            (the "simple method" assumption).
    """
    edges = face.edges()
    place = {j: rng.uniform(-0.8, 0.8) for j in range(4)}
    pts, eds, lines, configs = [], [], [], []
    for k, (q, which) in enumerate(zip(motions, pressed)):
        for j in which:
            e0, mid, half = edges[j]
            t = rng.uniform(-0.8, 0.8) if slide else place[j]
            x, e = joint.move(q, mid + t * half * e0, e0)
            pts.append(x + rng.normal(0.0, sigma_x, 3))
            eds.append(perturb_edge(rng, e, sigma_e))
            lines.append(j)
            configs.append(k)
    return Presses(
        np.array(pts),
        np.array(eds),
        np.array(lines),
        np.array(configs),
        sigma_x,
        sigma_e,
        np.asarray(motions, dtype=float),
        pressed,
    )


def random_unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def scenario(
    rng: np.random.Generator,
    kind: str,
    planar: bool,
    n_configs: int = 4,
    motion: float = 1.0,
    edges_per_config: int = 2,
    sigma_e: float = SIGMA_E,
    slide: bool = True,
) -> tuple[Face, Joint, Presses]:
    """A random face, joint and probing at env-like scales.

    The face is 60-120 mm by 20-40 mm; ``"planar"``: lying on the table (normal +z), a
    revolute axis vertical through a pin 10-20 mm inside one end, a prismatic direction in
    the table plane at any angle; 3D: the face and the joint at random angles (a revolute
    axis through a pin near the face's end; a prismatic direction anywhere).

    ``motion`` scales the joint's sweep over the configurations: revolute 90 deg, prismatic
    60 mm times it, spread evenly from 0. At each configuration ``edges_per_config`` edges
    are pressed: the long edge first, then the end edge, then the other long edge.
    """
    hx, hy = rng.uniform(0.03, 0.06), rng.uniform(0.01, 0.02)
    if planar:
        yaw = rng.uniform(-math.pi, math.pi)
        ex = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        ez = np.array([0.0, 0.0, 1.0])
    else:
        ez = random_unit(rng)
        ex = np.cross(ez, random_unit(rng))
        ex /= np.linalg.norm(ex)
    ey = np.cross(ez, ex)
    centre = rng.uniform(-0.1, 0.1, 3) * [1.0, 1.0, 0.0] + [0.0, 0.0, 0.05]
    face = Face(centre, ex, ey, (hx, hy))
    if kind == "rigid":
        joint = Joint("rigid")
        sweep = 0.0
    elif kind == "prismatic":
        if planar:
            a = rng.uniform(-math.pi, math.pi)
            v = np.array([math.cos(a), math.sin(a), 0.0])
        else:
            v = random_unit(rng)
        joint = Joint("prismatic", v)
        sweep = 0.06 * motion
    else:
        u = ez if planar else random_unit(rng)
        pin = centre - (hx - rng.uniform(0.01, 0.02)) * ex
        joint = Joint("revolute", u, pin)
        sweep = math.radians(90.0) * motion
    motions = np.linspace(0.0, sweep, n_configs) * rng.choice([-1.0, 1.0])
    order = [0, 3, 2]
    pressed = [[order[m % 3] for m in range(edges_per_config)] for _ in range(n_configs)]
    return face, joint, press(rng, face, joint, motions, pressed, sigma_e=sigma_e, slide=slide)


def drawer(rng: np.random.Generator, slide: bool) -> tuple[np.ndarray, Presses]:
    """A drawer's top (300 x 200 mm) pulled along its sides at a random yaw: four
    displacements 10 mm apart, its front and a side edge pressed at each (issue 28 item 5).

    Returns:
        The true direction and the presses.
    """
    yaw = rng.uniform(-math.pi, math.pi)
    ex = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    ey = np.array([-ex[1], ex[0], 0.0])
    face = Face(np.array([0.1, 0.2, 0.15]), ex, ey, (0.15, 0.1))
    motions = np.arange(4) * 0.01
    return ey, press(rng, face, Joint("prismatic", ey), motions, [[0, 3]] * 4, slide=slide)
