"""Intrinsic contact sensing: contact point, normal, friction moment and edge direction.

From one wrench measured by the fingertip's 6-axis force/torque sensor this module recovers
where the object touches the skin (Bicchi's intrinsic contact sensing), the friction moment
split as in Matsuo et al. (2010), eq. 12-14, the direction of the object's edge with its
predicted error, and the indentation of the skin.

Conventions (docs/design.md 2):

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

NumPy only; no pybullet or torch, so real robots can reuse it. The per-call work is done on
Python floats because NumPy's per-call overhead dominates on 3-vectors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sensing.sensor import SensorConfig
from tactile_gym.spatial import orient_like

__all__ = [
    "CONTACT_SHAPES",
    "CONTACT_MODELS",
    "EDGE_STD_UNOBSERVABLE",
    "ContactEstimate",
    "edge_from_trace",
    "estimate_contact",
    "indentation_depth",
]

CONTACT_MODELS = ("soft", "hard")
CONTACT_SHAPES = ("edge", "plane")
EDGE_STD_UNOBSERVABLE = math.pi / 2  # rad; "no information" about an undirected line

_DEFAULT_GEOMETRY = FingertipGeometry()
_REGION_TOL = 1e-9  # m; slack on the piece boundaries (seam at z = L, rim at z = 0)
_NAN3 = (math.nan, math.nan, math.nan)
_NAN33 = _NAN3 * 3


def _nan3() -> np.ndarray:
    return np.full(3, np.nan)


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
            point=_nan3(),
            normal=_nan3(),
            force=np.array(force, dtype=float),
            normal_moment=_nan3(),
            tangential_moment=_nan3(),
            edge_direction=_nan3(),
            edge_std=EDGE_STD_UNOBSERVABLE,
            edge_cov=np.full((3, 3), np.nan),
            corrected_point=_nan3(),
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


def _nonneg(value: float, name: str, unit: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0.0:
        raise ValueError(f"{name} must be a finite number >= 0 {unit}, got {value!r}")
    return v


def _cross(a, b):
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _sphere_soft(f, u, fnorm, m, radius, length):
    """Soft-finger solutions on the full sphere: [(r, n, sigma, pushes)].

    With n = (r - c)/R and m' = m - c x f the condition m - r x f = sigma n reads
    m' = R n x f + sigma n. Split n = a u + n_perp (u = f/|f|). Along u: m'.u = sigma a.
    Across u, J = (u x .) is a quarter turn, so m'_perp = (sigma - R|f| J) n_perp and
    |m'_perp|^2 = (sigma^2 + R^2|f|^2)(1 - a^2). Eliminating sigma = k/a (k = m'.u) gives a
    quadratic in s = a^2, F^2 s^2 + (k^2 + P - F^2) s - k^2 = 0 (F = R|f|, P = |m'_perp|^2),
    whose roots have product -k^2/F^2 <= 0: exactly one root lies in [0, 1] (g(0) <= 0 <=
    g(1) = P). a = -sqrt(s) pushes into the skin, a = +sqrt(s) pulls. Then
    n_perp = (sigma m'_perp + F u x m'_perp) / (sigma^2 + F^2).
    """
    mp = (m[0] + length * f[1], m[1] - length * f[0], m[2])  # m - c x f, c = (0, 0, L)
    k = _dot(mp, u)
    mperp = (mp[0] - k * u[0], mp[1] - k * u[1], mp[2] - k * u[2])
    p2 = _dot(mperp, mperp)
    big_f = radius * fnorm
    f2 = big_f * big_f
    b = k * k + p2 - f2
    disc = math.sqrt(b * b + 4.0 * f2 * k * k)
    # Pick the cancellation-free form of the non-negative root.
    s = 2.0 * k * k / (b + disc) if b > 0.0 else (disc - b) / (2.0 * f2)
    s = min(max(s, 0.0), 1.0)
    if s < 1e-24:  # force tangent to the sphere: neither pushes nor pulls
        return []
    ux_m = _cross(u, mperp)
    out = []
    for a in (-math.sqrt(s), math.sqrt(s)):
        sigma = k / a
        den = sigma * sigma + f2
        n = (
            a * u[0] + (sigma * mperp[0] + big_f * ux_m[0]) / den,
            a * u[1] + (sigma * mperp[1] + big_f * ux_m[1]) / den,
            a * u[2] + (sigma * mperp[2] + big_f * ux_m[2]) / den,
        )
        nn = math.sqrt(_dot(n, n))
        n = (n[0] / nn, n[1] / nn, n[2] / nn)
        r = (radius * n[0], radius * n[1], length + radius * n[2])
        out.append((r, n, sigma, a < 0.0))
    return out


def _cylinder_soft(f, m, radius):
    """Soft-finger solutions on the infinite cylinder: [(r, n, sigma, pushes)].

    With n = (cos t, sin t, 0) and r = R n + z e_z, the z row of m - r x f = sigma n gives
    R h sin(phi - t) = m_z (h = |f_xy|, phi its azimuth); cos(phi - t) < 0 pushes. The row
    along e_z x n gives z = (m . (e_z x n) + R f_z) / (f . n), and sigma = m . n + z m_z / R.
    """
    h = math.hypot(f[0], f[1])
    if h < 1e-12:
        return []
    sin_psi = m[2] / (radius * h)
    if abs(sin_psi) > 1.0:
        return []
    cos_abs = math.sqrt(1.0 - sin_psi * sin_psi)
    if cos_abs < 1e-12:
        return []
    cphi, sphi = f[0] / h, f[1] / h
    out = []
    for cos_psi in (-cos_abs, cos_abs):
        nx = cphi * cos_psi + sphi * sin_psi
        ny = sphi * cos_psi - cphi * sin_psi
        fn = f[0] * nx + f[1] * ny
        z = (-m[0] * ny + m[1] * nx + radius * f[2]) / fn
        sigma = m[0] * nx + m[1] * ny + z * m[2] / radius
        out.append(((radius * nx, radius * ny, z), (nx, ny, 0.0), sigma, cos_psi < 0.0))
    return out


def _sphere_hard(r0, u, radius, length):
    """Line r0 + t u against the full sphere: [(r, n, 0.0, pushes)] (entry pushes)."""
    d = (r0[0], r0[1], r0[2] - length)
    beta = _dot(d, u)
    disc = beta * beta - (_dot(d, d) - radius * radius)
    if disc < 0.0:
        return []
    sq = math.sqrt(disc)
    out = []
    for t, pushes in ((-beta - sq, True), (-beta + sq, False)):
        r = (r0[0] + t * u[0], r0[1] + t * u[1], r0[2] + t * u[2])
        n = (r[0] / radius, r[1] / radius, (r[2] - length) / radius)
        out.append((r, n, 0.0, pushes))
    return out


def _cylinder_hard(r0, u, radius):
    """Line r0 + t u against the infinite cylinder: [(r, n, 0.0, pushes)] (entry pushes)."""
    a = u[0] * u[0] + u[1] * u[1]
    if a < 1e-24:
        return []
    b = r0[0] * u[0] + r0[1] * u[1]
    disc = b * b - a * (r0[0] * r0[0] + r0[1] * r0[1] - radius * radius)
    if disc < 0.0:
        return []
    sq = math.sqrt(disc)
    out = []
    for t, pushes in ((-(b + sq) / a, True), ((sq - b) / a, False)):
        r = (r0[0] + t * u[0], r0[1] + t * u[1], r0[2] + t * u[2])
        rho = math.hypot(r[0], r[1])
        out.append((r, (r[0] / rho, r[1] / rho, 0.0), 0.0, pushes))
    return out


def _radially_out(s, v, radius):
    """Skin point at distance R from the axis point (0, 0, s) in the direction of v.

    The skin (z >= 0) is the set of points at distance R from the segment
    S = {s e_z, 0 <= s <= L}; below the rim (z < 0) is the sensor body, so from s = 0 only
    horizontal directions lead to skin.
    """
    if s <= 0.0 and v[2] < 0.0:
        v = (v[0], v[1], 0.0)
    nv = math.sqrt(_dot(v, v))
    n = (1.0, 0.0, 0.0) if nv < 1e-15 else (v[0] / nv, v[1] / nv, v[2] / nv)
    return (radius * n[0], radius * n[1], s + radius * n[2]), n


def _project_to_skin(p, radius, length):
    """Skin point closest to the point p, its normal and the distance, m."""
    s = min(max(p[2], 0.0), length)
    r, n = _radially_out(s, (p[0], p[1], p[2] - s), radius)
    w = (r[0] - p[0], r[1] - p[1], r[2] - p[2])
    return r, n, math.sqrt(_dot(w, w))


def _closest_to_line(r0, u, radius, length):
    """Skin point closest to the line r0 + t u, its normal and its distance to the line, m.

    It lies radially out from the point of S closest to the line; since r0 is perpendicular
    to u, that point is s = r0_z / (1 - u_z^2), clamped to [0, L].
    """
    g2 = 1.0 - u[2] * u[2]
    s = length if g2 < 1e-12 else min(max(r0[2] / g2, 0.0), length)
    v = (r0[0] + s * u[2] * u[0], r0[1] + s * u[2] * u[1], r0[2] + s * (u[2] * u[2] - 1.0))
    r, n = _radially_out(s, v, radius)
    w = (r[0] - r0[0], r[1] - r0[1], r[2] - r0[2])
    t = _dot(w, u)
    return r, n, math.sqrt(max(_dot(w, w) - t * t, 0.0))


def indentation_depth(
    normal_force, skin_stiffness: float, radius: float, contact_shape: str = "edge"
):
    """Indentation depth of a Winkler (elastic-foundation) skin of the given curvature.

    The skin is a bed of independent springs: pressure = ``skin_stiffness`` x local
    penetration. Near the contact the skin is the paraboloid z = (x^2 + y^2) / (2 R).

    * ``"plane"``: a rigid plane pushed delta into it,
      F = k_n integral (delta - rho^2/(2R))_+ dA = k_n pi R delta^2.
    * ``"edge"``: a rigid 90-degree wedge whose ridge line (along y) is tangent to the skin,
      pressed symmetrically; its faces have slope 1, so the penetration is
      (delta - |x| - y^2/(2R))_+ (the x^2/(2R) term is dropped since |x| <= delta << R).
      Integrating over x gives (delta - y^2/(2R))^2, then over y,
      F = k_n (16/15) sqrt(2R) delta^(5/2).

    Args:
        normal_force: normal load on the skin, N; float or array, >= 0.
        skin_stiffness: Winkler modulus k_n, N/m^3; > 0 (e.g. E/h = 8.8e7).
        radius: radius of curvature of the skin, m; > 0.
        contact_shape: one of ``CONTACT_SHAPES``.

    Returns:
        delta, m: a float for a scalar ``normal_force``, else an array of its shape.
    """
    if contact_shape not in CONTACT_SHAPES:
        raise ValueError(f"contact_shape must be one of {CONTACT_SHAPES}, got {contact_shape!r}")
    k = float(skin_stiffness)
    if not math.isfinite(k) or k <= 0.0:
        raise ValueError(f"skin_stiffness must be a finite number > 0 N/m^3, got {k!r}")
    rad = float(radius)
    if not math.isfinite(rad) or rad <= 0.0:
        raise ValueError(f"radius must be a finite number > 0 m, got {rad!r}")
    load = np.asarray(normal_force, dtype=float)
    if not np.all(np.isfinite(load)) or np.any(load < 0.0):
        raise ValueError(f"normal_force must be finite and >= 0 N, got {normal_force!r}")
    if load.ndim == 0:
        return _depth(float(load), k, rad, contact_shape)
    if contact_shape == "plane":
        return np.sqrt(load / (k * math.pi * rad))
    return (load / (k * (16.0 / 15.0) * math.sqrt(2.0 * rad))) ** 0.4


def _depth(load: float, k: float, rad: float, contact_shape: str) -> float:
    """``indentation_depth`` for checked scalar input, on floats (the per-call fast path)."""
    if contact_shape == "plane":
        return math.sqrt(load / (k * math.pi * rad))
    return (load / (k * (16.0 / 15.0) * math.sqrt(2.0 * rad))) ** 0.4


def estimate_contact(
    force,
    moment,
    geometry: FingertipGeometry = _DEFAULT_GEOMETRY,
    *,
    model: str = "soft",
    force_threshold: float = 0.2,
    force_noise_std: float = SensorConfig.force_noise_std,
    moment_noise_std: float = SensorConfig.moment_noise_std,
    skin_stiffness: float | None = None,
    contact_shape: str = "edge",
    previous_edge=None,
    min_tilt_snr: float = 3.0,
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
        force_threshold: below this |f|, N, there is no contact.
        force_noise_std: sensor force noise per axis, N (for edge_std and the miss tolerance);
            defaults to ``SensorConfig``'s.
        moment_noise_std: sensor moment noise per axis, N m; defaults to ``SensorConfig``'s.
        skin_stiffness: Winkler modulus k_n, N/m^3, to model the indentation; None skips it.
        contact_shape: object shape for the indentation model, one of ``CONTACT_SHAPES``.
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
    threshold = _nonneg(force_threshold, "force_threshold", "N")
    sigma_f = _nonneg(force_noise_std, "force_noise_std", "N")
    sigma_m = _nonneg(moment_noise_std, "moment_noise_std", "N m")
    min_snr = _nonneg(min_tilt_snr, "min_tilt_snr", "(standard deviations)")
    if skin_stiffness is not None:
        k_n = float(skin_stiffness)
        if not math.isfinite(k_n) or k_n <= 0.0:
            raise ValueError(
                f"skin_stiffness must be a finite number > 0 N/m^3 or None, got {skin_stiffness!r}"
            )
    prev = None if previous_edge is None else _vec3(previous_edge, "previous_edge")

    fnorm = math.sqrt(_dot(f, f))
    if fnorm < threshold or fnorm == 0.0:
        return ContactEstimate.invalid(f, f"force below threshold ({fnorm:.4g} N < {threshold} N)")
    radius = geometry.outer_radius
    contact = _contact_point(f, m, fnorm, model, radius, geometry.cylinder_length, sigma_f, sigma_m)
    if isinstance(contact, str):
        return ContactEstimate.invalid(f, contact)
    r, n, on_sphere, on_surface = contact
    q, q_n, q_t = _friction_moment(f, m, r, n)
    edge, edge_std, edge_cov, tilt, snr, observable = _edge(
        f, fnorm, r, n, on_sphere, radius, model, sigma_f, sigma_m, min_snr, prev
    )
    corrected, delta = _NAN3, math.nan
    if skin_stiffness is not None:
        corrected, delta = _indentation_correction(f, r, n, k_n, geometry, contact_shape)
    return ContactEstimate(
        valid=True,
        reason="",
        point=np.array(r),
        normal=np.array(n),
        force=np.array(f),
        normal_moment=np.array(q_n),
        tangential_moment=np.array(q_t),
        edge_direction=edge,
        edge_std=edge_std,
        edge_cov=np.array(edge_cov).reshape(3, 3),
        corrected_point=np.array(corrected),
        indentation=delta,
        on_surface=on_surface,
        tilt=tilt,
        edge_observable=observable,
        tilt_snr=snr,
        line_offset=_line_offset(f, fnorm, q, n, radius),
    )


def _contact_point(f, m, fnorm, model, radius, length, sigma_f, sigma_m):
    """Bicchi's contact point on the skin, with the fallbacks for a line that misses it.

    The candidates are the closed-form solutions on each piece of the skin (see
    ``estimate_contact``): the pushing one inside its piece wins. Failing that, the nearest
    of the pushing solutions just outside their piece (moved onto the skin) and, when no
    pulling solution lies on the skin, the skin point closest to the line of action, if it
    is within the noise tolerance 3 (sigma_m + (L + R) sigma_f)/|f|.

    Args:
        f: (3,) force, sensor frame, N.
        m: (3,) moment about the sensor origin, sensor frame, N m.
        fnorm: |f|, N; > 0.
        model: one of ``CONTACT_MODELS``.
        radius: outer skin radius R, m.
        length: cylinder length L (hemisphere centre height), m.
        sigma_f: force noise per axis, N.
        sigma_m: moment noise per axis, N m.

    Returns:
        (r, n, on_sphere, on_surface): the contact point (3,) and outward normal (3,) as
        tuples, whether r is on the hemisphere, and False for a fallback point; or, when no
        contact explains the wrench, the reason as a string.
    """
    u = (f[0] / fnorm, f[1] / fnorm, f[2] / fnorm)
    r0 = _cross(f, m)
    r0 = (r0[0] / (fnorm * fnorm), r0[1] / (fnorm * fnorm), r0[2] / (fnorm * fnorm))
    best, outside, pulls = _skin_solutions(f, m, fnorm, u, r0, model, radius, length)
    if best is not None:
        return best[1], best[2], best[3], True
    # Fallbacks: a pushing solution just off the skin, moved onto it; or, when the line of
    # action touches no skin at all, the skin point closest to it. A pulling solution on
    # the skin beats a pushing one farther off than the noise allows.
    fallbacks = [_project_to_skin(p, radius, length) for p in outside]
    if not pulls:
        fallbacks.append(_closest_to_line(r0, u, radius, length))
    tol = 3.0 * (sigma_m + (length + radius) * sigma_f) / fnorm
    r, n, dist = min(fallbacks, key=lambda c: c[2])
    if dist > tol:
        if pulls:
            return "force pulls out of the skin (f . n > 0)"
        return f"line of action misses surface by {dist:.3g} m (tolerance {tol:.3g} m)"
    return r, n, r[2] >= length, False


def _skin_solutions(f, m, fnorm, u, r0, model, radius, length):
    """Classify each skin piece's solutions for the contact point.

    Args:
        f, m, fnorm: the wrench and |f| (see ``_contact_point``).
        u: (3,) f / |f|.
        r0: (3,) point of the line of action closest to the sensor origin, f x m / |f|^2, m.
        model, radius, length: see ``_contact_point``.

    Returns:
        (best, outside, pulls): best is (|torsion|, r, n, on_sphere) of the pushing solution
        inside its piece (soft model: the one with the smaller torsion |q . n| if both
        pieces give one), or None; outside lists the pushing solutions that lie outside
        their piece (sensor noise near the rim); pulls says whether a pulling solution lies
        inside its piece.
    """
    if model == "soft":
        sphere = _sphere_soft(f, u, fnorm, m, radius, length)
    else:
        sphere = _sphere_hard(r0, u, radius, length)
    best, outside, pulls = _classify(sphere, True, length, None, [], False)
    if model == "soft":
        return _classify(_cylinder_soft(f, m, radius), False, length, best, outside, pulls)
    if best is None:  # the hard model's line enters the sphere first where it can
        return _classify(_cylinder_hard(r0, u, radius), False, length, best, outside, pulls)
    return best, outside, pulls


def _classify(solutions, on_sphere, length, best, outside, pulls):
    """Fold one skin piece's solutions [(r, n, torsion, pushes)] into (best, outside, pulls).

    A solution is inside its piece when z >= L (hemisphere) or 0 <= z <= L (cylinder), with
    ``_REGION_TOL`` of slack. A pushing one inside replaces ``best`` when its |torsion| is
    smaller; see ``_skin_solutions`` for the three results.
    """
    for r, n, torsion, pushes in solutions:
        if on_sphere:
            inside = r[2] >= length - _REGION_TOL
        else:
            inside = -_REGION_TOL <= r[2] <= length + _REGION_TOL
        if not inside:
            if pushes:
                outside.append(r)
        elif not pushes:
            pulls = True
        elif best is None or abs(torsion) < best[0]:
            best = (abs(torsion), r, n, on_sphere)
    return best, outside, pulls


def _friction_moment(f, m, r, n):
    """The friction moment q = m - r x f (eq. 12) split along the normal (eq. 13-14).

    Args:
        f: (3,) force, N; m: (3,) moment about the sensor origin, N m.
        r: (3,) contact point, m; n: (3,) outward unit normal there. All sensor frame.

    Returns:
        (q, q_n, q_t): q, its normal part (q . n) n and its tangential part q - q_n, N m.
    """
    rxf = _cross(r, f)
    q = (m[0] - rxf[0], m[1] - rxf[1], m[2] - rxf[2])
    qn = _dot(q, n)
    q_n = (qn * n[0], qn * n[1], qn * n[2])
    return q, q_n, (q[0] - q_n[0], q[1] - q_n[1], q[2] - q_n[2])


def _edge(f, fnorm, r, n, on_sphere, radius, model, sigma_f, sigma_m, min_snr, prev):
    """Edge direction e = normalise(n x f), its predicted error, and whether it is observable.

    The edge is observable when the force's tilt from -n stands out of the sensor noise,
    ``tilt_snr`` = sqrt(f_t^T S^-1 f_t) > ``min_snr`` (S the predicted covariance of the
    tangential force f_t, see ``_edge_noise``), and the first-order edge error stays below
    ``EDGE_STD_UNOBSERVABLE``. An untilted press has f_t = 0, so its e would be noise: then
    f_t ~ N(0, S), tilt_snr^2 is chi-square with 2 degrees of freedom, and the press passes
    with probability exp(-min_snr^2 / 2) (1.1 % at 3). A press whose noise-free tilt_snr is
    s0 is flagged with probability P(chi2(2, s0^2) < min_snr^2) <= Phi(min_snr - s0).

    Args:
        f: (3,) force, N; fnorm: |f|, N.
        r: (3,) contact point, m; n: (3,) outward unit normal there. All sensor frame.
        on_sphere: whether r is on the hemisphere (else on the cylinder side).
        radius: outer skin radius R, m.
        model: one of ``CONTACT_MODELS``.
        sigma_f, sigma_m: sensor noise per axis, N and N m.
        min_snr: the least tilt_snr at which e counts as observable.
        prev: (3,) previous edge direction to orient e like, or None.

    Returns:
        (e, edge_std, edge_cov, tilt, tilt_snr, observable): e, an array (3,) oriented by
        ``orient_like``; its RMS angle error, rad; the (3, 3) covariance of de, rad^2,
        row-major as 9 floats; the angle between f and -n, rad; tilt_snr (0 for an untilted
        force, NaN for a force tangent to the skin, where the noise model breaks down, inf
        without sensor noise); observable. When not observable, e and edge_cov are NaN and
        edge_std is ``EDGE_STD_UNOBSERVABLE``.
    """
    fn = _dot(f, n)
    ftv = (f[0] - fn * n[0], f[1] - fn * n[1], f[2] - fn * n[2])
    ft = math.sqrt(_dot(ftv, ftv))
    tilt = math.atan2(ft, -fn)
    if ft <= 1e-12 * fnorm or abs(fn) <= 1e-12 * fnorm:
        snr = 0.0 if ft <= 1e-12 * fnorm else math.nan
        return _nan3(), EDGE_STD_UNOBSERVABLE, _NAN33, tilt, snr, False
    ev = _cross(n, ftv)
    e = (ev[0] / ft, ev[1] / ft, ev[2] / ft)
    g = (-ftv[0] / ft, -ftv[1] / ft, -ftv[2] / ft)  # n x e
    s_ee, s_eg, s_gg, var_out, cov_io = _edge_noise(
        fn, ft, r, n, e, g, on_sphere, radius, model, sigma_f, sigma_m
    )
    det = s_ee * s_gg - s_eg * s_eg
    # f_t = -|f_t| g, so f_t^T S^-1 f_t = |f_t|^2 s_ee / det.
    snr = ft * math.sqrt(s_ee / det) if det > 0.0 else math.inf
    var_in = s_ee / (ft * ft)
    cov_io /= ft
    std = math.sqrt(var_in + var_out)
    if not (snr > min_snr and std < EDGE_STD_UNOBSERVABLE):
        return _nan3(), EDGE_STD_UNOBSERVABLE, _NAN33, tilt, snr, False
    # cov = var_in g g^T + var_out n n^T + cov_io (g n^T + n g^T); row i is x_i g + y_i n.
    g0, g1, g2 = g
    n0, n1, n2 = n
    x0, x1, x2 = var_in * g0 + cov_io * n0, var_in * g1 + cov_io * n1, var_in * g2 + cov_io * n2
    y0, y1, y2 = var_out * n0 + cov_io * g0, var_out * n1 + cov_io * g1, var_out * n2 + cov_io * g2
    c01 = x0 * g1 + y0 * n1
    c02 = x0 * g2 + y0 * n2
    c12 = x1 * g2 + y1 * n2
    cov = (x0 * g0 + y0 * n0, c01, c02, c01, x1 * g1 + y1 * n1, c12, c02, c12, x2 * g2 + y2 * n2)
    return orient_like(e, [] if prev is None else [prev]), std, cov, tilt, snr, True


def _edge_noise(fn, ft, r, n, e, g, on_sphere, radius, model, sigma_f, sigma_m):
    """First-order noise of the tangential force f_t and of e = normalise(n x f).

    The sensor noise (df, dm) is isotropic Gaussian, sigma_f and sigma_m per axis. Vectors are
    taken in the right-handed basis (e, g = n x e, n), where f = (0, -|f_t|, f_n).

    Perturbing the wrench moves r by dr = D h, h = dm - r x df, with (i) soft:
    dr = (n x h)/f_n; (ii) hard: dr = (I - u n^T/(u.n)) (f x h)/|f|^2, u = f/|f| (the line
    of action moves by (f x h)/|f|^2 and r slides along it to stay on the tangent plane).
    Both drop terms of order torsion/(R |f|) or pitch/R. The normal turns by dn = K dr, K the
    shape operator (I/R on the sphere, t t^T/R on the cylinder, t = e_z x n), so for a
    tangent x, x.dn = h.P_x where, with k = K x, (i) P_x = (k x n)/f_n and
    (ii) P_x = (k - n (f.k)/f_n) x f / |f|^2; in the basis both read
    P_x = (k.g/f_n, -(k.e) c_1, -(k.e) c_2) with c = (1/f_n, 0) (soft) or
    (f_n, |f_t|)/|f|^2 (hard). With h.P = dm.P - df.(P x r):

    * f_t changes in the tangent plane by dw = df_t - f_n dn, so
      dw.x = df.(x + f_n P_x x r) - f_n dm.P_x, which gives S, its 2x2 covariance in (e, g).
    * e turns in the tangent plane (about n, along g) by de.g = dw.e/|f_t| and out of it
      (along n) by de.n = -dn.e. The two share dn.e, so they are correlated: moment noise
      moves only n and keeps e perpendicular to f, so it turns e along e x f.

    For a press on the hemisphere's top the RMS angle error is
    ~ (sigma_f + sigma_m/R)/(|f| sin tilt), the estimate of docs/design.md 5, with the lever |r|
    of the sensor origin folded in.

    Args:
        fn: f . n, N (non-zero); ft: |f_t|, N.
        r: (3,) contact point, m; n, e, g: (3,) the unit basis. All sensor frame.
        on_sphere, radius, model, sigma_f, sigma_m: see ``_edge``.

    Returns:
        (s_ee, s_eg, s_gg, var_out, cov_io_ft): S's entries, N^2; var(de.n), rad^2; and
        |f_t| cov(de.g, de.n), N rad (var(de.g) is s_ee/|f_t|^2).
    """
    r0, r1, r2 = _dot(r, e), _dot(r, g), _dot(r, n)
    if on_sphere:
        kee, keg, kgg = 1.0 / radius, 0.0, 1.0 / radius
    else:
        te = n[0] * e[1] - n[1] * e[0]  # t . e
        tg = n[0] * g[1] - n[1] * g[0]
        kee, keg, kgg = te * te / radius, te * tg / radius, tg * tg / radius
    if model == "soft":
        c1, c2 = 1.0 / fn, 0.0
    else:
        f2 = fn * fn + ft * ft
        c1, c2 = fn / f2, ft / f2
    # Scalar code: this runs on every env step. P_e = (pe0, pe1, pe2), its P_e x r =
    # (qe0, qe1, qe2); a_x = x + f_n P_x x r; likewise for g.
    pe0, pe1, pe2 = keg / fn, -kee * c1, -kee * c2
    pg0, pg1, pg2 = kgg / fn, -keg * c1, -keg * c2
    qe0, qe1, qe2 = pe1 * r2 - pe2 * r1, pe2 * r0 - pe0 * r2, pe0 * r1 - pe1 * r0
    qg0, qg1, qg2 = pg1 * r2 - pg2 * r1, pg2 * r0 - pg0 * r2, pg0 * r1 - pg1 * r0
    ae0, ae1, ae2 = 1.0 + fn * qe0, fn * qe1, fn * qe2
    ag0, ag1, ag2 = fn * qg0, 1.0 + fn * qg1, fn * qg2
    vf = sigma_f * sigma_f
    vm = sigma_m * sigma_m
    vm_fn2 = vm * fn * fn
    pe_sq = pe0 * pe0 + pe1 * pe1 + pe2 * pe2
    s_ee = vf * (ae0 * ae0 + ae1 * ae1 + ae2 * ae2) + vm_fn2 * pe_sq
    s_eg = vf * (ae0 * ag0 + ae1 * ag1 + ae2 * ag2) + vm_fn2 * (pe0 * pg0 + pe1 * pg1 + pe2 * pg2)
    s_gg = vf * (ag0 * ag0 + ag1 * ag1 + ag2 * ag2) + vm_fn2 * (pg0 * pg0 + pg1 * pg1 + pg2 * pg2)
    var_out = vf * (qe0 * qe0 + qe1 * qe1 + qe2 * qe2) + vm * pe_sq
    cov_io_ft = vf * (ae0 * qe0 + ae1 * qe1 + ae2 * qe2) + vm * fn * pe_sq
    return s_ee, s_eg, s_gg, var_out, cov_io_ft


def _line_offset(f, fnorm, q, n, radius):
    """Distance of the wrench's central axis from c = r - R n, m (see ``ContactEstimate``).

    The moment about c is m_c = q + R n x f (q = m - r x f), and the axis passes c at
    |f x m_c|/|f|^2, with f x (n x f) = |f|^2 n - (f . n) f.
    """
    fq = _cross(f, q)
    f2 = fnorm * fnorm
    fn = _dot(f, n)
    d = (
        fq[0] + radius * (f2 * n[0] - fn * f[0]),
        fq[1] + radius * (f2 * n[1] - fn * f[1]),
        fq[2] + radius * (f2 * n[2] - fn * f[2]),
    )
    return math.sqrt(_dot(d, d)) / f2


def _indentation_correction(f, r, n, k_n, geometry, contact_shape):
    """Indentation depth and the contact point moved in by it (docs/design.md 4.5).

    Args:
        f: (3,) force, N; r: (3,) contact point, m; n: (3,) outward unit normal. Sensor frame.
        k_n: Winkler modulus, N/m^3; > 0.
        geometry: the fingertip (outer radius and skin thickness).
        contact_shape: one of ``CONTACT_SHAPES``.

    Returns:
        (r - delta n, delta): the corrected point (3,), m, and delta, m, the depth of
        ``indentation_depth`` for the normal load -f . n capped at the skin thickness (the
        shell is rigid).
    """
    load = max(-_dot(f, n), 0.0)
    delta = min(
        _depth(load, k_n, geometry.outer_radius, contact_shape),
        geometry.skin_thickness,
    )
    return (r[0] - delta * n[0], r[1] - delta * n[1], r[2] - delta * n[2]), delta


def edge_from_trace(points, point_std: float = 0.0005) -> tuple[np.ndarray, float]:
    """Edge direction from contact points collected while sliding along the edge.

    Fits a line through the points by their principal direction (SVD of the centred points).
    With the points spread over positions s_i along the line and independent noise of std
    sigma in each of the two perpendicular directions, the slope in each direction has
    variance sigma^2 / sum (s_i - s_mean)^2, so the RMS angle error is
    sqrt(2) sigma / sqrt(sum (s_i - s_mean)^2). sigma is the larger of ``point_std`` and the
    residual estimate sqrt(sum |perpendicular residual|^2 / (2 (N - 2))) (N > 2), so a curved
    or jumpy trace reports a larger error.

    Args:
        points: (N, 3) successive contact points, any one frame (e.g. world or sensor), m.
        point_std: 1-sigma noise of each point per axis, m; >= 0.

    Returns:
        (direction, std): the unit direction (3,), oriented from the first point towards the
        last, and its 1-sigma angle error, rad. With fewer than 2 points or a trace whose
        length along the line is at most ``point_std``, the direction is NaN and std is pi/2.

    Raises:
        ValueError: points not (N, 3) or not finite; point_std negative or not finite.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    sigma = _nonneg(point_std, "point_std", "m")
    unobservable = (np.full(3, np.nan), EDGE_STD_UNOBSERVABLE)
    n_pts = len(p)
    if n_pts < 2:
        return unobservable
    centred = p - p.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    direction = vt[0]
    s = centred @ direction
    if float(s.max() - s.min()) <= max(sigma, 1e-12):
        return unobservable
    spread = float(np.sqrt(np.sum(s**2)))
    if float(np.dot(p[-1] - p[0], direction)) < 0.0:
        direction = -direction
    if n_pts > 2:
        resid2 = float(np.sum(centred**2) - spread**2)
        sigma = max(sigma, math.sqrt(max(resid2, 0.0) / (2.0 * (n_pts - 2))))
    std = min(math.sqrt(2.0) * sigma / spread, EDGE_STD_UNOBSERVABLE)
    return direction, std
