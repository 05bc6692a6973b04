"""Intrinsic contact sensing from one wrench: contact point, normal, friction moment, edge.

``estimate_contact`` recovers where the object touches the skin (Bicchi's intrinsic contact
sensing, ``tactile_gym.sensing.contact_point``), the friction moment split as in Matsuo et al.
(2010), eq. 12-14, the direction of the object's edge with its predicted error
(``tactile_gym.sensing.edge``), and the indentation of the skin
(``tactile_gym.sensing.indentation``); ``docs/design.md`` 4 and 5.

Conventions (``docs/design.md`` 2):

* SI units: metres, newtons, newton-metres, radians. Stiffness in N/m^3 (Winkler modulus).
* Every point, direction, force and moment taken or returned here is in the **sensor frame**:
  origin at the F/T sensor, z along the finger axis, hemisphere centre at (0, 0, L) with
  L = ``FingertipGeometry.cylinder_length``.
* ``force`` f is the force the object applies to the fingertip; ``moment`` m is the moment of
  that load about the sensor origin. A contact at r that transmits f and a friction moment q
  gives m = r x f + q (eq. 11-12). Where f pushes into the skin, f . n < 0 for the outward
  normal n.
* The skin's outer surface is the hemisphere (z >= L) plus the cylinder side (0 <= z <= L),
  both of radius R = ``FingertipGeometry.outer_radius``.

The numeric core, from the wrench to every field of the estimate, is one compiled call
(``contact_core``, ``tactile_gym._jit``; ``docs/design.md`` 7.1), which ``TouchSensor`` calls
on every reading too. NumPy and numba only; no pybullet or torch, so real robots can reuse it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.sensing.contact_point import (
    CONTACT_MODELS,
    FOUND,
    MISSES,
    PULLS,
    contact_point,
    friction_moment,
    line_offset,
)
from tactile_gym.sensing.edge import EDGE_STD_UNOBSERVABLE, edge_from_force, nan3
from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sensing.indentation import CONTACT_SHAPES, indentation_correction
from tactile_gym.sensing.sensor import TOUCH_FORCE, SensorConfig
from tactile_gym.spatial import orient_like
from tactile_gym.validation import check_number
from tactile_gym.vec3 import dot_kernel

__all__ = [
    "MIN_TILT_SNR",
    "ContactEstimate",
    "contact_core",
    "contact_parameters",
    "estimate_contact",
]

_DEFAULT_GEOMETRY = FingertipGeometry()
#: The least tilt signal-to-noise ratio of an observable edge, standard deviations
#: (``estimate_contact``'s ``min_tilt_snr``).
MIN_TILT_SNR = 3.0
_NAN3 = (math.nan, math.nan, math.nan)
_NAN_MATRIX = np.full((3, 3), np.nan)


@dataclass(frozen=True)
class ContactEstimate:
    """One contact estimated from one wrench. All vectors in the sensor frame.

    Attributes:
        valid: whether a contact was found.
        reason: why not, "" when valid.
        point: (3,) contact point r on the outer skin surface, m; NaN when invalid.
        normal: (3,) outward unit surface normal n at r; NaN when invalid.
        force: (3,) the measured force f, N (always the input).
        normal_moment: (3,) q_n = (q . n) n with q = m - r x f (eq. 12), N m.
        tangential_moment: (3,) q_t = q - q_n (eq. 14), N m.
        edge_direction: (3,) unit edge direction e, or NaN when unobservable. See
            ``estimate_contact`` for how it relates to the paper's n x q_t and its sign.
        edge_std: predicted 1-sigma (RMS) angle error of e, rad, sqrt(trace(edge_cov));
            ``EDGE_STD_UNOBSERVABLE`` (pi/2) when e carries no information.
        edge_cov: (3, 3) first-order covariance of the perturbation de of the unit edge e,
            rad^2: var_in g g^T + var_out n n^T + c (g n^T + n g^T) with g = n x e, var_in
            for e turning about n, var_out for e tilting out of the tangent plane, and c
            their covariance (they share the turn of n, so c != 0 in general). e is in its
            null space. NaN when e is unobservable.
        corrected_point: (3,) indentation-corrected contact point r - delta n, m; NaN when
            no skin stiffness was given or the estimate is invalid.
        indentation: modelled indentation depth delta, m; NaN when not computed.
        on_surface: False when the line of action missed the skin and the surface point
            closest to it was used instead (the estimate is still valid, but flagged).
        tilt: angle between f and -n, rad; NaN when invalid.
        edge_observable: whether e carries edge information: the tilt stands out of the
            sensor noise by more than ``min_tilt_snr`` standard deviations (see
            ``estimate_contact``). False when invalid.
        tilt_snr: that margin, sqrt(f_t^T S^-1 f_t) with S the predicted covariance of the
            tangential force f_t; 0 for an untilted force; NaN when invalid or when f is
            tangent to the skin; inf when the noise leaves f_t exact in some direction
            (e.g. zero sensor noise).
        line_offset: distance of the wrench's line of action (its central axis) from the
            centre of curvature under the contact, r - R n (the hemisphere's centre on the
            hemisphere, the finger axis at r's height on the cylinder), m; R sin(tilt) for
            the hard model. NaN when invalid.
    """

    valid: bool
    reason: str
    point: np.ndarray
    normal: np.ndarray
    force: np.ndarray
    normal_moment: np.ndarray
    tangential_moment: np.ndarray
    edge_direction: np.ndarray
    edge_std: float
    edge_cov: np.ndarray
    corrected_point: np.ndarray
    indentation: float
    on_surface: bool
    tilt: float
    edge_observable: bool
    tilt_snr: float
    line_offset: float

    @classmethod
    def invalid(cls, force: np.ndarray, reason: str) -> ContactEstimate:
        """An estimate that found no contact.

        Args:
            force: (3,) the measured force, sensor frame, N.
            reason: why no contact was found; must not be empty.
        """
        if not reason:
            raise ValueError("reason must describe why the estimate is invalid, got ''")
        return cls(
            valid=False,
            reason=reason,
            point=nan3(),
            normal=nan3(),
            force=np.array(force, dtype=float),
            normal_moment=nan3(),
            tangential_moment=nan3(),
            edge_direction=nan3(),
            edge_std=EDGE_STD_UNOBSERVABLE,
            edge_cov=_NAN_MATRIX.copy(),
            corrected_point=nan3(),
            indentation=math.nan,
            on_surface=False,
            tilt=math.nan,
            edge_observable=False,
            tilt_snr=math.nan,
            line_offset=math.nan,
        )


def _vec3(value, name: str) -> tuple[float, float, float]:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got {a.shape}")
    x, y, z = a.tolist()
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f"{name} must be finite, got {a.tolist()}")
    return x, y, z


def estimate_contact(
    force,
    moment,
    geometry: FingertipGeometry = _DEFAULT_GEOMETRY,
    *,
    model: str = "soft",
    force_threshold: float = TOUCH_FORCE,
    force_noise_std: float = SensorConfig.force_noise_std,
    moment_noise_std: float = SensorConfig.moment_noise_std,
    skin_stiffness: float | None = None,
    contact_shape: str = "plane",
    previous_edge=None,
    min_tilt_snr: float = MIN_TILT_SNR,
) -> ContactEstimate:
    """Contact point, normal, friction moment and edge direction from one wrench.

    **Contact point** (Bicchi's intrinsic contact sensing), solved on each piece of the skin
    (hemisphere z >= L, cylinder side 0 <= z <= L) in closed form:

    * ``model="hard"``: r lies on the wrench's line of action r0 + t f/|f|,
      r0 = f x m / |f|^2; q = m - r x f is then pitch * f.
    * ``model="soft"``: the contact may also transmit a torsion about the normal, so r is
      where m - r x f is parallel to n(r) (q_t = 0 by construction). On the sphere this
      reduces to a quadratic in (n . f/|f|)^2, on the cylinder to sin(azimuth) = m_z/(R|f_xy|)
      plus a linear equation for z (see ``_sphere_soft``, ``_cylinder_soft``).

    Of the solutions, the one inside its piece where f pushes into the skin (f . n < 0) is kept;
    if both pieces give one (soft model only), the one with the smaller torsion |q . n|.
    Otherwise the line of action missed the skin, and the fallback is the nearest of: a
    pushing solution just outside its piece (e.g. below the rim z = 0) moved onto the skin,
    and, when no pulling solution lies on the skin, the skin point closest to the line. If it
    is within the noise tolerance 3 (sigma_m + (L + R) sigma_f)/|f|, it is used with
    ``on_surface=False``; if not, the estimate is invalid: "force pulls out of the skin" when
    a pulling solution lies on the skin, else "line of action misses surface". A wrench cannot
    tell a pull at r from a push along the same line where it enters the far side of the
    finger, so a pull is reported only when that entry is not on the skin.

    **Edge direction.** With r on the line of action, q = pitch * f, so the paper's
    q_t = pitch * f_t and its n x q_t = pitch * (n x f_t). This function returns
    e = normalise(n x f_t) (= normalise(n x f)), which equals sign(pitch) times the paper's
    normalise(n x q_t) for the hard model and stays defined when the pitch is ~0 and for the
    soft model (where q_t = 0). e lies in the tangent plane, perpendicular to the plane that
    holds n and f: a force tilted away from -n across an edge reveals the edge. Sign: if
    ``previous_edge`` is given, e is flipped to have e . previous_edge >= 0 (continuity);
    otherwise its component of largest magnitude is made positive (ties: the first).
    ``edge_cov`` is the first-order covariance of de under isotropic Gaussian sensor noise
    (see ``_edge_noise``) and ``edge_std`` = sqrt(trace(edge_cov)) the RMS angle error, about
    (sigma_f + sigma_m/R)/(|f| sin tilt). Most of it lies along e x f: an error in the
    contact point turns n, and e stays perpendicular to f.

    **Observability** (docs/design.md 4.1). e carries edge information only when f is tilted
    from -n; a press whose line of action passes through the centre of curvature (a flat
    face, or any radial press) has no tilt, and its e is noise. The edge counts as
    observable when the tangential force f_t stands out of its predicted noise,
    ``tilt_snr`` = sqrt(f_t^T S^-1 f_t) > ``min_tilt_snr`` (S the first-order 2x2
    covariance of f_t in the tangent plane), and edge_std < pi/2. An untilted press then
    passes with probability exp(-min_tilt_snr^2 / 2), 1.1 % at the default 3 (chi-square,
    2 degrees of freedom); one whose noise-free tilt_snr is s0 is flagged with probability
    P(chi2(2, s0^2) < min_tilt_snr^2) <= Phi(min_tilt_snr - s0) (noncentral chi-square).
    When it is not observable, ``edge_observable`` is False, e and edge_cov are NaN and
    edge_std is ``EDGE_STD_UNOBSERVABLE``. A shear on a flat face tilts f as an edge does,
    so this test cannot tell the two apart. ``line_offset`` says how far the line of action
    passes from the centre of curvature.

    **Indentation** (docs/design.md 4.5): with ``skin_stiffness`` given,
    delta = ``indentation_depth(-f . n, skin_stiffness, R, contact_shape)`` capped at the skin
    thickness (the shell is rigid), and corrected_point = r - delta n. The sphere formula is
    used on the cylinder too, an approximation there.

    Args:
        force: (3,) force f the object applies to the fingertip, sensor frame, N.
        moment: (3,) moment m of that load about the sensor origin, sensor frame, N m.
        geometry: the fingertip.
        model: one of ``CONTACT_MODELS``.
        force_threshold: below this |f|, N, there is no contact (``TOUCH_FORCE``).
        force_noise_std: sensor force noise per axis, N (for edge_std and the miss tolerance);
            defaults to ``SensorConfig``'s.
        moment_noise_std: sensor moment noise per axis, N m; defaults to ``SensorConfig``'s.
        skin_stiffness: Winkler modulus k_n, N/m^3, to model the indentation; None skips it.
        contact_shape: object shape for the indentation model, one of ``CONTACT_SHAPES``;
            ``"plane"``, what a press near an edge is like (``docs/design.md`` 4.5).
        previous_edge: (3,) last edge direction, sensor frame, to fix the sign of e.
        min_tilt_snr: the least ``tilt_snr`` at which the edge counts as observable, in
            standard deviations; >= 0. An untilted press passes with probability
            exp(-min_tilt_snr^2 / 2).

    Returns:
        A ContactEstimate, valid or not (never raises for physically odd wrenches).

    Raises:
        ValueError: bad shapes, non-finite input, unknown model or shape, negative parameters.
    """
    f = _vec3(force, "force")
    m = _vec3(moment, "moment")
    if model not in CONTACT_MODELS:
        raise ValueError(f"model must be one of {CONTACT_MODELS}, got {model!r}")
    if contact_shape not in CONTACT_SHAPES:
        raise ValueError(f"contact_shape must be one of {CONTACT_SHAPES}, got {contact_shape!r}")
    threshold = check_number("force_threshold", force_threshold, 0.0)
    sigma_f = check_number("force_noise_std", force_noise_std, 0.0)
    sigma_m = check_number("moment_noise_std", moment_noise_std, 0.0)
    min_snr = check_number("min_tilt_snr", min_tilt_snr, 0.0)
    if skin_stiffness is not None:
        k_n = float(skin_stiffness)
        if not math.isfinite(k_n) or k_n <= 0.0:
            raise ValueError(
                f"skin_stiffness must be a finite number > 0 N/m^3 or None, got {skin_stiffness!r}"
            )
        skin_stiffness = k_n
    prev = None if previous_edge is None else _vec3(previous_edge, "previous_edge")
    parameters = contact_parameters(
        geometry, model, threshold, sigma_f, sigma_m, skin_stiffness, contact_shape, min_snr
    )
    out = contact_core(np.array(f + m), parameters, 1.0)
    values = out.tolist()
    if values[STATUS] != FOUND:
        return ContactEstimate.invalid(f, _invalid_reason(values, threshold))
    edge = out[EDGE]
    if values[OBSERVABLE]:
        edge = orient_like(edge, [] if prev is None else [prev])
    return ContactEstimate(
        valid=True,
        reason="",
        point=out[POINT],
        normal=out[NORMAL],
        force=np.array(f),
        normal_moment=out[NORMAL_MOMENT],
        tangential_moment=out[TANGENTIAL_MOMENT],
        edge_direction=edge,
        edge_std=values[EDGE_STD],
        edge_cov=out[EDGE_COV].reshape(3, 3),
        corrected_point=out[CORRECTED],
        indentation=values[INDENTATION],
        on_surface=bool(values[ON_SURFACE]),
        tilt=values[TILT],
        edge_observable=bool(values[OBSERVABLE]),
        tilt_snr=values[TILT_SNR],
        line_offset=values[LINE_OFFSET],
    )


#: ``contact_core``'s statuses: a contact, a force below the threshold, and those of
#: ``contact_point`` that found none.
BELOW = 3
#: Where ``contact_core`` writes each field of the estimate (a slice or an index): the
#: status, |f|, then ``ContactEstimate``'s fields (the edge unsigned, the booleans as 0 or
#: 1), then how far a missed line of action passes the skin and the tolerance.
STATUS, FNORM = 0, 1
POINT, NORMAL = slice(2, 5), slice(5, 8)
NORMAL_MOMENT, TANGENTIAL_MOMENT = slice(8, 11), slice(11, 14)
EDGE, EDGE_STD, EDGE_COV = slice(14, 17), 17, slice(18, 27)
CORRECTED, INDENTATION, ON_SURFACE, TILT = slice(27, 30), 30, 31, 32
OBSERVABLE, TILT_SNR, LINE_OFFSET, MISS, TOLERANCE = 33, 34, 35, 36, 37
_FIELDS = 38


def contact_parameters(
    geometry: FingertipGeometry,
    model: str,
    threshold: float,
    sigma_f: float,
    sigma_m: float,
    skin_stiffness: float | None,
    contact_shape: str,
    min_snr: float,
) -> np.ndarray:
    """``contact_core``'s parameters, already checked (``estimate_contact``'s, in its order):
    the soft model (1.0 or 0.0), R, L, the threshold, the noise, the stiffness (NaN: no
    indentation), the skin thickness, the edge shape (1.0 or 0.0), the least tilt SNR."""
    return np.array(
        [
            float(model == "soft"),
            geometry.outer_radius,
            geometry.cylinder_length,
            threshold,
            sigma_f,
            sigma_m,
            math.nan if skin_stiffness is None else skin_stiffness,
            geometry.skin_thickness,
            float(contact_shape == "edge"),
            min_snr,
        ]
    )


@kernel()
def contact_core(wrench, parameters, noise_scale):
    """The contact estimate of one checked wrench, every field in one array (``STATUS`` ...).

    Args:
        wrench: (6,) finite force (N) and moment (N m), sensor frame.
        parameters: (10,) ``contact_parameters``.
        noise_scale: factor on the sensor noise (1/sqrt(n) for the mean of n readings).

    Returns:
        (38,) floats at the indices and slices of this module (``STATUS``: ``FOUND``,
        ``PULLS``, ``MISSES`` or ``BELOW``); only the status, |f| and, for a miss, the miss
        distance and tolerance are set for an invalid estimate.
    """
    out = np.full(_FIELDS, np.nan)
    f = (wrench[0], wrench[1], wrench[2])
    m = (wrench[3], wrench[4], wrench[5])
    soft = parameters[0] != 0.0
    radius, length, threshold = parameters[1], parameters[2], parameters[3]
    sigma_f = parameters[4] * noise_scale
    sigma_m = parameters[5] * noise_scale
    stiffness, thickness = parameters[6], parameters[7]
    fnorm = math.sqrt(dot_kernel(f, f))
    out[FNORM] = fnorm
    if fnorm < threshold or fnorm == 0.0:
        out[STATUS] = BELOW
        return out
    status, r, n, on_sphere, on_surface, miss, tol = contact_point(
        f, m, fnorm, soft, radius, length, sigma_f, sigma_m
    )
    out[STATUS] = status
    if status != FOUND:
        out[MISS], out[TOLERANCE] = miss, tol
        return out
    q, q_n, q_t = friction_moment(f, m, r, n)
    observable, e, edge_std, edge_cov, tilt, snr = edge_from_force(
        f, fnorm, r, n, on_sphere, radius, soft, sigma_f, sigma_m, parameters[9]
    )
    for i in range(3):  # POINT, NORMAL, NORMAL_MOMENT, TANGENTIAL_MOMENT, EDGE
        out[2 + i] = r[i]
        out[5 + i] = n[i]
        out[8 + i] = q_n[i]
        out[11 + i] = q_t[i]
        out[14 + i] = e[i]
    out[EDGE_STD] = edge_std
    for i in range(9):  # EDGE_COV
        out[18 + i] = edge_cov[i]
    if not math.isnan(stiffness):
        corrected, delta = indentation_correction(
            f, r, n, stiffness, radius, thickness, parameters[8] != 0.0
        )
        for i in range(3):  # CORRECTED
            out[27 + i] = corrected[i]
        out[INDENTATION] = delta
    out[ON_SURFACE] = 1.0 if on_surface else 0.0
    out[TILT] = tilt
    out[OBSERVABLE] = 1.0 if observable else 0.0
    out[TILT_SNR] = snr
    out[LINE_OFFSET] = line_offset(f, fnorm, q, n, radius)
    return out


def _invalid_reason(out: list[float], threshold: float) -> str:
    """Why ``contact_core`` found no contact, from its output (a list of floats)."""
    status = out[STATUS]
    if status == BELOW:
        return f"force below threshold ({out[FNORM]:.4g} N < {threshold} N)"
    if status == PULLS:
        return "force pulls out of the skin (f . n > 0)"
    if status == MISSES:
        return (
            f"line of action misses surface by {out[MISS]:.3g} m (tolerance {out[TOLERANCE]:.3g} m)"
        )
    raise ValueError(f"not an invalid status of contact_core: {status!r}")
