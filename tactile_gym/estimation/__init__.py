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
  :func:`direction_error` - the angle between two directions, ignoring sign;
* :func:`axis_nees` - normalised estimation error squared of an estimate's covariance;
* :class:`JointTypeEstimator` / :func:`estimate_joint_type` - which joint it is (rigid,
  revolute, prismatic, or none of them), from the same measurements labelled by edge line
  and link configuration (docs/design.md 6.10), with one :class:`JointModel` per type
  (:class:`RigidModel`, :class:`RevoluteModel`, :class:`PrismaticModel`) and the priors of
  :class:`JointTypePrior`;
* :func:`fit_slide_direction` / :func:`fit_slide_simple` - a prismatic joint's direction from
  the edge lines, and the "simple method" analogue from the contact points.
"""

from tactile_gym.estimation.axis import COVARIANCE_LAYOUT, AxisEstimate
from tactile_gym.estimation.fit3d import fit_axis_3d
from tactile_gym.estimation.fits import fit_axis_planar, fit_axis_simple
from tactile_gym.estimation.joint_models import (
    JOINT_TYPES,
    PARAMETER_LAYOUTS,
    JointModel,
    ModelFit,
    RigidModel,
)
from tactile_gym.estimation.joint_prior import JointTypePrior
from tactile_gym.estimation.joint_prismatic import PrismaticModel
from tactile_gym.estimation.joint_revolute import RevoluteModel
from tactile_gym.estimation.joint_type import (
    FLAGS,
    OUTCOMES,
    RULES,
    JointTypeEstimate,
    JointTypeEstimator,
    estimate_joint_type,
)
from tactile_gym.estimation.metrics import axis_error, axis_nees, direction_error
from tactile_gym.estimation.online import COVARIANCES, JointAxisEstimator
from tactile_gym.estimation.planar import edge_rotation_variance, planar_residual_variance
from tactile_gym.estimation.prior import AxisPrior
from tactile_gym.estimation.robust import LOSSES
from tactile_gym.estimation.slide import (
    SlideEstimate,
    fit_slide_direction,
    fit_slide_simple,
    slide_error,
)

__all__ = [
    "COVARIANCES",
    "COVARIANCE_LAYOUT",
    "FLAGS",
    "JOINT_TYPES",
    "LOSSES",
    "OUTCOMES",
    "PARAMETER_LAYOUTS",
    "RULES",
    "AxisEstimate",
    "AxisPrior",
    "JointAxisEstimator",
    "JointModel",
    "JointTypeEstimate",
    "JointTypeEstimator",
    "JointTypePrior",
    "ModelFit",
    "PrismaticModel",
    "RevoluteModel",
    "RigidModel",
    "SlideEstimate",
    "axis_error",
    "axis_nees",
    "direction_error",
    "edge_rotation_variance",
    "estimate_joint_type",
    "fit_axis_3d",
    "fit_axis_planar",
    "fit_axis_simple",
    "fit_slide_direction",
    "fit_slide_simple",
    "planar_residual_variance",
    "slide_error",
]
