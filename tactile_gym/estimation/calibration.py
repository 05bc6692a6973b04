"""The calibrated error model of a tactile measurement (docs/design.md 6.9).

A measurement's error is not all white sensor noise. What the online estimator's
``covariance="calibrated"`` makes of the noise it is handed, per press:

* **The contact point varies less than its bound.** The point is the truncated patch's
  pressure centre, 0.9-3.1 mm inside the face (docs/design.md 4.5), and ``point_std`` bounds
  that error. Its part common to the presses of one edge shifts every edge line alike in the
  link's frame, which the fitted edge distance absorbs (the line turns rigidly with the link);
  only its variation between presses is an error of the axis: the pressure centre moves by
  0.35 mm per mm of the press's offset across the edge (``tests/test_sim_estimation.py``), so
  presses aimed at one tilt scatter it by a few tenths of a millimetre. ``point_scatter`` is
  that part, and it is the spot's: presses at one spot share it.
* **The edge errs out of the face more than the reading noise says.** The sensing's
  ``edge_cov`` is the first-order covariance of the averaged readings' noise. Out of the face
  it leaves out the zero's own error (the tare's noise and the drift since the tare), the
  noise-free press's error, and the tilt of its own thin direction, which follows the contact
  normal rather than the face. ``edge_excess_std`` is added in every direction normal to the
  edge, independent between presses.
* **A spot's bias does not average away.** A press's noise-free error (its contact point's
  depth, its edge's turn from the skin's node spacing and the edge's rounding) is a function
  of where and how the fingertip presses: presses at one spot at one link angle share it,
  whatever the readings' noise does. It is part of a press's own error (the scripted
  presses' measured errors hold it); repeated, it is counted once per press at its spot: a
  press among an effective ``m`` at one spot gets ``(m - 1)`` times the shared variance
  added. For ``m`` presses at exactly one spot this is exact (their mean's variance is the
  independent part over ``m`` plus the shared part), and a press alone keeps its own
  variance. The shared edge part has the shape of the press's own edge covariance (the
  noise-free error turns the edge as the noise does) and the total RMS ``edge_model_std``.
  Presses count as one spot by their contact points' distance, ``exp(-|x_i - x_j|^2 /
  (2 spot_radius^2))``: after a turn of the link the same place on the link lies elsewhere,
  so a turned link is a new spot.

Conventions: world frame, metres, radians. The constants were measured on the scripted
policy's presses of the development seeds (``benchmarks/calibration.py errors``); the
figures are in docs/design.md 6.9.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation.axis import isotropic_edge_covs

__all__ = ["CALIBRATED", "ErrorModel", "press_noise", "spot_counts"]

_EYE3 = np.eye(3)


@dataclass(frozen=True)
class ErrorModel:
    """The parts of a measurement's error that its handed noise leaves out (module docstring).

    Attributes:
        point_scatter: std of the contact point's error between presses, per axis, m: the
            variation of its depth inside the face with the press's geometry, shared by the
            presses at one spot; used in place of ``point_std`` when smaller. Measured:
            0.19-0.24 mm across the edge, 0.05-0.08 mm normal to the face.
        edge_excess_std: std added to the edge's error in each direction normal to it, rad,
            independent between presses: what makes the mean squared error out of the face
            over its predicted variance one (0.129 deg on both tasks).
        edge_model_std: RMS (total over both normal directions) of the edge's noise-free
            error between presses, rad: a part of a single press's edge covariance, of its
            shape, shared by the presses at one spot. Measured with a noise-free sensor:
            0.62-0.65 deg within the face (0.06-0.08 deg out of it).
        spot_radius: distance between contact points over which presses count as one spot,
            m: about one and a half of the skin's node spacings (0.65 mm), over which the
            noise-free error of a press changes.
    """

    point_scatter: float = 2.5e-4
    edge_excess_std: float = math.radians(0.13)
    edge_model_std: float = math.radians(0.6)
    spot_radius: float = 1e-3


#: The model of ``JointAxisEstimator(covariance="calibrated")``.
CALIBRATED = ErrorModel()


def press_noise(
    edge: np.ndarray,
    dims: int,
    edge_std: float,
    edge_cov: np.ndarray | None,
    point_std: float,
    model: ErrorModel,
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """One press's calibrated noise: its own and the part it shares with its spot.

    Args:
        edge: (3,) unit edge as measured (z = 0 for an edge given in the x-y plane).
        dims: 2 for an edge given in the x-y plane (all its handed error turns it about z),
            else 3.
        edge_std: the handed total RMS edge error, rad (used without ``edge_cov``).
        edge_cov: the handed (3, 3) validated edge covariance, rad^2, or None.
        point_std: the handed contact-point std per axis, m.
        model: the error model.

    Returns:
        ``(edge_cov_own, edge_cov_shared, point_var_own, point_var_shared)``: (3, 3) rad^2
        and m^2. The own parts hold the shared ones (a press alone has just its own).
    """
    normal = _EYE3 - np.outer(edge, edge)
    if edge_cov is not None:
        handed = edge_cov
    elif dims == 2:
        turn = np.array([-edge[1], edge[0], 0.0])
        handed = edge_std * edge_std * np.outer(turn, turn)
    else:
        handed = isotropic_edge_covs(edge[None], edge_std)[0]
    own = handed + model.edge_excess_std**2 * normal
    # The noise-free error turns the edge as the noise does (both move the force line over
    # the patch), so it takes the shape of the press's own covariance; a press whose own
    # error is below it shares all of it.
    total = float(np.trace(own))
    shared = own * min(1.0, model.edge_model_std**2 / total) if total > 0.0 else own
    point_var = min(point_std, model.point_scatter) ** 2
    return own, shared, point_var, point_var


def spot_counts(points: np.ndarray, radius: float) -> np.ndarray:
    """(N,) effective number of presses at each press's spot, itself included (>= 1).

    Args:
        points: (N, 3) contact points, world frame, m.
        radius: ``ErrorModel.spot_radius``, m.
    """
    diff = points[:, None, :] - points[None, :, :]
    sq = np.einsum("ijk,ijk->ij", diff, diff)
    return np.exp(-0.5 * sq / (radius * radius)).sum(axis=1)
