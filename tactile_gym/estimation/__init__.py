"""Joint-axis estimation from tactile measurements (Matsuo et al. 2010, section II and IV-B).

NumPy/SciPy only: this package must import without pybullet or torch, so real robots can
reuse it. Everything is in the world frame (z up), metres and radians.

Measurement noise: ``point_std`` is the contact-point std per axis (m); ``edge_std`` the
total RMS angle error of an edge (rad), the noise then isotropic about the edge; or
``edge_cov`` its (3, 3) covariance (rad^2, world frame, of the perturbation of the unit
edge), e.g. ``var_in g g^T + var_out n n^T`` for a skin normal n and ``g = n x e``.

* :func:`fit_axis_planar` - the paper's proposed method for an axis along z (eq. 16-21);
* :func:`fit_axis_simple` - the paper's perpendicular-bisector baseline (eq. 22-26);
* :func:`fit_axis_3d` - any axis direction (eq. 3, 8, 9-10), robust losses, covariance;
* :class:`JointAxisEstimator` - the online, weighted estimator; its ``covariance`` (one of
  ``COVARIANCES``) takes the handed noise as independent (``"independent"``) or adds the
  systematic parts of a press's error (``"calibrated"``, docs/design.md 6.9);
* :class:`AxisPrior` - a Gaussian prior on the axis that the fits and the estimator fuse
  with the measurements (maximum a posteriori);
* :func:`axis_error` - position and angle error against the truth (docs/design.md 6.7);
* :func:`axis_nees` - normalised estimation error squared of an estimate's covariance.
"""

from tactile_gym.estimation.axis import COVARIANCE_LAYOUT, AxisEstimate
from tactile_gym.estimation.fit3d import fit_axis_3d
from tactile_gym.estimation.fits import fit_axis_planar, fit_axis_simple
from tactile_gym.estimation.metrics import axis_error, axis_nees
from tactile_gym.estimation.online import COVARIANCES, JointAxisEstimator
from tactile_gym.estimation.planar import edge_rotation_variance, planar_residual_variance
from tactile_gym.estimation.prior import AxisPrior
from tactile_gym.estimation.robust import LOSSES

__all__ = [
    "COVARIANCES",
    "COVARIANCE_LAYOUT",
    "LOSSES",
    "AxisEstimate",
    "AxisPrior",
    "JointAxisEstimator",
    "axis_error",
    "axis_nees",
    "edge_rotation_variance",
    "fit_axis_3d",
    "fit_axis_planar",
    "fit_axis_simple",
    "planar_residual_variance",
]
