"""The edge direction: from one wrench (with its predicted error) or from a slide's trace.

A force tilted from the skin normal across an edge reveals the edge, e = normalise(n x f)
(``docs/design.md`` 4.1); its first-order covariance under the sensor's noise and whether the
tilt stands out of that noise at all (observability, ``docs/design.md`` 5) come with it. A
line through the contact points of a slide gives another estimate (``docs/design.md`` 4.3).

Conventions (``docs/design.md`` 2): SI units, radians; vectors in the sensor frame, as tuples of
floats on the per-reading path (``tactile_gym.vec3``). The per-reading functions are written
in numba's subset and compiled (``tactile_gym._jit``), rounding as Python floats do
(``tactile_gym.sensing.contact_point``). NumPy and numba only.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.validation import check_number
from tactile_gym.vec3 import cross_kernel as cross
from tactile_gym.vec3 import dot_kernel as dot

__all__ = ["EDGE_STD_UNOBSERVABLE", "edge_from_force", "edge_from_trace"]

EDGE_STD_UNOBSERVABLE = math.pi / 2  # rad; "no information" about an undirected line
_NAN3 = (math.nan, math.nan, math.nan)
_NAN33 = _NAN3 * 3
_NAN_VECTOR = np.full(3, np.nan)


def nan3() -> np.ndarray:
    """A fresh (3,) array of NaN: an undefined vector."""
    return _NAN_VECTOR.copy()  # a copy costs a fifth of np.full, on every reading in free air


@kernel()
def edge_from_force(f, fnorm, r, n, on_sphere, radius, soft, sigma_f, sigma_m, min_snr):
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
        soft: the soft contact model (else the hard one, ``CONTACT_MODELS``).
        sigma_f, sigma_m: sensor noise per axis, N and N m.
        min_snr: the least tilt_snr at which e counts as observable.

    Returns:
        (observable, e, edge_std, edge_cov, tilt, tilt_snr): whether e is; e as n x f_t /
        |f_t|, which points along the edge with the force's tilt on a fixed side (a caller
        signs it, ``orient_like`` or the physical sign of ``TouchSensor``); its RMS angle
        error, rad; the (3, 3) covariance of de, rad^2, row-major as 9 floats; the angle
        between f and -n, rad; tilt_snr (0 for an untilted force, NaN for a force tangent to
        the skin, where the noise model breaks down, inf without sensor noise). When not
        observable, e and edge_cov are NaN and edge_std is ``EDGE_STD_UNOBSERVABLE``.
    """
    fn = dot(f, n)
    ftv = (f[0] - fn * n[0], f[1] - fn * n[1], f[2] - fn * n[2])
    ft = math.sqrt(dot(ftv, ftv))
    tilt = math.atan2(ft, -fn)
    if ft <= 1e-12 * fnorm or abs(fn) <= 1e-12 * fnorm:
        snr = 0.0 if ft <= 1e-12 * fnorm else math.nan
        return False, _NAN3, EDGE_STD_UNOBSERVABLE, _NAN33, tilt, snr
    ev = cross(n, ftv)
    e = (ev[0] / ft, ev[1] / ft, ev[2] / ft)
    g = (-ftv[0] / ft, -ftv[1] / ft, -ftv[2] / ft)  # n x e
    s_ee, s_eg, s_gg, var_out, cov_io = _edge_noise(
        fn, ft, r, n, e, g, on_sphere, radius, soft, sigma_f, sigma_m
    )
    det = s_ee * s_gg - s_eg * s_eg
    # f_t = -|f_t| g, so f_t^T S^-1 f_t = |f_t|^2 s_ee / det.
    snr = ft * math.sqrt(s_ee / det) if det > 0.0 else math.inf
    var_in = s_ee / (ft * ft)
    cov_io /= ft
    std = math.sqrt(var_in + var_out)
    if not (snr > min_snr and std < EDGE_STD_UNOBSERVABLE):
        return False, _NAN3, EDGE_STD_UNOBSERVABLE, _NAN33, tilt, snr
    # cov = var_in g g^T + var_out n n^T + cov_io (g n^T + n g^T); row i is x_i g + y_i n.
    g0, g1, g2 = g
    n0, n1, n2 = n
    x0, x1, x2 = var_in * g0 + cov_io * n0, var_in * g1 + cov_io * n1, var_in * g2 + cov_io * n2
    y0, y1, y2 = var_out * n0 + cov_io * g0, var_out * n1 + cov_io * g1, var_out * n2 + cov_io * g2
    c01 = x0 * g1 + y0 * n1
    c02 = x0 * g2 + y0 * n2
    c12 = x1 * g2 + y1 * n2
    cov = (x0 * g0 + y0 * n0, c01, c02, c01, x1 * g1 + y1 * n1, c12, c02, c12, x2 * g2 + y2 * n2)
    return True, e, std, cov, tilt, snr


@kernel()
def _edge_noise(fn, ft, r, n, e, g, on_sphere, radius, soft, sigma_f, sigma_m):
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
        on_sphere, radius, soft, sigma_f, sigma_m: see ``edge_from_force``.

    Returns:
        (s_ee, s_eg, s_gg, var_out, cov_io_ft): S's entries, N^2; var(de.n), rad^2; and
        |f_t| cov(de.g, de.n), N rad (var(de.g) is s_ee/|f_t|^2).
    """
    r0, r1, r2 = dot(r, e), dot(r, g), dot(r, n)
    if on_sphere:
        kee, keg, kgg = 1.0 / radius, 0.0, 1.0 / radius
    else:
        te = n[0] * e[1] - n[1] * e[0]  # t . e
        tg = n[0] * g[1] - n[1] * g[0]
        kee, keg, kgg = te * te / radius, te * tg / radius, tg * tg / radius
    if soft:
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
    sigma = check_number("point_std", point_std, 0.0)
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
