"""Regime map: when does the edge measured from one wrench hold?

Run: ``python benchmarks/regime_map.py [--quick] [--readings N] [--seed S] [--figure PATH]
[--save PATH]``. Prints markdown tables and writes ``docs/figures/regime_map.png``;
``--quick`` runs a coarse grid for iteration (~20 s; the full map ~1.5 min). Single process,
single thread.

Every probe touches the scissors' free link 5 cm from the pin (docs/design.md 4.1), the finger
axis along the face normal and the sphere centre ``offset`` across the edge (negative: over
the face; positive: beyond the edge). The link is held firmly (holding torque ``HELD``) so
that the map shows the sensing alone; section 5 lets a link give way. The simulator's truth
(edge line, face normal) places the finger and scores the error; the gate quantities use
only what a robot has: the F/T reading and the fingertip's own pose.

Sections:

1. Presses and the shear map: press to 2 / 5 / 8 N along the face normal, then move the
   fingertip sideways at constant height by ``SHEARS`` (the skin sticks, then slips) in the
   direction ``theta`` from the across-edge outward direction toward the edge direction.
2. Oblique presses: the press path tilted ``alpha`` from the face normal along the edge or
   across it.
3. The gate: thresholds on the drag (3a), the drag rule (3b), the tilt (3c), the friction
   share (3d) and the combined gate on every probe (3e).
4. Slides along the edge with a contact-point trace, the path ``gamma`` off the edge.
5. A lid (axis horizontal) that gives way under the press.

Observables, world frame (the robot's base frame), from one reading:

* ``touch``: the fingertip position at the first reading with |f| above the contact
  threshold; ``path`` = unit(touch - now), the press path reversed (it points out of the
  object, like the force on the skin);
* ``deviation``: the angle between the path and the force line. A tilt that the truncated
  patch makes keeps the force on a path along the face normal (deviation <= 0.23 tilt,
  the rounded edge's share); a tilt that friction makes puts the force between the path
  and the skin normal (deviation >= tilt): the friction share deviation / tilt;
* ``drag`` = asin(|path . e|): the force is perpendicular to the measured edge e, so this is
  the angle between path and force line along e. Friction along the edge turns e by
  ~atan(c tan(drag) / tan(tilt)) (``bias_bound``);
* ``tilt``: the angle between the force and the skin normal at the contact point;
* ``travel``: the fingertip's travel since touchdown along the force line, against what a
  flat-face press needs for the same force (a link that gives way needs far more).
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from tactile_gym.sensing import (  # noqa: E402
    edge_from_trace,
    estimate_contact,
    indentation_depth,
)
from tactile_gym.sim import ObjectConfig, ProbeScene  # noqa: E402
from tactile_gym.spatial import matrix_to_quaternion, z_to  # noqa: E402

FIGURE = Path(__file__).resolve().parents[1] / "docs" / "figures" / "regime_map.png"

HELD = 1.0  # N m, holding torque that keeps the link still under every probe here
ALONG = 0.05  # m, probe position along the edge from the pin
CLEAR = 0.0005  # m, start of each press: this far from touching the face plane
PRESS_STEP = 0.0001  # m per control step (2 mm/s at 12 x 1/240 s)
SHEAR_STEP = 0.0001  # m per control step
SLIDE_STEP = 0.0002  # m per control step
SLIDE_LENGTH = 0.008  # m
SLIDE_SKIP = 0.002  # m, start of the slide left out of the fit (stick-slip onset)
SHEARS = (0.0001, 0.002)  # m: the skin sticks at the first, slips at the second
CONTACT_THRESHOLD = 0.2  # N, estimate_contact's default force_threshold

FORCES = (2.0, 5.0, 8.0)  # N
OFFSETS = tuple(np.round(np.arange(-6.0, 3.5, 1.0), 1) * 1e-3)  # m
THETAS = tuple(range(0, 360, 30))  # deg
ALPHAS = (0.0, 0.25, 0.5, 1.0, 2.0, 5.0)  # deg
OBLIQUE_OFFSETS = (-0.004, -0.002, -0.001, 0.0, 0.001, 0.002, 0.003)  # m
GAMMAS = (-5.0, -2.0, 0.0, 2.0, 5.0)  # deg, + drifts outward (beyond the edge)
SLIDE_OFFSETS = (-0.006, -0.004, -0.002, 0.0, 0.002)  # m
HOLDING = (HELD, 0.3, 0.25, 0.2, 0.1)  # N m, the lid's holding torques

QUICK = dict(
    OFFSETS=(-0.006, -0.003, -0.001, 0.0, 0.002),
    THETAS=tuple(range(0, 360, 90)),
    OBLIQUE_OFFSETS=(-0.002, 0.0, 0.002),
    GAMMAS=(0.0, 2.0),
    SLIDE_OFFSETS=(-0.004, 0.0),
    HOLDING=(HELD, 0.1),
)


# --- geometry and motion --------------------------------------------------------------------


@dataclass(frozen=True)
class ProbeFrame:
    """The probed spot of the edge, world frame (truth: used to place and to score only).

    Attributes:
        point: (3,) point of the edge line ``ALONG`` from the pin, m.
        along: (3,) unit edge direction.
        out: (3,) unit direction across the edge, in the face plane, away from the face.
        up: (3,) unit outward normal of the face.
    """

    point: np.ndarray
    along: np.ndarray
    out: np.ndarray
    up: np.ndarray

    def direction(self, theta: float) -> np.ndarray:
        """Unit vector in the face plane ``theta`` (rad) from ``out`` toward ``along``."""
        return math.cos(theta) * self.out + math.sin(theta) * self.along


def probe_frame(scene: ProbeScene) -> ProbeFrame:
    """The probed spot of the scene's free link at its current joint angle.

    The edge joins the link's +z_H face and its ``edge_side`` y_H face; the pressed face is
    the one that faces up more (the top face of the scissors, the top of a lid), the other
    is the side beyond the edge.
    """
    ep, ed = scene.edge_line
    rot = scene.object.link_rotation
    a, b = rot[:, 2], rot[:, 1] * scene.object_config.edge_side
    up, out = (a, b) if a[2] >= b[2] else (b, a)
    return ProbeFrame(ep + ALONG * ed, ed, out.copy(), up.copy())


def line_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two undirected lines, rad."""
    c = abs(float(a @ b)) / (float(np.linalg.norm(a)) * float(np.linalg.norm(b)))
    return math.acos(min(1.0, c))


@dataclass
class Touch:
    """A press that reached its force.

    Attributes:
        frame: the probed spot.
        quat: (4,) fingertip orientation held throughout, x y z w.
        touch: (3,) fingertip position at the first reading above ``CONTACT_THRESHOLD``, m.
        reached: whether |f| reached the press force.
    """

    frame: ProbeFrame
    quat: np.ndarray
    touch: np.ndarray
    reached: bool = True


def press(
    scene: ProbeScene,
    offset: float,
    force: float,
    *,
    joint_angle: float = 0.0,
    tilt: float = 0.0,
    tilt_toward: str = "along",
    max_travel: float | None = None,
) -> Touch:
    """Press the hemisphere onto the face near the edge until |f| reaches ``force``.

    The finger axis is the face normal; the path is the face normal tilted by ``tilt`` (rad)
    toward ``tilt_toward`` ("along": the edge direction; "out": across the edge, beyond it;
    "in": across, over the face). The guarded move stops the press at ``force``; the path is
    aimed so that it crosses the face plane at the sphere centre's ``offset`` across the edge.
    With ``max_travel`` (m) the press also stops that far past touchdown (the robot's
    sanity limit, for a link that gives way); otherwise not reaching ``force`` is an error.
    """
    scene.reset(joint_angle, [0.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0])
    fr = probe_frame(scene)
    g = scene.geometry
    quat = matrix_to_quaternion(z_to(-fr.up))
    side = {"along": fr.along, "out": fr.out, "in": -fr.out}[tilt_toward]
    path = -math.cos(tilt) * fr.up + math.sin(tilt) * side
    centre = fr.point + offset * fr.out + g.outer_radius * fr.up  # touching the face plane
    start = centre + g.cylinder_length * fr.up - CLEAR / math.cos(tilt) * path
    scene.reset(joint_angle, start, quat)
    scene.force_limit = force
    touch = None
    reached = False
    for k in range(1, 400):
        info = scene.control_step(start + k * PRESS_STEP * path, quat)
        if touch is None and np.linalg.norm(scene.true_wrench[:3]) > CONTACT_THRESHOLD:
            touch = scene.fingertip_position
        if info.force_limited:
            reached = True
            break
        if max_travel is not None and touch is not None:
            if np.linalg.norm(scene.fingertip_position - touch) > max_travel:
                break
    if not reached and max_travel is None:
        raise RuntimeError(f"press at offset {offset} m never reached {force} N")
    hold(scene, quat, 2)
    return Touch(fr, quat, touch, reached)


def hold(scene: ProbeScene, quat: np.ndarray, steps: int) -> None:
    """Keep the fingertip where it is for ``steps`` control steps."""
    pos = scene.fingertip_position
    for _ in range(steps):
        scene.control_step(pos, quat)


def move(scene: ProbeScene, quat: np.ndarray, displacement: np.ndarray, step: float) -> None:
    """Move the fingertip by ``displacement`` (m, world) in straight steps of at most ``step``,
    with the guarded move out of the way."""
    scene.force_limit = 50.0
    base = scene.fingertip_position
    n = max(1, math.ceil(float(np.linalg.norm(displacement)) / step - 1e-9))
    for k in range(1, n + 1):
        scene.control_step(base + displacement * k / n, quat)


# --- readings ---------------------------------------------------------------------------------


@dataclass
class Noisy:
    """Noisy readings of one probe (angles in rad; NaN where not defined).

    Attributes:
        errors: edge error against the truth, NaN where the edge is flagged.
        observables: ``edge_observable``.
        tilts, drags, deviations, edge_stds: the gate quantities of each reading.
    """

    errors: np.ndarray
    observables: np.ndarray
    tilts: np.ndarray
    drags: np.ndarray
    deviations: np.ndarray
    edge_stds: np.ndarray

    def stats(self) -> tuple[float, float, float]:
        """(median, P95) of the error over the readings whose edge is observable, rad, and the
        fraction flagged; NaN errors when fewer than a quarter (or 3) are observable."""
        ok = self.observables
        if ok.sum() < max(3, len(ok) // 4):
            return math.nan, math.nan, 1.0 - ok.mean()
        err = self.errors[ok]
        return float(np.median(err)), float(np.quantile(err, 0.95)), 1.0 - ok.mean()


@dataclass
class Readings:
    """Edge errors and gate quantities of one probe: the noise-free wrench and noisy readings.

    Scalars are the noise-free reading (angles in rad; error and drag NaN where the edge is
    flagged, ``edge_observable`` False). ``force``: |f|, N; ``joint``: the joint angle, rad
    (truth, to check that the link stayed put); ``travel``: the fingertip's travel since
    touchdown along the force line (into the object), m; ``travel_ratio``: travel over what
    a flat-face press to |f| needs (``expected_travel``); ``point_offset``: the corrected
    contact point's offset across the edge, m, + beyond it (truth, a diagnostic).
    ``single``: single readings; ``mean``: means of ``AVERAGE`` readings each, estimated
    with the noise they leave (sigma / sqrt(AVERAGE)), as a 0.5 s hold at 20 Hz gives.
    """

    error: float
    observable: bool
    tilt: float
    drag: float
    deviation: float
    edge_std: float
    force: float
    joint: float
    travel: float
    travel_ratio: float
    point_offset: float
    single: Noisy
    mean: Noisy

    def noisy_stats(self) -> tuple[float, float, float]:
        """``single.stats()``."""
        return self.single.stats()


AVERAGE = 10  # readings per mean


def observe(scene: ProbeScene, wrench: np.ndarray, touch: np.ndarray, noise_scale: float = 1.0):
    """(estimate, error, drag, deviation) of one reading: error against the true edge (rad,
    NaN if flagged); drag and deviation from the fingertip's path and the wrench only.
    ``noise_scale`` scales the sensor noise the estimate assumes (1/sqrt(n) for a mean)."""
    cfg = scene.sensor_config
    est = estimate_contact(
        wrench[:3],
        wrench[3:],
        scene.geometry,
        skin_stiffness=scene.skin_config.normal_stiffness,
        force_noise_std=cfg.force_noise_std * noise_scale,
        moment_noise_std=cfg.moment_noise_std * noise_scale,
    )
    if not est.valid:
        return est, math.nan, math.nan, math.nan
    path = touch - scene.fingertip_position
    force = scene.sensor_to_world_vector(wrench[:3])
    deviation = line_angle(path, force)
    if not est.edge_observable:
        return est, math.nan, math.nan, deviation
    edge = scene.sensor_to_world_vector(est.edge_direction)
    error = line_angle(edge, scene.edge_line[1])
    drag = math.asin(min(1.0, abs(float(path @ edge)) / float(np.linalg.norm(path))))
    return est, error, drag, deviation


def _noisy(scene, touch, rng, n, average) -> Noisy:
    rows = []
    for _ in range(n):
        w = np.mean([scene.read_wrench(rng) for _ in range(average)], axis=0)
        e, err, dr, dv = observe(scene, w, touch, 1.0 / math.sqrt(average))
        rows.append((err, e.edge_observable, e.tilt, dr, dv, e.edge_std))
    a = np.array(rows, dtype=float).reshape(n, 6)
    return Noisy(a[:, 0], a[:, 1].astype(bool), a[:, 2], a[:, 3], a[:, 4], a[:, 5])


def across_offset(scene: ProbeScene, point: np.ndarray) -> float:
    """Signed offset of a world point across the probed edge, m, + beyond it (truth)."""
    fr = probe_frame(scene)
    return float((point - fr.point) @ fr.out)


def expected_travel(scene: ProbeScene, force: float) -> float:
    """Fingertip travel from touchdown (|f| = ``CONTACT_THRESHOLD``) to |f| = ``force`` on a
    flat face, m: the Winkler sphere-on-plane indentation (observable: the skin's model and
    the reading, no truth)."""
    k_n, radius = scene.skin_config.normal_stiffness, scene.geometry.outer_radius
    depth = indentation_depth(np.array([force, CONTACT_THRESHOLD]), k_n, radius, "plane")
    return float(depth[0] - depth[1])


def read(scene: ProbeScene, touch: np.ndarray, rng: np.random.Generator, n: int) -> Readings:
    """The noise-free reading, ``n`` single noisy ones and ``n`` means of ``AVERAGE``."""
    est, error, drag, dev = observe(scene, scene.true_wrench, touch)
    force = scene.sensor_to_world_vector(scene.true_wrench[:3])
    travel = abs(float((touch - scene.fingertip_position) @ force)) / float(np.linalg.norm(force))
    return Readings(
        error=error,
        observable=bool(est.edge_observable),
        tilt=est.tilt,
        drag=drag,
        deviation=dev,
        edge_std=est.edge_std,
        force=float(np.linalg.norm(scene.true_wrench[:3])),
        joint=scene.joint_angle,
        travel=travel,
        travel_ratio=travel / expected_travel(scene, float(np.linalg.norm(scene.true_wrench[:3]))),
        point_offset=across_offset(scene, scene.sensor_to_world_point(est.corrected_point)),
        single=_noisy(scene, touch, rng, n, 1),
        mean=_noisy(scene, touch, rng, n, AVERAGE),
    )


# --- 1. shear map ---------------------------------------------------------------------------


def shear_map(scene, rng, n_read, forces, offsets, thetas):
    """Press, then shear at constant height: {(force, offset, theta_deg, size): Readings};
    theta None and size 0 for the press alone."""
    out = {}
    for force in forces:
        for off in offsets:
            t = press(scene, off, force)
            out[(force, off, None, 0.0)] = read(scene, t.touch, rng, n_read)
            for th in thetas:
                t = press(scene, off, force)
                done = 0.0
                for size in SHEARS:
                    move(
                        scene,
                        t.quat,
                        (size - done) * t.frame.direction(math.radians(th)),
                        SHEAR_STEP,
                    )
                    hold(scene, t.quat, 2)
                    done = size
                    out[(force, off, th, size)] = read(scene, t.touch, rng, n_read)
    return out


# --- 2. oblique presses -----------------------------------------------------------------------

OBLIQUE_DIRS = ("along", "out", "in")


def oblique_presses(scene, rng, n_read, forces, offsets):
    """Presses along a path ``alpha`` off the face normal: {(force, dir, offset, alpha_deg):
    Readings}."""
    out = {}
    for force in forces:
        for toward in OBLIQUE_DIRS:
            for off in offsets:
                for a in ALPHAS:
                    t = press(scene, off, force, tilt=math.radians(a), tilt_toward=toward)
                    out[(force, toward, off, a)] = read(scene, t.touch, rng, n_read)
    return out


# --- 4. slides along the edge -----------------------------------------------------------------


@dataclass
class Slide:
    """A slide along the edge and the line fitted through its contact points.

    Angles in rad, lengths in m. ``fit_error`` and ``tilt_*`` from the noise-free wrench,
    ``fit_errors`` one per noisy trace (one reading per step). ``across``: the force's tilt
    from the skin normal perpendicular to the fingertip's path (friction does not produce it;
    the truncated patch does), mean over the fitted part; ``across_slope``: its change per
    metre of travel; ``drift``: the contact point's motion in the sensor frame perpendicular
    to the path, per metre of travel; ``edge_distance``: the corrected contact point's
    distance from the true edge line at the start and end of the fitted part (truth).
    """

    fit_error: float
    fit_std: float
    fit_errors: np.ndarray
    across: float
    across_slope: float
    across_slopes: np.ndarray
    drift: float
    drifts: np.ndarray
    along: float
    point_offset: tuple[float, float]
    centroid_offset: tuple[float, float]
    wrench_error: float


def _slide_observables(scene, est, path_dir):
    """(corrected point world, across tilt, along tilt, sensor-frame point) of one estimate."""
    n = scene.sensor_to_world_vector(est.normal)
    f = scene.sensor_to_world_vector(est.force)
    d = path_dir - (path_dir @ n) * n
    d /= np.linalg.norm(d)
    c = np.cross(n, d)
    fn = -float(f @ n)
    across = math.atan2(float(f @ c), fn)
    along = math.atan2(float(f @ d), fn)
    return scene.sensor_to_world_point(est.corrected_point), across, along, est.corrected_point


def _trace_stats(points, across, sensor_pts, travel, path_sensor_across):
    direction, std = edge_from_trace(points)
    slope = np.polyfit(travel, across, 1)[0]
    drift = np.polyfit(travel, sensor_pts @ path_sensor_across, 1)[0]
    return direction, std, slope, drift


def slide(scene, rng, n_traces, offset, gamma, force=5.0) -> Slide:
    """Press at ``offset``, then move ``SLIDE_LENGTH`` at constant height along the edge
    turned ``gamma`` (rad) outward, one control step per ``SLIDE_STEP``."""
    k_n = scene.skin_config.normal_stiffness
    t = press(scene, offset, force)
    fr = t.frame
    path = math.cos(gamma) * fr.along + math.sin(gamma) * fr.out
    n_steps = round(SLIDE_LENGTH / SLIDE_STEP)
    base = scene.fingertip_position
    scene.force_limit = 50.0
    clean, noisy, travel, wrench_err = [], [[] for _ in range(n_traces)], [], []
    centroids = []
    for i in range(1, n_steps + 1):
        scene.control_step(base + i * SLIDE_STEP * path, t.quat)
        if i * SLIDE_STEP <= SLIDE_SKIP + 1e-9:
            continue
        travel.append(i * SLIDE_STEP)
        w = scene.true_wrench
        est = estimate_contact(w[:3], w[3:], scene.geometry, skin_stiffness=k_n)
        clean.append(_slide_observables(scene, est, path))
        centroids.append(scene.contact_centroid)
        if est.edge_observable:
            e = scene.sensor_to_world_vector(est.edge_direction)
            wrench_err.append(line_angle(e, fr.along))
        for k in range(n_traces):
            w = scene.read_wrench(rng)
            est = estimate_contact(w[:3], w[3:], scene.geometry, skin_stiffness=k_n)
            noisy[k].append(_slide_observables(scene, est, path))
    travel = np.array(travel)
    centroids = [c for c in centroids if c is not None]
    # The direction across the path in the sensor frame (the finger does not turn).
    across_s = scene.world_to_sensor_vector(np.cross(fr.up, path))

    def stats(rows):
        pts = np.array([r[0] for r in rows])
        acr = np.array([r[1] for r in rows])
        sen = np.array([r[3] for r in rows])
        direction, std, slope, drift = _trace_stats(pts, acr, sen, travel, across_s)
        return (
            line_angle(direction, fr.along),
            std,
            slope,
            drift,
            acr,
            np.array([r[2] for r in rows]),
        )

    err, std, slope, drift, acr, alg = stats(clean)
    noisy_stats = [stats(rows) for rows in noisy]
    return Slide(
        fit_error=err,
        fit_std=std,
        fit_errors=np.array([s[0] for s in noisy_stats]),
        across=float(np.mean(np.abs(acr))),
        across_slope=slope,
        across_slopes=np.array([s[2] for s in noisy_stats]),
        drift=drift,
        drifts=np.array([s[3] for s in noisy_stats]),
        along=float(np.mean(np.abs(alg))),
        point_offset=(
            across_offset(scene, clean[0][0]),
            across_offset(scene, clean[-1][0]),
        ),
        centroid_offset=(
            across_offset(scene, centroids[0]),
            across_offset(scene, centroids[-1]),
        ),
        wrench_error=float(np.median(wrench_err)) if wrench_err else math.nan,
    )


# --- 5. a link that moves -----------------------------------------------------------------------

LID_ANGLE = 0.3  # rad, the lid's opening when the press starts
LINK_TRAVEL = 0.004  # m, the press gives up this far past touchdown
HOLD_STEPS = 20  # control steps of 0.05 s


@dataclass
class LinkRun:
    """A press on a lid (its axis horizontal, so the press turns it) and a 1 s hold.

    Attributes:
        end: the readings at the end of the press.
        reached: whether the press reached its force before ``LINK_TRAVEL``.
        turn: joint angle change over the press, rad (truth).
        turn_hold: joint angle change over the hold, rad (truth).
        force_change: |f| change over the hold, N.
        drift: contact point drift rate over the hold, noise-free, m/s.
        drifts: the same from noisy readings (one per control step), one per seed, m/s.
    """

    end: Readings
    reached: bool
    turn: float
    turn_hold: float
    force_change: float
    drift: float
    drifts: np.ndarray


def link_run(scene, rng, n_read, n_seeds, holding, force=5.0) -> LinkRun:
    """Press the edge of a lid opened ``LID_ANGLE`` and held by ``holding`` N m, along its
    face normal at offset 0, then keep the fingertip still for 1 s."""
    cfg = ObjectConfig.lid(holding_torque=holding)
    scene.reset(LID_ANGLE, [0.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0], object_config=cfg)
    t = press(scene, 0.0, force, joint_angle=LID_ANGLE, max_travel=LINK_TRAVEL)
    end = read(scene, t.touch, rng, n_read)
    q1, f1 = scene.joint_angle, float(np.linalg.norm(scene.true_wrench[:3]))
    k_n = scene.skin_config.normal_stiffness
    times = np.arange(HOLD_STEPS) * scene.substeps * scene.time_step
    clean, noisy = [], [[] for _ in range(n_seeds)]
    pos = scene.fingertip_position
    for _ in range(HOLD_STEPS):
        scene.control_step(pos, t.quat)
        for rows, w in [(clean, scene.true_wrench)] + [
            (rows, scene.read_wrench(rng)) for rows in noisy
        ]:
            est = estimate_contact(w[:3], w[3:], scene.geometry, skin_stiffness=k_n)
            rows.append(est.corrected_point)

    def rate(rows):
        return float(np.linalg.norm(np.polyfit(times, np.array(rows), 1)[0]))

    return LinkRun(
        end=end,
        reached=t.reached,
        turn=q1 - LID_ANGLE,
        turn_hold=scene.joint_angle - q1,
        force_change=float(np.linalg.norm(scene.true_wrench[:3])) - f1,
        drift=rate(clean),
        drifts=np.array([rate(r) for r in noisy]),
    )


# --- reporting ----------------------------------------------------------------------------------


def deg(x: float, digits: int = 1) -> str:
    """An angle in rad as degrees, "—" for NaN."""
    return "—" if not np.isfinite(x) else f"{math.degrees(x):.{digits}f}"


def mm(x: float, digits: int = 1) -> str:
    return "—" if not np.isfinite(x) else f"{1e3 * x:+.{digits}f}"


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def print_presses(shears, forces, offsets) -> None:
    print("\n### 1a. Presses along the face normal (no shear); cells: 2 · 5 · 8 N\n")
    rows = []
    for off in offsets:
        cells = [[] for _ in range(8)]
        for force in forces:
            r = shears[(force, off, None, 0.0)]
            med, p, flagged = r.single.stats()
            med10, p10, _ = r.mean.stats()
            cells[0].append(deg(r.tilt))
            cells[1].append(deg(r.error))
            cells[2].append(f"{deg(med)}/{deg(p)}")
            cells[3].append(f"{deg(med10)}/{deg(p10)}")
            cells[4].append(f"{100 * flagged:.0f}")
            cells[5].append(deg(r.deviation, 2))
            cells[6].append(f"{1e3 * r.travel:.2f} ({r.travel_ratio:.1f})")
            cells[7].append(mm(r.point_offset))
        rows.append([mm(off)] + [" · ".join(c) for c in cells])
    print(
        table(
            [
                "offset (mm)",
                "tilt (deg)",
                "error (deg)",
                "single med/P95 (deg)",
                f"mean of {AVERAGE} med/P95",
                "flagged (%)",
                "deviation (deg)",
                "travel, mm (/ flat-face travel)",
                "contact point across (mm)",
            ],
            rows,
        )
    )


def print_shear_map(shears, forces, offsets, thetas) -> None:
    for size in SHEARS:
        for force in forces:
            print(
                f"\n### 1b. Shear {1e3 * size:.1f} mm after a {force:.0f} N press: noise-free "
                "error (noisy P95), deg; — flagged\n"
            )
            rows = []
            for off in offsets:
                row = [mm(off)]
                for th in thetas:
                    r = shears[(force, off, th, size)]
                    _, p95, _ = r.noisy_stats()
                    row.append(f"{deg(r.error, 0)} ({deg(p95, 0)})")
                rows.append(row)
            print(table(["offset (mm) \\ theta (deg)"] + [str(t) for t in thetas], rows))


def print_oblique(obl, force, offsets) -> None:
    print(
        f"\n### 2. Oblique presses at {force:.0f} N: noise-free error / drag (deg), by path "
        "angle alpha\n"
    )
    rows = []
    for toward in OBLIQUE_DIRS:
        for off in offsets:
            row = [toward, mm(off), deg(obl[(force, toward, off, 0.0)].tilt)]
            for a in ALPHAS:
                r = obl[(force, toward, off, a)]
                row.append(f"{deg(r.error)} / {deg(r.drag, 2)}")
            rows.append(row)
    print(table(["path tilted", "offset (mm)", "tilt (deg)"] + [f"{a:g}" for a in ALPHAS], rows))


DRAG_TO_TILT = 1.7  # friction tilt along the edge per unit drag, the largest measured
#: A tilt made by the truncated patch keeps the force on the press path (deviation <= 0.23
#: tilt measured, the rounded edge's share); one made by friction puts the force between the
#: path and the skin normal (deviation >= 1.05 tilt measured). The gate keeps deviation <=
#: FRICTION_SHARE x tilt.
FRICTION_SHARE = 0.5


def bias_bound(drag, tilt, ratio: float = DRAG_TO_TILT):
    """Edge error that a drag of the force along the edge predicts, rad.

    Friction tilts the force along the edge by beta; the truncated patch tilts it by ``tilt``
    across; the measured edge then turns by atan(tan(beta) / tan(tilt)). beta is not
    observable, but the drag (the path-force angle along the measured edge) is, and with the
    skin sticking beta = ``ratio`` x drag:

    * a press along a path alpha off the face normal: each node's tangential offset is its
      penetration times tan(alpha), so beta = atan(tan(alpha) k_t/k_n) = alpha/3 for the
      Winkler skin (k_t = k_n/3), and drag = alpha - beta = 2 beta: ratio 1/2;
    * a sideways move after the press: all nodes in contact move together, and beta is
      1.1-1.7 x drag (measured on the shear map where the error is 3-10 deg): the worst
      case, hence the default ``DRAG_TO_TILT``.
    """
    return np.arctan(ratio * np.tan(np.asarray(drag)) / np.tan(np.asarray(tilt)))


FIELDS = ("errors", "observables", "drags", "deviations", "tilts", "edge_stds")


def pool(readings: list[Readings], kind: str) -> dict[str, np.ndarray]:
    """The ``kind`` ("single", "mean" or "clean": the noise-free reading) readings of many
    probes, concatenated: {field: array} with ``FIELDS`` as names."""
    if kind == "clean":
        names = ("error", "observable", "drag", "deviation", "tilt", "edge_std")
        return {f: np.array([getattr(r, n) for r in readings]) for f, n in zip(FIELDS, names)}
    return {f: np.concatenate([getattr(getattr(r, kind), f) for r in readings]) for f in FIELDS}


def passes(
    p: dict[str, np.ndarray],
    drag: float = math.inf,
    std: float = math.inf,
    budget: float | None = None,
    share: float = FRICTION_SHARE,
) -> np.ndarray:
    """Readings that pass a gate: edge observable, deviation at most ``share`` x tilt, drag
    at most ``drag`` (rad), ``edge_std`` at most ``std`` (rad), and, with ``budget`` (rad),
    the drag rule's bias plus twice edge_std within it."""
    with np.errstate(invalid="ignore"):
        keep = p["observables"].astype(bool) & (p["drags"] <= drag)
        keep &= (p["deviations"] <= share * p["tilts"]) & (p["edge_stds"] <= std)
        if budget is not None:
            keep &= bias_bound(p["drags"], p["tilts"]) + 2.0 * p["edge_stds"] <= budget
    return keep


def p95(x) -> float:
    return float(np.quantile(x, 0.95)) if len(x) >= 5 else math.nan


GATE_DRAGS = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, math.inf)  # deg
GATE_STD = 1.5  # deg


def _cell(p, keep) -> str:
    return f"{deg(p95(p['errors'][keep]))} ({100 * keep.mean():.0f} %)"


def gate_sweep(readings, label) -> dict[str, dict[float, float]]:
    """Print the P95 of the error under drag <= A (deviation <= ``FRICTION_SHARE`` x tilt);
    return
    {column: {A: P95}}."""
    pools = {kind: pool(readings, kind) for kind in ("clean", "single", "mean")}
    print(
        f"\n### 3a. Gate on the drag, {label}: P95 of the edge error, deg (share passing), "
        f"deviation <= {FRICTION_SHARE:g} x tilt\n"
    )
    columns = {
        "noise-free": ("clean", math.inf),
        "single": ("single", math.inf),
        f"single, edge_std <= {GATE_STD:g}": ("single", GATE_STD),
        f"mean of {AVERAGE}": ("mean", math.inf),
        f"mean of {AVERAGE}, edge_std <= {GATE_STD:g}": ("mean", GATE_STD),
    }
    out: dict[str, dict[float, float]] = {c: {} for c in columns}
    rows = []
    for a in GATE_DRAGS:
        row = ["any" if math.isinf(a) else f"{a:g}"]
        for name, (kind, s) in columns.items():
            p = pools[kind]
            keep = passes(p, math.radians(a), math.radians(s))
            out[name][a] = p95(p["errors"][keep])
            row.append(_cell(p, keep))
        rows.append(row)
    print(table(["drag <= (deg)", *columns], rows))
    return out


def print_friction_share(groups: dict[str, list[Readings]]) -> None:
    """Deviation / tilt: near 0 when the truncated patch tilts the force, >= 1 when friction
    does."""
    print(
        "\n### 3d. Friction share: deviation / tilt of the observable readings (noise-free; "
        f"single: share passing deviation <= {FRICTION_SHARE:g} tilt), and the error of those "
        "that pass and fail\n"
    )
    rows = []
    for name, readings in groups.items():
        clean = pool(readings, "clean")
        ok = clean["observables"].astype(bool)
        if not ok.any():
            continue
        ratio = clean["deviations"][ok] / clean["tilts"][ok]
        keep = passes(clean)
        fail = ok & ~keep
        single = pool(readings, "single")
        s_ok = single["observables"].astype(bool)
        rows.append(
            [
                name,
                str(int(ok.sum())),
                f"{ratio.min():.2f} / {np.median(ratio):.2f} / {ratio.max():.2f}",
                f"{100 * keep[ok].mean():.0f}",
                deg(np.max(clean["errors"][keep])) if keep.any() else "—",
                deg(np.min(clean["errors"][fail])) if fail.any() else "—",
                f"{100 * passes(single)[s_ok].mean():.0f}" if s_ok.any() else "—",
            ]
        )
    print(
        table(
            [
                "probes",
                "observable",
                "deviation/tilt min / median / max",
                "pass (%)",
                "largest error passing",
                "smallest error failing",
                "single readings pass (%)",
            ],
            rows,
        )
    )


def print_budget_gate(groups: dict[str, list[Readings]]) -> None:
    """The combined gate: drag rule bias + 2 edge_std within a budget, deviation bounded."""
    print(
        "\n### 3e. Combined gate: observable, deviation <= "
        f"{FRICTION_SHARE:g} x tilt, atan({DRAG_TO_TILT:g} tan(drag)/tan(tilt)) + 2 edge_std <= "
        "budget. "
        "P95 of the error, deg (share passing)\n"
    )
    rows = []
    for name, readings in groups.items():
        row = [name]
        for kind in ("clean", "single", "mean"):
            p = pool(readings, kind)
            ok = p["observables"].astype(bool)
            row.append(_cell(p, ok))
            for budget in (3.0, 5.0):
                keep = passes(p, budget=math.radians(budget))
                row.append(_cell(p, keep))
        rows.append(row)
    header = ["probes"]
    for kind in ("noise-free", "single", f"mean of {AVERAGE}"):
        header += [f"{kind}: observable", "budget 3", "budget 5"]
    print(table(header, rows))


def print_bias_rule(groups: dict[str, list[Readings]]) -> None:
    print(
        f"\n### 3b. The drag rule: noise-free error / atan({DRAG_TO_TILT:g} tan(drag)/tan(tilt)), "
        "probes whose "
        f"error exceeds 1 deg and whose deviation is at most {FRICTION_SHARE:g} x tilt\n"
    )
    rows = []
    for name, readings in groups.items():
        ratio = np.array(
            [
                r.error / float(bias_bound(r.drag, r.tilt))
                for r in readings
                if r.observable
                and r.error > math.radians(1.0)
                and r.drag > 0
                and r.deviation <= FRICTION_SHARE * r.tilt
            ]
        )
        if not len(ratio):
            continue
        q = np.quantile(ratio, [0.05, 0.5, 0.95])
        rows.append([name, str(len(ratio)), f"{q[1]:.2f}", f"{q[0]:.2f}-{q[2]:.2f}"])
    print(table(["probes", "count", "median ratio", "5-95 %"], rows))


STRAIGHT_PRESS = 0.5  # drag-to-tilt ratio of a straight press along an oblique path


def print_tilt_rule(obl, force, offsets) -> None:
    print(
        f"\n### 3c. Edge error against the tilt, {force:.0f} N along-edge presses: noise-free "
        f"error (rule with c = {STRAIGHT_PRESS:g}, a straight press / c = {DRAG_TO_TILT:g}, any "
        "path), deg\n"
    )
    rows = []
    for off in offsets:
        r0 = obl[(force, "along", off, 0.0)]
        row = [mm(off), deg(r0.tilt)]
        for a in ALPHAS[1:]:
            r = obl[(force, "along", off, a)]
            low = float(bias_bound(r.drag, r.tilt, STRAIGHT_PRESS))
            row.append(f"{deg(r.error)} ({deg(low)}/{deg(float(bias_bound(r.drag, r.tilt)))})")
        rows.append(row)
    print(table(["offset (mm)", "tilt (deg)"] + [f"alpha {a:g}" for a in ALPHAS[1:]], rows))
    print(
        "\nLeast tilt (deg) that keeps the bias of a residual drag under 1 / 3 / 5 deg, "
        f"tilt = atan(c tan(drag) / tan(bias)): straight press (c = {STRAIGHT_PRESS:g}) / any "
        f"path (c = {DRAG_TO_TILT:g})\n"
    )
    rows = []
    for d in (0.1, 0.25, 0.5, 1.0):
        cells = []
        for b in (1.0, 3.0, 5.0):
            tb = math.tan(math.radians(b))
            lo, hi = (
                math.atan(c * math.tan(math.radians(d)) / tb)
                for c in (STRAIGHT_PRESS, DRAG_TO_TILT)
            )
            cells.append(f"{math.degrees(lo):.1f} / {math.degrees(hi):.1f}")
        rows.append([f"{d:g}", *cells])
    print(table(["drag (deg)", "bias 1 deg", "bias 3 deg", "bias 5 deg"], rows))


def print_slides(slides) -> None:
    print(
        "\n### 4. Slides along the edge (8 mm at constant height, first 2 mm left out): line "
        "through the contact points; angles in deg\n"
    )
    rows = []
    for (force, off, gam), s in slides.items():
        rows.append(
            [
                f"{force:g}",
                mm(off),
                f"{gam:+g}",
                deg(s.fit_error, 2),
                f"{deg(np.median(s.fit_errors), 2)}/{deg(p95(s.fit_errors), 2)}",
                deg(s.fit_std, 1),
                deg(s.along),
                deg(s.across, 2),
                f"{math.degrees(s.across_slope) * 1e-3:+.2f} "
                f"({math.degrees(np.median(np.abs(s.across_slopes))) * 1e-3:.2f})",
                f"{s.drift:+.3f} ({np.median(np.abs(s.drifts)):.3f})",
                f"{mm(s.point_offset[0], 2)}->{mm(s.point_offset[1], 2)}",
                f"{mm(s.centroid_offset[0], 2)}->{mm(s.centroid_offset[1], 2)}",
                deg(s.wrench_error, 0),
            ]
        )
    print(
        table(
            [
                "force (N)",
                "offset (mm)",
                "gamma (deg)",
                "fit error",
                "noisy med/P95",
                "trace std",
                "along tilt",
                "across tilt",
                "across-tilt slope, deg/mm (noisy |.|)",
                "drift mm/mm (noisy |.|)",
                "contact point across (mm)",
                "true centroid across (mm)",
                "one-wrench error",
            ],
            rows,
        )
    )


def print_link(runs) -> None:
    print(
        f"\n### 5. A link that gives way: 5 N press along the face normal at offset 0 on a lid "
        f"opened {math.degrees(LID_ANGLE):.0f} deg (its axis horizontal: the press turns it), "
        f"giving up {1e3 * LINK_TRAVEL:.0f} mm past touchdown; then 1 s with the fingertip "
        "still\n"
    )
    rows = []
    for h, r in runs.items():
        e = r.end
        med, p, _ = e.noisy_stats()
        rows.append(
            [
                f"{h:g}",
                f"{math.degrees(r.turn):.2f}",
                f"{e.force:.2f}",
                f"{1e3 * e.travel:.2f} ({e.travel_ratio:.1f})",
                deg(e.drag, 2),
                deg(e.deviation, 2),
                deg(e.tilt),
                deg(e.error),
                f"{deg(med)}/{deg(p)}",
                f"{math.degrees(r.turn_hold):.3f}",
                f"{r.force_change:+.3f}",
                f"{1e3 * r.drift:.3f} ({1e3 * np.median(r.drifts):.3f})",
            ]
        )
    print(
        table(
            [
                "holding (N m)",
                "turn in press (deg)",
                "|f| (N)",
                "travel, mm (/ flat-face)",
                "drag",
                "deviation",
                "tilt",
                "error",
                "noisy med/P95",
                "turn in hold (deg)",
                "|f| change in hold (N)",
                "contact drift mm/s (noisy)",
            ],
            rows,
        )
    )


TRAVEL_RATIO_MAX = 2.5  # travel since touchdown over a flat-face press's, at most


def print_summary(shears, obl, links) -> None:
    """The gate this benchmark supports, with the numbers it rests on."""
    held = [r for k, r in shears.items() if k[3] == 0.0] + list(obl.values())
    ratio_held = max(r.travel_ratio for r in held if r.travel > 0)
    gave = [r.end.travel_ratio for r in links.values() if abs(r.turn) > math.radians(0.1)]
    print("\n### Gate supported here (observables only; tables 1a, 3a-3e, 5)\n")
    print(
        "1. `edge_observable` (tilt_snr > 3).\n"
        f"2. Friction share: deviation <= {FRICTION_SHARE:g} x tilt (deviation: path since "
        "touchdown vs force line).\n"
        f"3. Drag bias plus noise: atan({DRAG_TO_TILT:g} tan(drag)/tan(tilt)) + 2 edge_std <= "
        "budget (drag: path-force angle along the measured edge).\n"
        f"4. A press's travel since touchdown <= {TRAVEL_RATIO_MAX:g} x a flat-face press's to "
        f"the same force (presses on the held link here: at most {ratio_held:.1f}; links that "
        "gave way: " + (", ".join(f"{g:.1f}" for g in gave) if gave else "none in this run") + ")."
    )


# --- figure -------------------------------------------------------------------------------------

BOUNDS = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 45.0, 90.0)  # deg, colour bins


def plot(path, shears, obl, slides, forces, offsets, thetas) -> None:
    """Heat maps of the shear map and the gate's support; writes a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm

    cmap = plt.get_cmap("YlOrRd", len(BOUNDS) - 1).copy()
    cmap.set_bad("0.8")
    norm = BoundaryNorm(BOUNDS, cmap.N)
    fig, axes = plt.subplots(
        4, len(forces), figsize=(4.4 * len(forces), 15.0), layout="constrained"
    )
    cols = [None, *thetas]
    y = 1e3 * np.array(offsets)
    panels = [
        (SHEARS[0], False, f"noise-free, shear {1e3 * SHEARS[0]:.1f} mm"),
        (SHEARS[0], True, f"noisy P95, shear {1e3 * SHEARS[0]:.1f} mm"),
        (SHEARS[1], False, f"noise-free, shear {1e3 * SHEARS[1]:.0f} mm (slips)"),
    ]
    for row, (size, noisy, title) in enumerate(panels):
        for j, force in enumerate(forces):
            ax = axes[row, j]
            grid = np.full((len(offsets), len(cols)), np.nan)
            flagged = np.zeros_like(grid, dtype=bool)
            for i, off in enumerate(offsets):
                for k, th in enumerate(cols):
                    r = shears[(force, off, th, 0.0 if th is None else size)]
                    if noisy:
                        _, value, frac = r.noisy_stats()
                        flagged[i, k] = frac > 0.5
                    else:
                        value, flagged[i, k] = r.error, not r.observable
                    grid[i, k] = math.degrees(value) if np.isfinite(value) else np.nan
            ax.pcolormesh(
                np.arange(len(cols) + 1) - 0.5,
                np.concatenate([y - 0.5, [y[-1] + 0.5]]),
                np.ma.masked_invalid(grid),
                cmap=cmap,
                norm=norm,
            )
            ii, kk = np.nonzero(flagged)
            ax.plot(kk, y[ii], "x", color="0.3", ms=4)
            ax.axvline(0.5, color="k", lw=1)
            ax.axhline(0.0, color="k", lw=0.5, ls=":")
            ax.set_xticks(range(len(cols)))
            ax.set_xticklabels(["none"] + [str(t) if t in (90, 180, 270) else "" for t in thetas])
            ax.set_title(f"{force:.0f} N: {title}", fontsize=9)
            if j == 0:
                ax.set_ylabel("centre offset across the edge (mm)")
            if row == len(panels) - 1:
                ax.set_xlabel("shear direction from across-edge outward (deg)")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(
        sm, ax=axes[:3, -1].tolist(), label="edge error (deg); grey/x: flagged", shrink=0.5
    )

    # Gate support: error against the drag and against the rule; slide traces. Probes whose
    # tilt is mostly friction (deviation > FRICTION_SHARE x tilt) in grey.
    probes = {
        "o": [r for r in obl.values() if r.observable and r.drag > 0],
        "s": [r for k, r in shears.items() if k[3] == SHEARS[0] and r.observable and r.drag > 0],
    }
    shared = {m: [r.deviation <= FRICTION_SHARE * r.tilt for r in rs] for m, rs in probes.items()}
    ax = axes[3, 0]
    for marker, rs in probes.items():
        ok = np.array(shared[marker])
        x = np.degrees([r.drag for r in rs])
        y = np.degrees([r.error for r in rs])
        ax.scatter(x[~ok], y[~ok], s=6, marker=marker, c="0.75")
        sc = ax.scatter(
            x[ok],
            y[ok],
            c=np.degrees([r.tilt for r in rs])[ok],
            s=7,
            marker=marker,
            cmap="viridis",
            vmin=0.0,
            vmax=20.0,
        )
    fig.colorbar(sc, ax=ax, label="tilt (deg)")
    d = np.logspace(-2, 1, 50)
    for t in (4.0, 8.0, 14.0):
        ax.plot(d, np.degrees(bias_bound(np.radians(d), np.radians(t))), "k--", lw=0.7)
        ax.text(d[-1], math.degrees(bias_bound(math.radians(d[-1]), math.radians(t))), f"{t:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.005, 10)
    ax.set_ylim(0.01, 90)
    ax.set_xlabel("drag: path-force angle along the edge (deg)")
    ax.set_ylabel("noise-free edge error (deg)")
    ax.set_title(
        "o: oblique presses, s: 0.1 mm shears, grey: friction share > "
        f"{FRICTION_SHARE:g}\n--: rule at tilt 4/8/14 deg",
        fontsize=9,
    )

    ax = axes[3, 1]
    for marker, rs in probes.items():
        ok = np.array(shared[marker])
        x = np.degrees([float(bias_bound(r.drag, r.tilt)) for r in rs])
        y = np.degrees([r.error for r in rs])
        ax.scatter(x[~ok], y[~ok], s=6, marker=marker, c="0.75")
        ax.scatter(
            x[ok],
            y[ok],
            s=7,
            marker=marker,
            c="C0" if marker == "o" else "C3",
            label={"o": "oblique presses", "s": "0.1 mm shears"}[marker],
        )
    x = np.array([0.01, 90.0])
    ax.plot(x, x, "k--", lw=0.7, label="error = rule")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.01, 90)
    ax.set_ylim(0.01, 90)
    ax.set_xlabel(f"rule: atan({DRAG_TO_TILT:g} tan(drag) / tan(tilt)) (deg)")
    ax.set_ylabel("noise-free edge error (deg)")
    ax.set_title("the drag rule, noise-free (grey: friction share too large)", fontsize=9)
    ax.legend(fontsize=7)

    ax = axes[3, 2] if len(forces) > 2 else axes[3, -1]
    five = {(o, g): v for (f, o, g), v in slides.items() if f == 5.0}
    for off in sorted({k[0] for k in five}):
        gs = sorted(g for (o, g) in five if o == off)
        ax.plot(
            gs,
            [math.degrees(five[(off, g)].fit_error) for g in gs],
            "o-",
            ms=3,
            label=f"{1e3 * off:+.0f} mm",
        )
    g = np.array(sorted({k[1] for k in five}))
    ax.plot(g, np.abs(g), "k--", lw=0.7, label="path")
    ax.set_xlabel("slide path off the edge, outward + (deg)")
    ax.set_ylabel("line-fit error (deg)")
    ax.set_title("slides, 5 N: line through the contact points", fontsize=9)
    ax.legend(fontsize=7)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=65)
    plt.close(fig)


# --- main ---------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="coarse grid, for iteration")
    parser.add_argument("--readings", type=int, default=None, help="noisy readings per probe")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--figure", type=Path, default=FIGURE, help="PNG to write")
    parser.add_argument("--no-figure", action="store_true")
    parser.add_argument("--save", type=Path, default=None, help="pickle the results here")
    args = parser.parse_args(argv)
    grid = dict(
        OFFSETS=OFFSETS,
        THETAS=THETAS,
        OBLIQUE_OFFSETS=OBLIQUE_OFFSETS,
        GAMMAS=GAMMAS,
        SLIDE_OFFSETS=SLIDE_OFFSETS,
        HOLDING=HOLDING,
    )
    if args.quick:
        grid.update(QUICK)
    n_read = args.readings or (10 if args.quick else 40)
    t0 = time.perf_counter()
    shown = sys.argv[1:] if argv is None else argv
    print(f"`{' '.join(['python', f'benchmarks/{Path(__file__).name}', *shown])}`")
    rng = np.random.default_rng(args.seed)
    scene = ProbeScene(ObjectConfig.scissors(holding_torque=HELD))
    offsets, thetas = grid["OFFSETS"], grid["THETAS"]
    shears = shear_map(scene, rng, n_read, FORCES, offsets, thetas)
    obl = oblique_presses(scene, rng, n_read, FORCES, grid["OBLIQUE_OFFSETS"])
    slides = {
        (5.0, off, gam): slide(scene, rng, max(4, n_read // 4), off, math.radians(gam))
        for off in grid["SLIDE_OFFSETS"]
        for gam in grid["GAMMAS"]
    }
    for force in (2.0, 8.0):
        for off in grid["SLIDE_OFFSETS"][-2:]:
            slides[(force, off, 0.0)] = slide(scene, rng, max(4, n_read // 4), off, 0.0, force)
    links = {h: link_run(scene, rng, n_read, max(4, n_read // 4), h) for h in grid["HOLDING"]}
    scene.close()
    t_sim = time.perf_counter() - t0
    if args.save is not None:
        with open(args.save, "wb") as fh:
            pickle.dump(dict(shears=shears, oblique=obl, slides=slides, links=links), fh)
    turn = max(abs(r.joint) for r in [*shears.values(), *obl.values()])
    print(
        f"\nScissors free link held by {HELD} N m (largest joint turn {math.degrees(turn):.4f} "
        f"deg), probe {1e3 * ALONG:.0f} mm from the pin, {n_read} noisy readings per probe "
        "(sensor noise 0.02 N, 5e-4 N m), seed "
        f"{args.seed}. Offsets: sphere centre across the edge, + beyond it. Errors in deg."
    )
    print_presses(shears, FORCES, offsets)
    print_shear_map(shears, FORCES, offsets, thetas)
    for force in FORCES:
        print_oblique(obl, force, grid["OBLIQUE_OFFSETS"])
    along = [r for k, r in obl.items() if k[1] == "along"]
    sweeps = {
        "along-edge oblique presses": gate_sweep(along, "along-edge oblique presses"),
        "all oblique presses": gate_sweep(list(obl.values()), "all oblique presses"),
    }
    print("\nLargest drag threshold (deg) whose P95 stays under 3 / 5 deg:\n")
    rows = []
    for label, sweep in sweeps.items():
        for column, by_drag in sweep.items():
            best = []
            for bound in (3.0, 5.0):
                ok = [a for a in GATE_DRAGS if by_drag[a] < math.radians(bound)]
                best.append(("any" if math.isinf(max(ok)) else f"{max(ok):g}") if ok else "none")
            rows.append([label, column, *best])
    print(table(["population", "readings", "P95 < 3", "P95 < 5"], rows))
    print_bias_rule(
        {
            "presses along the edge, alpha > 0": [
                r for k, r in obl.items() if k[1] == "along" and k[3] > 0
            ],
            "presses across the edge, alpha > 0": [
                r for k, r in obl.items() if k[1] != "along" and k[3] > 0
            ],
            f"shear {1e3 * SHEARS[0]:.1f} mm": [r for k, r in shears.items() if k[3] == SHEARS[0]],
        }
    )
    print_tilt_rule(obl, 5.0, grid["OBLIQUE_OFFSETS"])
    groups = {
        "presses, no shear": [r for k, r in shears.items() if k[3] == 0.0],
        "presses across the edge, alpha > 0": [
            r for k, r in obl.items() if k[1] != "along" and k[3] > 0
        ],
        "presses along the edge, alpha > 0": [
            r for k, r in obl.items() if k[1] == "along" and k[3] > 0
        ],
        f"shear {1e3 * SHEARS[0]:.1f} mm": [r for k, r in shears.items() if k[3] == SHEARS[0]],
        f"shear {1e3 * SHEARS[1]:.0f} mm (slips)": [
            r for k, r in shears.items() if k[3] == SHEARS[1]
        ],
        "lid, all holding torques": [r.end for r in links.values()],
    }
    print_friction_share(groups)
    print_budget_gate(groups)
    print_slides(slides)
    print_link(links)
    print_summary(shears, obl, links)
    if not args.no_figure:
        plot(args.figure, shears, obl, slides, FORCES, offsets, thetas)
        print(f"\nFigure: {args.figure} ({args.figure.stat().st_size / 1e3:.0f} kB)")
    print(
        f"\nTook {time.perf_counter() - t0:.0f} s ({t_sim:.0f} s simulating), "
        f"{len(shears) + len(obl)} probes, {len(slides)} slides, {len(links)} link runs."
    )


if __name__ == "__main__":
    main()
