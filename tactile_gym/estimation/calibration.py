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
  it leaves out the zero's own error (the tare's noise and the drift since the tare) and the
  tilt of its own thin direction, which follows the contact normal rather than the face.
  ``edge_excess_std`` is added in every direction normal to the edge, independent between
  presses.
* **A press's noise-free error adds to it, and a spot's does not average away.** With a
  noise-free sensor the scripted presses' edges still err 0.6 deg within the face: the skin's
  node spacing and the edge's rounding move the force line over the patch as the noise does.
  The sensing's covariance leaves it out, so a press's own edge covariance gets it added,
  with the shape of the handed covariance and the total RMS ``edge_model_std``. It is a
  function of where and how the fingertip presses, as is the contact point's depth
  (``point_scatter``): presses at one spot at one link angle share both, whatever the
  readings' noise does. So a press among an effective ``m`` at one spot gets ``(m - 1)``
  times these shared variances added: for ``m`` presses at exactly one spot their mean's
  variance is then the independent part over ``m`` plus the shared part, as it is, and a
  press alone keeps its own. Presses count as one spot by their contact points' distance,
  ``exp(-|x_i - x_j|^2 / (2 spot_radius^2))``: after a turn of the link the same place on
  the link lies elsewhere, so a turned link is a new spot.

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
            over its predicted variance one, the noise-free error included (0.121 and
            0.126 deg on the planar and 3D tasks).
        edge_model_std: RMS (total over both normal directions) of the edge's noise-free
            error between presses, rad, added to each press's edge covariance in its shape
            and shared by the presses at one spot. Measured with a noise-free sensor:
            0.62-0.65 deg within the face, 0.06-0.08 deg out of it.
        spot_radius: distance between contact points over which presses count as one spot,
            m: about one and a half of the skin's node spacings (0.65 mm), over which the
            noise-free error of a press changes.
    """

    point_scatter: float = 2.5e-4
    edge_excess_std: float = math.radians(0.12)
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
        Without any handed edge error the shared part is isotropic.
    """
    normal = _EYE3 - np.outer(edge, edge)
    if edge_cov is not None:
        handed = edge_cov
    elif dims == 2:
        turn = np.array([-edge[1], edge[0], 0.0])
        handed = edge_std * edge_std * np.outer(turn, turn)
    else:
        handed = isotropic_edge_covs(edge[None], edge_std)[0]
    # The noise-free error turns the edge as the reading noise does (both move the force
    # line over the patch), so it takes the shape of the handed covariance.
    total = float(np.trace(handed))
    if total > 0.0:
        shared = handed * (model.edge_model_std**2 / total)
    else:
        shared = 0.5 * model.edge_model_std**2 * normal
    own = handed + shared + model.edge_excess_std**2 * normal
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
