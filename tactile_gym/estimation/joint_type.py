"""Which joint is it? Posterior joint-type probabilities from touch alone (docs/design.md 6.10).

NumPy/SciPy only. World frame, metres, radians. Measurements are the axis fits' (a contact
point with ``point_std``, an edge direction with ``edge_std`` or ``edge_cov``), physically
oriented (``e = n x f``, docs/design.md 7.3), with two labels: the edge line of the link the
press was on (``line``) and the link configuration it was taken at (``config``: presses with
one label were taken without the link moving in between; by default every press is a
configuration of its own).

:class:`JointTypeEstimator` fits the rigid, revolute and prismatic models
(:mod:`.joint_models`) and the "none" alternative (every measurement its own line) and
weighs them by their Laplace evidence and the prior type probabilities (the selection rule,
docs/design.md 6.10). Degenerate data is flagged, never guessed:

* ``"too_few"``: fewer than ``min_measurements``; the probabilities are the prior's;
* ``"one_configuration"``: every press at one configuration, so nothing moved that could
  tell the types apart; the probabilities are the prior's;
* ``"no_motion"``: the edge lines did not move beyond the noise (the rigid model passes its
  goodness-of-fit test): rigid, or a joint that did not move. The probabilities weigh the
  two by the prior's ``stuck_probability`` per configuration;
* ``"one_edge"``: every edge measured has one direction, so a slide along it would not move
  its line (and the prismatic direction is only partly identified): with the prior's
  ``along_edge_probability`` a slide along it stays as likely as the prior says, not ruled
  out;
* ``"none_fits"``: every model fails its chi-square goodness-of-fit test (at
  ``fit_alpha``): the edges are neither one direction nor turning about one axis, or the
  stated noise is too tight. Grossly inconsistent data also moves the probability to the
  explicit ``"none"`` outcome;
* ``"best_misfits"``: the most probable model fails its test while another passes: the
  motion is small against the priors' ranges, and the evidence prefers a model the data
  reject to one whose parameters are a priori unlikely.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from tactile_gym.estimation.axis import as_edge_covs
from tactile_gym.estimation.interface import FULL_REFIT_GROWTH
from tactile_gym.estimation.joint_models import (
    JOINT_TYPES,
    MODES,
    ModelFit,
    RigidModel,
    saturated_evidence,
)
from tactile_gym.estimation.joint_prior import JointTypePrior
from tactile_gym.estimation.joint_prismatic import PrismaticModel
from tactile_gym.estimation.joint_revolute import RevoluteModel
from tactile_gym.estimation.lines import (
    DOF_PER_MEASUREMENT,
    LineData,
    edge_covariances,
    line_data,
)
from tactile_gym.estimation.robust import check_loss

__all__ = [
    "FLAGS",
    "OUTCOMES",
    "RULES",
    "JointTypeEstimate",
    "JointTypeEstimator",
    "estimate_joint_type",
]

OUTCOMES = (*JOINT_TYPES, "none")
"""The outcomes the probabilities are over: the joint types, then "none" (no model holds)."""

RULES = ("laplace", "bic")
"""Model-selection rules: the Laplace evidence (default), or the Bayesian information
criterion ``ln L - (k / 2) ln(4 N)`` for comparison (docs/design.md 6.10)."""

FLAGS = ("too_few", "one_configuration", "no_motion", "one_edge", "none_fits", "best_misfits")
"""The flags a :class:`JointTypeEstimate` may carry (see the module docstring)."""

# Edge directions within this angle (or 4 edge stds per normal direction) of their common
# direction count as one direction (flag "one_edge"), rad.
_ONE_DIRECTION_TOL = math.radians(1.0)


@dataclass(frozen=True)
class JointTypeEstimate:
    """The joint type and each model's fit.

    Attributes:
        probabilities: (4,) posterior probabilities of ``OUTCOMES``: rigid, revolute,
            prismatic, none.
        joint_type: the most probable outcome; None when the measurements cannot tell the
            types apart at all (flags ``"too_few"``, ``"one_configuration"``).
        models: each joint type's :class:`~tactile_gym.estimation.joint_models.ModelFit`
            (empty when the models were not fitted).
        flags: the conditions of ``FLAGS`` that hold.
        reasons: one sentence per flag.
        n_measurements: number of measurements.
        log_evidence: (4,) the log evidence of each outcome under the rule (-inf when not
            fitted).
    """

    probabilities: np.ndarray
    joint_type: str | None
    models: dict[str, ModelFit]
    flags: tuple[str, ...]
    reasons: tuple[str, ...]
    n_measurements: int
    log_evidence: np.ndarray = field(default_factory=lambda: np.full(len(OUTCOMES), -np.inf))

    def probability(self, outcome: str) -> float:
        """The probability of one of ``OUTCOMES``."""
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, got {outcome!r}")
        return float(self.probabilities[OUTCOMES.index(outcome)])

    @property
    def best(self) -> ModelFit | None:
        """The fit of the most probable joint type (None when the models were not fitted)."""
        if not self.models:
            return None
        return self.models[JOINT_TYPES[int(np.argmax(self.probabilities[:3]))]]


class JointTypeEstimator:
    """Online joint-type estimation: add one measurement at a time.

    Each :meth:`estimate` after an :meth:`add` refits the models from their last solutions
    (from scratch once the measurements have grown by ``FULL_REFIT_GROWTH``); the revolute
    axis fit updates as :class:`~tactile_gym.estimation.online.JointAxisEstimator` does.

    Args:
        mode: ``"planar"`` (a revolute axis is vertical, a prismatic direction horizontal)
            or ``"3d"``.
        prior: the priors (:class:`~tactile_gym.estimation.joint_prior.JointTypePrior`);
            kept across :meth:`reset`.
        loss: the revolute axis fit's loss (one of ``LOSSES``).
        covariance: what the revolute axis fit takes the handed noise for
            (``COVARIANCES``, :class:`~tactile_gym.estimation.online.JointAxisEstimator`);
            the models' likelihoods take it as independent either way.
        min_measurements: measurements needed before the models are fitted (>= 2).
        rule: the model-selection rule, one of ``RULES``.
        fit_alpha: level of the chi-square goodness-of-fit tests (flags ``"no_motion"``
            and ``"none_fits"``), in (0, 1).
        restart_misfits: a model whose refit from its last solution fails its
            goodness-of-fit test is refitted from scratch too, and the likelier fit kept (a
            start from an early estimate can hold the fit in a wrong minimum; the v1 joint
            ids, ``docs/design.md`` 7.12). False: the last solutions only (v0).
    """

    def __init__(
        self,
        mode: str = "planar",
        prior: JointTypePrior | None = None,
        loss: str = "soft_l1",
        min_measurements: int = 2,
        rule: str = "laplace",
        fit_alpha: float = 1e-3,
        covariance: str = "independent",
        restart_misfits: bool = False,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        if prior is not None and not isinstance(prior, JointTypePrior):
            raise ValueError(f"prior must be a JointTypePrior or None, got {prior!r}")
        check_loss(loss)
        if not (float(min_measurements).is_integer() and min_measurements >= 2):
            raise ValueError(f"min_measurements must be an integer >= 2, got {min_measurements!r}")
        if rule not in RULES:
            raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
        if not (math.isfinite(fit_alpha) and 0.0 < fit_alpha < 1.0):
            raise ValueError(f"fit_alpha must be in (0, 1), got {fit_alpha!r}")
        self.mode = mode
        self.prior = JointTypePrior() if prior is None else prior
        self.loss = loss
        self.min_measurements = int(min_measurements)
        self.rule = rule
        self.fit_alpha = float(fit_alpha)
        self.covariance = covariance
        self.restart_misfits = bool(restart_misfits)
        self.reset()

    def reset(self) -> None:
        """Forget every measurement and the models' last fits."""
        self._points: list[np.ndarray] = []
        self._edges: list[np.ndarray] = []
        self._point_std: list[float] = []
        self._edge_std: list[float] = []
        self._edge_cov: list[np.ndarray] = []
        self._lines: list[int] = []
        self._configs: list[int] = []
        self._line_ids: dict[int, int] = {}
        self._config_ids: dict[object, int] = {}
        self._models = (
            RigidModel(self.mode, self.prior),
            RevoluteModel(self.mode, self.prior, self.loss, self.covariance),
            PrismaticModel(self.mode, self.prior),
        )
        self._n_full = 0
        self._cached: JointTypeEstimate | None = None

    @property
    def n_measurements(self) -> int:
        """Number of measurements added since the last reset."""
        return len(self._points)

    def add(
        self,
        point: np.ndarray,
        edge: np.ndarray,
        point_std: float,
        edge_std: float,
        edge_cov: np.ndarray | None = None,
        *,
        line: int = 0,
        config: int | None = None,
    ) -> None:
        """Add one measurement.

        Args:
            point: (3,) contact point, world frame, m.
            edge: (3,) edge direction, world frame, any length > 0, physically oriented
                (its sign is the measurement's: ``e = n x f``).
            point_std: contact-point std per axis, m, >= 0.
            edge_std: total RMS angle error of the edge, rad, >= 0; the noise is isotropic
                about the edge unless ``edge_cov`` is given.
            edge_cov: optional (3, 3) covariance of the edge's perturbation, world frame,
                rad^2 (as for :func:`~tactile_gym.estimation.fit3d.fit_axis_3d`).
            line: label of the link's edge line the press was on (any integer).
            config: label of the link configuration (any integer): presses with one label
                were taken without the link moving in between. None: a configuration of
                its own.

        Raises:
            ValueError: on a malformed point or edge, a zero edge, a negative or non-finite
                std, an invalid edge_cov, or a label that is not an integer.
        """
        x = _vector(point, "point")
        e = _vector(edge, "edge")
        if not float(np.linalg.norm(e)) > 1e-12:
            raise ValueError(f"edge must have a non-zero length, got {e.tolist()}")
        sx, se = float(point_std), float(edge_std)
        if not (math.isfinite(sx) and sx >= 0):
            raise ValueError(f"point_std must be finite and >= 0 m, got {point_std!r}")
        if not (math.isfinite(se) and se >= 0):
            raise ValueError(f"edge_std must be finite and >= 0 rad, got {edge_std!r}")
        unit = e / np.linalg.norm(e)
        if edge_cov is None:
            cov = edge_covariances(unit[None], np.array([se]), None)[0]
        else:
            cov = np.asarray(edge_cov, dtype=float)
            if cov.shape != (3, 3):
                raise ValueError(f"edge_cov must have shape (3, 3), got {cov.shape}")
            cov = as_edge_covs(cov[None], unit[None])[0]
        if not _is_int(line):
            raise ValueError(f"line must be an integer label, got {line!r}")
        if config is not None and not _is_int(config):
            raise ValueError(f"config must be an integer label or None, got {config!r}")
        n = len(self._points)
        key = ("own", n) if config is None else int(config)
        self._points.append(x)
        self._edges.append(unit)
        self._point_std.append(sx)
        self._edge_std.append(se)
        self._edge_cov.append(cov)
        self._lines.append(self._line_ids.setdefault(int(line), len(self._line_ids)))
        self._configs.append(self._config_ids.setdefault(key, len(self._config_ids)))
        self._cached = None

    def estimate(self) -> JointTypeEstimate:
        """The current joint-type estimate (cached until the next :meth:`add`)."""
        if self._cached is None:
            self._cached = self._refit()
        return self._cached

    @property
    def data(self) -> LineData:
        """The measurements added, validated, whitened and labelled (a new object per
        call)."""
        return line_data(
            np.array(self._points),
            np.array(self._edges),
            np.array(self._point_std),
            np.array(self._edge_std),
            np.array(self._edge_cov),
            np.array(self._lines),
            np.array(self._configs),
        )

    def _refit(self) -> JointTypeEstimate:
        n = self.n_measurements
        prior_p = np.exp(self.prior.log_outcome_priors)
        if n < self.min_measurements:
            reason = f"{n} measurements, fewer than the {self.min_measurements} needed"
            return JointTypeEstimate(prior_p, None, {}, ("too_few",), (reason,), n)
        if len(self._config_ids) == 1:
            reason = "every press at one configuration: nothing moved to tell the types apart"
            return JointTypeEstimate(prior_p, None, {}, ("one_configuration",), (reason,), n)
        data = self.data
        full = not n < self._n_full * FULL_REFIT_GROWTH
        if full:
            for model in self._models:
                model.reset_start()
            self._n_full = n
        rigid_model, revolute_model, prismatic_model = self._models
        rigid = rigid_model.fit(data)
        fits = {
            "rigid": rigid,
            "revolute": revolute_model.fit(data, rigid),
            "prismatic": prismatic_model.fit(data, rigid),
        }
        if self.restart_misfits and not full:
            models = list(self._models)
            for i, name in ((1, "revolute"), (2, "prismatic")):
                if fits[name].fit_probability >= self.fit_alpha:
                    continue
                fresh_model = copy.deepcopy(models[i])
                fresh_model.reset_start()
                fresh = fresh_model.fit(data, rigid)
                if fresh.log_likelihood > fits[name].log_likelihood:
                    fits[name], models[i] = fresh, fresh_model
            self._models = tuple(models)
        log_z = np.empty(len(OUTCOMES))
        if self.rule == "laplace":
            for i, name in enumerate(JOINT_TYPES):
                log_z[i] = fits[name].log_evidence
            log_z[3] = saturated_evidence(data, self.prior)
        else:
            n_res = DOF_PER_MEASUREMENT * n
            for i, name in enumerate(JOINT_TYPES):
                f = fits[name]
                log_z[i] = f.log_likelihood - 0.5 * f.n_params * math.log(n_res)
            # Every measurement its own line fits exactly, at 4 parameters each.
            log_z[3] = data.log_norm - 0.5 * n_res * math.log(n_res)
        log_post = log_z + self.prior.log_outcome_priors
        post = np.exp(log_post - log_post.max())
        post /= post.sum()
        flags, reasons = self._flags(data, fits, post)
        return JointTypeEstimate(
            post, OUTCOMES[int(np.argmax(post))], fits, flags, reasons, n, log_z
        )

    def _flags(self, data: LineData, fits: dict[str, ModelFit], post: np.ndarray):
        flags, reasons = [], []
        rigid = fits["rigid"]
        if rigid.fit_probability >= self.fit_alpha:
            flags.append("no_motion")
            reasons.append(
                "the edge lines did not move beyond the noise (the rigid model fits, chi2 "
                f"{rigid.chi2:.1f} for {rigid.dof:.1f} dof): rigid, or a joint that did not move"
            )
        e = data.e
        principal = np.linalg.eigh(e.T @ e)[1][:, 2]
        spread = float(np.arccos(min(float(np.min(np.abs(e @ principal))), 1.0)))
        tol = max(_ONE_DIRECTION_TOL, 4.0 * float(data.edge_std.max()))
        if spread <= tol:
            flags.append("one_edge")
            reasons.append(
                f"every edge within {math.degrees(spread):.1f} deg of one direction: a slide "
                "along it would not move its line, and the prismatic direction is only "
                "partly identified"
            )
        passing = [f.joint_type for f in fits.values() if f.fit_probability >= self.fit_alpha]
        if not passing:
            flags.append("none_fits")
            reasons.append(
                f"no model passes its goodness-of-fit test (p < {self.fit_alpha:g}): the edges "
                "are neither one direction nor turning about one axis, or the stated noise "
                "is too small"
            )
        else:
            best = fits[JOINT_TYPES[int(np.argmax(post[:3]))]]
            if best.joint_type not in passing:
                flags.append("best_misfits")
                reasons.append(
                    f"the most probable model ({best.joint_type}) fails its goodness-of-fit "
                    f"test (chi2 {best.chi2:.1f} for {best.dof:.1f} dof) while "
                    f"{', '.join(passing)} passes: the motion is small against the priors' "
                    "ranges"
                )
        return tuple(flags), tuple(reasons)


def _vector(value: object, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be a finite (3,) vector, got {value!r}")
    return v


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def estimate_joint_type(
    points: np.ndarray,
    edges: np.ndarray,
    point_std: np.ndarray | float,
    edge_std: np.ndarray | float,
    edge_cov: np.ndarray | None = None,
    *,
    lines: np.ndarray | None = None,
    configs: np.ndarray | None = None,
    mode: str = "planar",
    prior: JointTypePrior | None = None,
    loss: str = "soft_l1",
    rule: str = "laplace",
) -> JointTypeEstimate:
    """The joint type of a batch of measurements: :class:`JointTypeEstimator` fed them all.

    Args:
        points: (N, 3) contact points, world frame, m.
        edges: (N, 3) physically oriented edge directions, world frame.
        point_std: contact-point std per axis, m: scalar or (N,).
        edge_std: total RMS edge angle error, rad: scalar or (N,).
        edge_cov: optional (N, 3, 3) edge covariances, rad^2.
        lines: optional (N,) integer edge-line labels (default: all one line).
        configs: optional (N,) integer configuration labels (default: each its own).
        mode, prior, loss, rule: as for :class:`JointTypeEstimator`.

    Raises:
        ValueError: on malformed input (see :meth:`JointTypeEstimator.add`).
    """
    est = JointTypeEstimator(mode, prior, loss, rule=rule)
    feed(est, points, edges, point_std, edge_std, edge_cov, lines, configs)
    return est.estimate()


def feed(
    est: JointTypeEstimator,
    points: np.ndarray,
    edges: np.ndarray,
    point_std: np.ndarray | float,
    edge_std: np.ndarray | float,
    edge_cov: np.ndarray | None,
    lines: np.ndarray | None,
    configs: np.ndarray | None,
) -> None:
    """Add a batch of measurements to an estimator (arguments as for
    :func:`estimate_joint_type`)."""
    x = np.asarray(points, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {x.shape}")
    n = x.shape[0]
    e = np.asarray(edges, dtype=float)
    if e.shape != (n, 3):
        raise ValueError(f"edges must have shape ({n}, 3), got {e.shape}")
    sx = _per_measurement(point_std, n, "point_std")
    se = _per_measurement(edge_std, n, "edge_std")
    cov = None if edge_cov is None else np.asarray(edge_cov, dtype=float)
    if cov is not None and cov.shape != (n, 3, 3):
        raise ValueError(f"edge_cov must have shape ({n}, 3, 3), got {cov.shape}")
    line_labels = np.zeros(n, dtype=int) if lines is None else np.asarray(lines)
    if line_labels.shape != (n,):
        raise ValueError(f"lines must have shape ({n},), got {line_labels.shape}")
    config_labels = None if configs is None else np.asarray(configs)
    if config_labels is not None and config_labels.shape != (n,):
        raise ValueError(f"configs must have shape ({n},), got {config_labels.shape}")
    for i in range(n):
        est.add(
            x[i],
            e[i],
            sx[i],
            se[i],
            None if cov is None else cov[i],
            line=line_labels[i].item(),
            config=None if config_labels is None else config_labels[i].item(),
        )


def _per_measurement(value: object, n: int, name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return np.full(n, float(a))
    if a.shape != (n,):
        raise ValueError(f"{name} must be a scalar or shape ({n},), got {a.shape}")
    return a
