"""Bicchi's intrinsic contact sensing: where on the skin a wrench was applied.

Closed-form contact points on the fingertip's two skin pieces (the hemisphere z >= L and the
cylinder side 0 <= z <= L, both of radius R) for a soft finger (a torsion about the normal is
allowed) or a hard one (the contact lies on the wrench's line of action), with the fallbacks
for a line of action that noise moves just off the skin; the friction moment split of
Matsuo et al. (2010), eq. 12-14; and how far the line of action passes from the centre of
curvature. ``estimate_contact`` (``tactile_gym.sensing.contact``) strings them together.

Conventions (``docs/design.md`` 2): SI units; every point, direction, force and moment in the
sensor frame (origin at the F/T sensor, z along the finger axis, hemisphere centre at
(0, 0, L)); f is the force on the fingertip, m its moment about the sensor origin. Vectors are
tuples of floats (``tactile_gym.vec3``). NumPy only.
"""

from __future__ import annotations

import math

from tactile_gym.vec3 import cross, dot

__all__ = ["CONTACT_MODELS", "contact_point", "friction_moment", "line_offset"]

CONTACT_MODELS = ("soft", "hard")
_REGION_TOL = 1e-9  # m; slack on the piece boundaries (seam at z = L, rim at z = 0)


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
    k = dot(mp, u)
    mperp = (mp[0] - k * u[0], mp[1] - k * u[1], mp[2] - k * u[2])
    p2 = dot(mperp, mperp)
    big_f = radius * fnorm
    f2 = big_f * big_f
    b = k * k + p2 - f2
    disc = math.sqrt(b * b + 4.0 * f2 * k * k)
    # Pick the cancellation-free form of the non-negative root.
    s = 2.0 * k * k / (b + disc) if b > 0.0 else (disc - b) / (2.0 * f2)
    s = min(max(s, 0.0), 1.0)
    if s < 1e-24:  # force tangent to the sphere: neither pushes nor pulls
        return []
    ux_m = cross(u, mperp)
    out = []
    for a in (-math.sqrt(s), math.sqrt(s)):
        sigma = k / a
        den = sigma * sigma + f2
        n = (
            a * u[0] + (sigma * mperp[0] + big_f * ux_m[0]) / den,
            a * u[1] + (sigma * mperp[1] + big_f * ux_m[1]) / den,
            a * u[2] + (sigma * mperp[2] + big_f * ux_m[2]) / den,
        )
        nn = math.sqrt(dot(n, n))
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
    beta = dot(d, u)
    disc = beta * beta - (dot(d, d) - radius * radius)
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
    nv = math.sqrt(dot(v, v))
    n = (1.0, 0.0, 0.0) if nv < 1e-15 else (v[0] / nv, v[1] / nv, v[2] / nv)
    return (radius * n[0], radius * n[1], s + radius * n[2]), n


def _project_to_skin(p, radius, length):
    """Skin point closest to the point p, its normal and the distance, m."""
    s = min(max(p[2], 0.0), length)
    r, n = _radially_out(s, (p[0], p[1], p[2] - s), radius)
    w = (r[0] - p[0], r[1] - p[1], r[2] - p[2])
    return r, n, math.sqrt(dot(w, w))


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
    t = dot(w, u)
    return r, n, math.sqrt(max(dot(w, w) - t * t, 0.0))


def contact_point(f, m, fnorm, model, radius, length, sigma_f, sigma_m):
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
    r0 = cross(f, m)
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
        f, m, fnorm: the wrench and |f| (see ``contact_point``).
        u: (3,) f / |f|.
        r0: (3,) point of the line of action closest to the sensor origin, f x m / |f|^2, m.
        model, radius, length: see ``contact_point``.

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


def friction_moment(f, m, r, n):
    """The friction moment q = m - r x f (eq. 12) split along the normal (eq. 13-14).

    Args:
        f: (3,) force, N; m: (3,) moment about the sensor origin, N m.
        r: (3,) contact point, m; n: (3,) outward unit normal there. All sensor frame.

    Returns:
        (q, q_n, q_t): q, its normal part (q . n) n and its tangential part q - q_n, N m.
    """
    rxf = cross(r, f)
    q = (m[0] - rxf[0], m[1] - rxf[1], m[2] - rxf[2])
    qn = dot(q, n)
    q_n = (qn * n[0], qn * n[1], qn * n[2])
    return q, q_n, (q[0] - q_n[0], q[1] - q_n[1], q[2] - q_n[2])


def line_offset(f, fnorm, q, n, radius):
    """Distance of the wrench's central axis from c = r - R n, m (see ``ContactEstimate``).

    The moment about c is m_c = q + R n x f (q = m - r x f), and the axis passes c at
    |f x m_c|/|f|^2, with f x (n x f) = |f|^2 n - (f . n) f.
    """
    fq = cross(f, q)
    f2 = fnorm * fnorm
    fn = dot(f, n)
    d = (
        fq[0] + radius * (f2 * n[0] - fn * f[0]),
        fq[1] + radius * (f2 * n[1] - fn * f[1]),
        fq[2] + radius * (f2 * n[2] - fn * f[2]),
    )
    return math.sqrt(dot(d, d)) / f2
