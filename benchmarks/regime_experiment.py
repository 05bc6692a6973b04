"""Regime map, the experiment: probes of the scissors' free link near its edge.

Every probe touches the free link 5 cm from the pin (``docs/design.md`` 4.1), the finger
axis along the face normal and the sphere centre ``offset`` across the edge (negative: over
the face; positive: beyond the edge). Presses are the shared press
(``tactile_gym.sensing.PressController``) on the noisy reading, and every reading is read by
the env's ``TouchSensor``. The link is held firmly (holding torque ``HELD``) so that the map
shows the sensing alone; a lid lets a link give way. The simulator's truth (edge line, face
normal) places the finger and scores the error; the gate quantities use only what a robot
has: the F/T reading and the fingertip's own pose.

Observables, world frame (the robot's base frame), from one reading:

* ``touch``: the fingertip position at the first reading of a touch; ``path`` =
  unit(touch - now), the press path reversed (it points out of the object, like the force on
  the skin);
* ``deviation``: the angle between the path and the force line (the gate's friction share,
  ``tactile_gym.perception.gate.friction_free``);
* ``drag`` = asin(|path . e|): the angle between path and force line along the measured edge
  e (``tactile_gym.perception.gate.drag_bias``);
* ``tilt``: the angle between the force and the skin normal at the contact point;
* ``travel``: the fingertip's travel since the touch along the force line, against what a
  flat-face press needs for the same force (``tactile_gym.perception.gate.link_held``).

Run through ``benchmarks/regime_map.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from tactile_gym.perception.gate import flat_press_depth
from tactile_gym.sensing import (
    PressConfig,
    PressController,
    TouchSensor,
    edge_from_trace,
    run_press,
)
from tactile_gym.sim import ObjectConfig, ProbeScene
from tactile_gym.spatial import matrix_to_quaternion, z_to

HELD = 1.0  # N m, holding torque that keeps the link still under every probe here
ALONG = 0.05  # m, probe position along the edge from the pin
CLEAR = 0.0005  # m, start of each press: this far from touching the face plane
HOLD = 2  # readings a press holds still before it is read
#: The presses: 0.1 mm per control step (2 mm/s at 12 x 1/240 s) on the noisy reading, to
#: within 0.1 N of the force; the stiffness keeps the steps stable up to 8 N on a flat face.
PRESS = PressConfig(tolerance=0.1, max_step=0.0001, stiffness=12000.0, dwell=HOLD, reach=0.003)
SHEAR_STEP = 0.0001  # m per control step
SLIDE_STEP = 0.0002  # m per control step
SLIDE_LENGTH = 0.008  # m
SLIDE_SKIP = 0.002  # m, start of the slide left out of the fit (stick-slip onset)
SHEARS = (0.0001, 0.002)  # m: the skin sticks at the first, slips at the second

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
class ProbedSpot:
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


def probed_spot(scene: ProbeScene) -> ProbedSpot:
    """The probed spot of the scene's free link at its current joint angle.

    The edge joins the link's +z_H face and its ``edge_side`` y_H face; the pressed face is
    the one that faces up more (the top face of the scissors, the top of a lid), the other
    is the side beyond the edge.
    """
    ep, ed = scene.edge_line
    rot = scene.object.link_rotation
    a, b = rot[:, 2], rot[:, 1] * scene.object_config.edge_side
    up, out = (a, b) if a[2] >= b[2] else (b, a)
    return ProbedSpot(ep + ALONG * ed, ed, out.copy(), up.copy())


def line_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two undirected lines, rad."""
    c = abs(float(a @ b)) / (float(np.linalg.norm(a)) * float(np.linalg.norm(b)))
    return math.acos(min(1.0, c))


@dataclass
class Probe:
    """A press on the probed spot.

    Attributes:
        frame: the probed spot.
        quat: (4,) fingertip orientation held throughout, x y z w.
        touch: (3,) fingertip position at the first reading of a touch (``TOUCH_FORCE``), m.
        reached: whether |f| reached the press force.
    """

    frame: ProbedSpot
    quat: np.ndarray
    touch: np.ndarray
    reached: bool = True


def press(
    scene: ProbeScene,
    rng: np.random.Generator,
    offset: float,
    force: float,
    *,
    joint_angle: float = 0.0,
    tilt: float = 0.0,
    tilt_toward: str = "along",
    give_way: float = math.inf,
) -> Probe:
    """Press the hemisphere onto the face near the edge with the shared press to ``force``.

    The finger axis is the face normal; the path is the face normal tilted by ``tilt`` (rad)
    toward ``tilt_toward`` ("along": the edge direction; "out": across the edge, beyond it;
    "in": across, over the face), aimed so that it crosses the face plane at the sphere
    centre's ``offset`` across the edge. The press (``PressController``) steps along the path
    on the noisy reading and holds still for ``HOLD`` readings. With ``give_way`` (m) it gives
    up that far past the touch (the robot's sanity limit, for a link that gives way);
    otherwise not reaching ``force`` is an error.
    """
    scene.reset(joint_angle, [0.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0])
    fr = probed_spot(scene)
    g = scene.geometry
    quat = matrix_to_quaternion(z_to(-fr.up))
    side = {"along": fr.along, "out": fr.out, "in": -fr.out}[tilt_toward]
    path = -math.cos(tilt) * fr.up + math.sin(tilt) * side
    centre = fr.point + offset * fr.out + g.outer_radius * fr.up  # touching the face plane
    start = centre + g.cylinder_length * fr.up - CLEAR / math.cos(tilt) * path
    scene.reset(joint_angle, start, quat)
    scene.force_limit = 50.0  # the press, not the guarded move, stops at the force
    control = PressController(replace(PRESS, target_force=force, give_way=give_way))
    touch, target = None, start

    def advance(step: float) -> None:
        nonlocal touch, target
        if touch is None and control.touch_travel is not None:
            touch = scene.fingertip_position  # where the first touching reading was taken
        target = target + step * path
        scene.control_step(target, quat)

    run_press(control, lambda: scene.read_wrench(rng), advance)
    if control.phase == "missed":
        raise RuntimeError(f"press at offset {offset} m never reached {force} N")
    return Probe(fr, quat, touch, control.phase == "done")


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
    a flat-face press to |f| needs (``flat_press_depth``); ``point_offset``: the corrected
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


def sensor_of(scene: ProbeScene) -> TouchSensor:
    """The env's reading of a wrench, for the scene's fingertip, sensor and skin."""
    return TouchSensor(scene.geometry, scene.sensor_config, scene.skin_config.normal_stiffness)


def observe(scene: ProbeScene, wrench: np.ndarray, touch: np.ndarray, readings: int = 1):
    """(touch, error, drag, deviation) of one wrench, the mean of ``readings`` readings: the
    world-frame ``Touch``; the error against the true edge (rad, NaN if flagged); drag and
    deviation from the fingertip's path and the wrench only."""
    rotation, position = scene.fingertip_rotation, scene.fingertip_position
    reading = sensor_of(scene).sense(wrench, rotation, position, readings)
    if not reading.valid:
        return reading, math.nan, math.nan, math.nan
    path = touch - position
    deviation = line_angle(path, reading.force)
    if not reading.observable:
        return reading, math.nan, math.nan, deviation
    error = line_angle(reading.edge, scene.edge_line[1])
    drag = math.asin(min(1.0, abs(float(path @ reading.edge)) / float(np.linalg.norm(path))))
    return reading, error, drag, deviation


def _noisy(scene, touch, rng, n, average) -> Noisy:
    rows = []
    for _ in range(n):
        w = np.mean([scene.read_wrench(rng) for _ in range(average)], axis=0)
        t, err, dr, dv = observe(scene, w, touch, average)
        rows.append((err, t.observable, t.tilt, dr, dv, t.edge_std))
    a = np.array(rows, dtype=float).reshape(n, 6)
    return Noisy(a[:, 0], a[:, 1].astype(bool), a[:, 2], a[:, 3], a[:, 4], a[:, 5])


def across_offset(scene: ProbeScene, point: np.ndarray) -> float:
    """Signed offset of a world point across the probed edge, m, + beyond it (truth)."""
    fr = probed_spot(scene)
    return float((point - fr.point) @ fr.out)


def read(scene: ProbeScene, touch: np.ndarray, rng: np.random.Generator, n: int) -> Readings:
    """The noise-free reading, ``n`` single noisy ones and ``n`` means of ``AVERAGE``."""
    clean, error, drag, dev = observe(scene, scene.true_wrench, touch)
    magnitude = float(np.linalg.norm(clean.force))
    travel = abs(float((touch - scene.fingertip_position) @ clean.force)) / magnitude
    flat = flat_press_depth(
        magnitude, scene.skin_config.normal_stiffness, scene.geometry.outer_radius
    )
    return Readings(
        error=error,
        observable=clean.observable,
        tilt=clean.tilt,
        drag=drag,
        deviation=dev,
        edge_std=clean.edge_std,
        force=magnitude,
        joint=scene.joint_angle,
        travel=travel,
        travel_ratio=travel / flat,
        point_offset=across_offset(scene, clean.point),
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
            t = press(scene, rng, off, force)
            out[(force, off, None, 0.0)] = read(scene, t.touch, rng, n_read)
            for th in thetas:
                t = press(scene, rng, off, force)
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
                    t = press(scene, rng, off, force, tilt=math.radians(a), tilt_toward=toward)
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


def _slide_observables(scene, touch, path_dir):
    """(corrected point, across tilt, along tilt, point relative to the sensor origin) of one
    world-frame ``Touch``."""
    n, f = touch.normal, touch.force
    d = path_dir - (path_dir @ n) * n
    d /= np.linalg.norm(d)
    c = np.cross(n, d)
    fn = -float(f @ n)
    across = math.atan2(float(f @ c), fn)
    along = math.atan2(float(f @ d), fn)
    return touch.point, across, along, touch.point - scene.fingertip_position


def _trace_stats(points, across, sensor_pts, travel, path_sensor_across):
    direction, std = edge_from_trace(points)
    slope = np.polyfit(travel, across, 1)[0]
    drift = np.polyfit(travel, sensor_pts @ path_sensor_across, 1)[0]
    return direction, std, slope, drift


def slide(scene, rng, n_traces, offset, gamma, force=5.0) -> Slide:
    """Press at ``offset``, then move ``SLIDE_LENGTH`` at constant height along the edge
    turned ``gamma`` (rad) outward, one control step per ``SLIDE_STEP``."""
    sensor = sensor_of(scene)
    t = press(scene, rng, offset, force)
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
        pose = scene.fingertip_rotation, scene.fingertip_position
        touch = sensor.sense(scene.true_wrench, *pose)
        clean.append(_slide_observables(scene, touch, path))
        centroids.append(scene.contact_centroid)
        if touch.observable:
            wrench_err.append(line_angle(touch.edge, fr.along))
        for k in range(n_traces):
            touch = sensor.sense(scene.read_wrench(rng), *pose)
            noisy[k].append(_slide_observables(scene, touch, path))
    travel = np.array(travel)
    centroids = [c for c in centroids if c is not None]
    # The direction across the path (the finger does not turn).
    across_s = np.cross(fr.up, path)

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
    t = press(scene, rng, 0.0, force, joint_angle=LID_ANGLE, give_way=LINK_TRAVEL)
    end = read(scene, t.touch, rng, n_read)
    q1, f1 = scene.joint_angle, float(np.linalg.norm(scene.true_wrench[:3]))
    sensor = sensor_of(scene)
    times = np.arange(HOLD_STEPS) * scene.substeps * scene.time_step
    clean, noisy = [], [[] for _ in range(n_seeds)]
    pos = scene.fingertip_position
    for _ in range(HOLD_STEPS):
        scene.control_step(pos, t.quat)
        for rows, w in [(clean, scene.true_wrench)] + [
            (rows, scene.read_wrench(rng)) for rows in noisy
        ]:
            rows.append(sensor.sense(w, scene.fingertip_rotation, scene.fingertip_position).point)

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
