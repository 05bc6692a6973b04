"""The sensing's error prediction and observability flag, checked in simulation.

``estimate_contact`` predicts, for every reading, the covariance of its edge error
(``edge_cov``) and whether the edge is observable at all (``edge_observable``). Here both are
held to the simulated skin: noisy readings of 5 N presses whose patch the edge truncates must
scatter around the true edge as ``edge_cov`` says, and presses that carry no edge information
(a flat face, a line of action through the sphere centre) must be flagged. The truth
(``scene.edge_line``) appears only in the checks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tactile_gym.sensing import PressConfig, PressController, estimate_contact, run_press
from tactile_gym.sim import ObjectConfig, ProbeScene
from tactile_gym.sim.scene import PHYSICS
from tactile_gym.spatial import matrix_to_quaternion, z_to

ALONG = 0.05  # m, probe position along the edge from the pin
#: The shared press on the noisy reading: 0.1 mm per control step, to within 0.1 N, then two
#: still readings.
PRESS = PressConfig(tolerance=0.1, max_step=0.0001, stiffness=12000.0, dwell=2, reach=0.004)


@pytest.fixture(scope="module", params=PHYSICS)
def scene(request):
    # Held firmly: the presses here must not turn the link.
    s = ProbeScene(ObjectConfig.scissors(holding_torque=1.0), physics=request.param)
    yield s
    s.close()


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def press(scene, offset, joint_angle=0.0, force=5.0, path_axis=(0, 0, 1), finger_axis=None):
    """Press the free link's top face near its probed edge until |f| reaches ``force``.

    The sphere centre moves along -``path_axis`` toward the point ``offset`` across the edge
    (+ beyond it), ``ALONG`` from the pin; the finger axis (sensor z) points along
    -``finger_axis`` (default: the path).

    Returns:
        (quaternion of the finger, fingertip position at touchdown: the first reading of a
        touch, world frame).
    """
    scene.reset(joint_angle, [0.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0])
    ep, ed = scene.edge_line
    out = scene.object.link_rotation[:, 1] * scene.object_config.edge_side
    n = _unit(path_axis)
    axis = n if finger_axis is None else _unit(finger_axis)
    quat = matrix_to_quaternion(z_to(-axis))
    g = scene.geometry
    start = ep + ALONG * ed + offset * out + (g.outer_radius + 0.001) * n + g.cylinder_length * axis
    scene.reset(joint_angle, start, quat)
    scene.force_limit = 50.0  # the press, not the guarded move, stops at the force
    control = PressController(replace(PRESS, target_force=force))
    rng = np.random.default_rng(1)
    target, touch = start, None

    def advance(step: float) -> None:
        nonlocal target, touch
        if touch is None and control.touch_travel is not None:
            touch = scene.fingertip_position
        target = target - step * n
        scene.control_step(target, quat)

    run_press(control, lambda: scene.read_wrench(rng), advance)
    assert control.phase == "done"
    assert np.linalg.norm(scene.true_wrench[:3]) == pytest.approx(force, rel=0.05)
    return quat, touch


def hold(scene, quat, steps: int = 2) -> None:
    pos = scene.fingertip_position
    for _ in range(steps):
        scene.control_step(pos, quat)


def estimate(scene, wrench):
    return estimate_contact(
        wrench[:3],
        wrench[3:],
        scene.geometry,
        skin_stiffness=scene.skin_config.normal_stiffness,
    )


def test_edge_cov_predicts_the_per_reading_edge_error(scene):
    """NEES of 300 noisy readings of 5 N presses that the edge truncates (sphere centre 2 mm
    over the face to 2 mm beyond the edge, three joint angles) is 2 +- 30 %.

    The error de = e - e_true of a unit vector lies, to first order, in the plane normal to
    e, and ``edge_cov`` is the covariance of de there: rank 2, e in its null space. So
    de^T pinv(edge_cov) de is chi-square with 2 degrees of freedom (mean 2); the pseudo-
    inverse drops de's second-order part along e. Both axes matter: the covariance is very
    elongated (RMS ~0.2 deg out of the tangent plane, 2-8 deg within it), and a test along the
    error's own direction, |de|^2 / (u^T C u), would hide a wrong minor axis.
    Measured: NEES 2.21 with this seed, 92 % of readings within the chi-square 95 % bound
    (seeds 0-9: NEES 1.92-2.22, 94-96 %). The noise-free error, 0.1-0.8 deg here (node
    spacing, rounded edge), is not in edge_cov; it is small beside the 2-9 deg noise.
    """
    rng = np.random.default_rng(12345)
    nees = []
    for joint_angle in (0.0, 0.6, -0.9):
        for offset in (-0.002, -0.001, 0.0, 0.001, 0.002):
            press(scene, offset, joint_angle)
            truth = scene.world_to_sensor_vector(scene.edge_line[1])
            for _ in range(20):
                est = estimate(scene, scene.read_wrench(rng))
                assert est.edge_observable
                e = est.edge_direction
                de = e - np.sign(e @ truth) * truth
                nees.append(de @ np.linalg.pinv(est.edge_cov, rcond=1e-10) @ de)
    nees = np.array(nees)
    inside = np.mean(nees <= 5.991)  # chi-square(2) 95 % quantile
    print(f"NEES {nees.mean():.2f} over {len(nees)} readings; {100 * inside:.1f} % within 95 %")
    assert len(nees) >= 200
    assert nees.mean() == pytest.approx(2.0, rel=0.3)
    assert 0.9 <= inside <= 0.99


def _flagged_share(scene, n: int = 100) -> float:
    rng = np.random.default_rng(7)
    return float(
        np.mean([not estimate(scene, scene.read_wrench(rng)).edge_observable for _ in range(n)])
    )


@pytest.mark.parametrize(
    "name, offset, path_axis, finger_axis",
    [
        # The centre 8 mm over the face: the ~5 mm patch of a 5 N press stays clear of the edge.
        ("flat face", -0.008, (0, 0, 1), None),
        # A vertical press on the flat face with the finger tilted 30 degrees: contact off the
        # tip, the force along the face normal through the centre.
        ("tilted finger", -0.008, (0, 0, 1), (0.0, 0.5, np.sqrt(3.0) / 2.0)),
        # Along the corner's bisector: both faces press symmetrically, force through the
        # centre; the edge is under the skin but carries no information.
        ("corner bisector", 0.0, (0, -1, 1), None),
    ],
)
def test_presses_without_edge_information_are_flagged(scene, name, offset, path_axis, finger_axis):
    """The line of action passes within 0.1 mm of the sphere centre (measured 0.001-0.025),
    the noise-free reading is flagged, and at least 90 % of noisy ones are (an untilted press
    passes with probability 1.1 %; measured 0.7-1.2 % over 1000 readings)."""
    press(scene, offset, path_axis=path_axis, finger_axis=finger_axis)
    clean = estimate(scene, scene.true_wrench)
    assert clean.valid and clean.line_offset < 1e-4
    print(f"{name}: tilt {np.rad2deg(clean.tilt):.3f} deg, tilt_snr {clean.tilt_snr:.2f}")
    assert not clean.edge_observable
    assert _flagged_share(scene) >= 0.9


def _angle(a, b) -> float:
    """Angle between two lines, rad."""
    return float(np.arccos(min(1.0, abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b))))


def gate_quantities(scene, touch):
    """(tilt, drag, deviation, error) of the noise-free reading, rad. drag and deviation come
    from the fingertip's path since touchdown and the wrench only (see
    benchmarks/regime_map.py); the error uses the true edge."""
    est = estimate(scene, scene.true_wrench)
    assert est.edge_observable
    path = touch - scene.fingertip_position
    force = scene.sensor_to_world_vector(scene.true_wrench[:3])
    edge = scene.sensor_to_world_vector(est.edge_direction)
    drag = float(np.arcsin(abs(path @ edge) / np.linalg.norm(path)))
    return est.tilt, drag, _angle(path, force), _angle(edge, scene.edge_line[1])


def test_drag_and_friction_share_tell_friction_from_the_edge(scene):
    """The physics behind the measurement gate of benchmarks/regime_map.py, noise-free.

    * A press along the face normal: the truncated patch tilts the force from the skin
      normal while the force stays on the press path (deviation <= 0.25 tilt; measured 0.1).
    * A press whose path is 2 deg off the face normal along the edge: the sticking skin drags
      the force along by beta = atan(tan(alpha) k_t/k_n) = alpha/3, so the path-force angle
      along the measured edge (drag) is 2 alpha/3, and the edge turns by atan(tan(beta) /
      tan(tilt)) = atan(0.5 tan(drag)/tan(tilt)) (measured 1.31 deg drag, 4.4 deg error, rule
      4.7).
    * A 0.05 mm sideways move along the edge after the press: all nodes in contact move
      together, and the edge turns by atan(c tan(drag)/tan(tilt)) with c ~ 1 (measured 0.98;
      0.9-1.6 over the benchmark's shear map, whose gate takes c = 1.7).
    * A 0.1 mm sideways move on the flat face: friction alone tilts the force, enough to pass
      the noise test, and the 'edge' is perpendicular to the move; the force then lies
      between path and normal: deviation >= tilt (measured 1.2).
    """

    def rule(drag, tilt, c):
        return np.arctan(c * np.tan(drag) / np.tan(tilt))

    ed = scene.edge_line[1]  # joint angle 0 throughout
    quat, touch = press(scene, 0.0)
    tilt, drag, dev, err = gate_quantities(scene, touch)
    assert dev <= 0.25 * tilt and drag < np.deg2rad(0.05) and err < np.deg2rad(1.0)

    alpha = np.deg2rad(2.0)
    quat, touch = press(
        scene,
        0.0,
        path_axis=np.cos(alpha) * np.array([0, 0, 1]) - np.sin(alpha) * ed,
        finger_axis=(0, 0, 1),
    )
    tilt, drag, dev, err = gate_quantities(scene, touch)
    assert drag == pytest.approx(2.0 * alpha / 3.0, rel=0.15)
    assert err == pytest.approx(rule(drag, tilt, 0.5), rel=0.25)
    assert dev <= 0.5 * tilt

    quat, touch = press(scene, 0.0)
    scene.force_limit = 50.0
    scene.control_step(scene.fingertip_position + 0.00005 * ed, quat)
    hold(scene, quat)
    tilt, drag, dev, err = gate_quantities(scene, touch)
    assert 0.8 <= np.tan(err) * np.tan(tilt) / np.tan(drag) <= 1.7

    quat, touch = press(scene, -0.006)
    scene.force_limit = 50.0
    scene.control_step(scene.fingertip_position + 0.0001 * ed, quat)
    hold(scene, quat)
    tilt, drag, dev, err = gate_quantities(scene, touch)
    assert err > np.deg2rad(80.0) and dev >= tilt
