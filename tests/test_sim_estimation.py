"""The 3D fit's covariance on measurements simulated in PyBullet (door and tilted families).

Eight presses over 120 degrees of the free link, each straight along the normal of a face
that the probed edge bounds, to 5 N, with the sphere centre over the edge (-1 to +1 mm across
it) and the contact 40-75 mm along it: the door's broad side face just below its top edge,
the tilted links' top face. Each press is simulated once, held, and its noise-free wrench
kept; noisy trials then add the F/T sensor's noise (``SensorConfig()`` stds, per axis) for
the mean of ``READINGS`` readings, run ``estimate_contact`` and fit the axis with
``fit_axis_3d``. The truth (``scene.true_axis``, ``probed_edge``) only places the presses and
scores the fits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tactile_gym.envs.scenarios import probed_edge
from tactile_gym.estimation import axis_nees, fit_axis_3d
from tactile_gym.sensing import SensorConfig, estimate_contact
from tactile_gym.sim import ObjectConfig, ProbeScene, SkinConfig
from tactile_gym.spatial import matrix_to_quaternion, z_to

ANGLES = np.radians(np.linspace(-60.0, 60.0, 8))  # rad, joint angle of each press
# m, sphere centre across the edge (+: beyond it), spread over the presses.
OFFSETS = np.linspace(-0.001, 0.001, 8)[[0, 4, 1, 5, 2, 6, 3, 7]]
PRESS_STEP = 0.0002  # m per control step
# F/T readings averaged per measurement: edge stds of 1.3-2.5 deg, where the first-order
# edge_cov holds and the edge's own bias (0.0-1.0 deg here, node spacing) stays small.
READINGS = 4
# Contact-point std per axis, m. The indentation-corrected point is the truncated patch's
# pressure centre: 1.9-2.6 mm inside the face here, 0.1-0.4 mm under it. The edge distance d
# absorbs what all presses share (the offset is rigid in the link's frame); what varies is
# noise to the fit: the pressure centre moves by 0.35 mm per mm of the press's offset from
# the edge (here +-1 mm, std 0.22 mm of the point), and the sensor noise scatters it by
# ~0.1 mm per axis (4 readings).
POINT_STD = 0.00025


def _press_family(family: str):
    """Simulate the presses of one family: (noise-free wrench, sensor rotation, sensor
    origin) per press, and the true (pin, direction)."""
    config = ObjectConfig.family_default(family, holding_torque=1.0)
    presses = []
    with ProbeScene(config, SkinConfig()) as scene:
        g = scene.geometry
        for i, (angle, offset) in enumerate(zip(ANGLES, OFFSETS, strict=True)):
            origin, direction, side_normal, top_normal = probed_edge(config, angle)
            # The door's top face is 8 mm wide: a 5 N patch would reach its far edge.
            if family == "door":
                normal, across = side_normal, top_normal
            else:
                normal, across = top_normal, side_normal
            quat = matrix_to_quaternion(z_to(-normal))
            centre = origin + (0.04 + 0.005 * i) * direction + offset * across
            start = centre + (g.outer_radius + 0.001 + g.cylinder_length) * normal
            scene.reset(angle, start, quat)
            scene.force_limit = 5.0
            for k in range(1, 100):
                if scene.control_step(start - k * PRESS_STEP * normal, quat).force_limited:
                    break
            hold = scene.fingertip_position
            for _ in range(2):
                scene.control_step(hold, quat)
            assert np.linalg.norm(scene.true_wrench[:3]) == pytest.approx(5.0, rel=0.05)
            presses.append((scene.true_wrench, scene.fingertip_rotation, hold))
        truth = scene.true_axis
    return presses, truth


@pytest.fixture(scope="module")
def simulated():
    return {family: _press_family(family) for family in ("door", "tilted")}


@pytest.mark.parametrize("family", ["door", "tilted"])
@pytest.mark.parametrize(
    "loss, trials", [("linear", 300), pytest.param("soft_l1", 2000, marks=pytest.mark.slow)]
)
def test_3d_covariance_is_calibrated_on_simulated_presses(
    simulated, family: str, loss: str, trials: int
):
    """NEES of (position normal to the axis, direction), 4 dof, within 30 %.

    Measured, least squares (300 trials): door 3.27, tilted 4.11 (other seeds 3.13-3.63
    and 3.98-4.42). soft_l1, the env's loss (2000 trials, slow): 3.08 and 4.63; 2 % of its
    trials lie beyond the chi-square 99 % quantile, so 300 trials would scatter 4.2-5.5.
    The door's NEES is low in the bulk (median 2.3 against 3.4): the 0.25 mm point std is
    generous to its presses. Edge stds are 1.3-2.5 deg per press. With single readings
    (2.7-5.1 deg) the door's NEES is 8.7 (least squares), with a fifth of the trials beyond
    the 99 % quantile: at such noise the fit sometimes settles on an axis in the plane of
    the edges.
    """
    presses, (pin, u) = simulated[family]
    sensor = SensorConfig()
    force_std = sensor.force_noise_std / math.sqrt(READINGS)
    moment_std = sensor.moment_noise_std / math.sqrt(READINGS)
    stds = np.r_[np.full(3, force_std), np.full(3, moment_std)]
    k_n = SkinConfig().normal_stiffness
    rng = np.random.default_rng(71)
    nees = []
    for _ in range(trials):
        points, edges, covs = [], [], []
        for wrench, rotation, origin in presses:
            noisy = wrench + rng.standard_normal(6) * stds
            est = estimate_contact(
                noisy[:3],
                noisy[3:],
                force_noise_std=force_std,
                moment_noise_std=moment_std,
                skin_stiffness=k_n,
                contact_shape="plane",
            )
            assert est.edge_observable
            points.append(rotation @ est.corrected_point + origin)
            edges.append(rotation @ est.edge_direction)
            covs.append(rotation @ est.edge_cov @ rotation.T)
        points, edges, covs = np.array(points), np.array(edges), np.array(covs)
        fit = fit_axis_3d(points, edges, point_std=POINT_STD, edge_cov=covs, loss=loss)
        assert fit.method == "3d"
        nees.append(axis_nees(fit, pin, u)[0])
    print(f"{family} {loss}: NEES {np.mean(nees):.2f} (4 dof)")
    assert np.mean(nees) == pytest.approx(4.0, rel=0.3)
