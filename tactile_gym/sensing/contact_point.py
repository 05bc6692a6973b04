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
tuples of floats (``tactile_gym.vec3``).

Every function here is written in numba's subset and compiled (``tactile_gym._jit``): the
contact estimate of ``tactile_gym.sensing.contact`` runs them in one compiled call per
reading (``docs/design.md`` 7.1). Compiled, they round as the Python floats did, operation
by operation, to the bit (numba without fastmath, libm's sqrt and atan2; ``math.hypot`` is
CPython's own algorithm, which ``_hypot`` follows, as libm's hypot differs in the last bit).
No pybullet or gymnasium.
"""

from __future__ import annotations

import math

from tactile_gym._jit import kernel
from tactile_gym.vec3 import cross_kernel as cross
from tactile_gym.vec3 import dot_kernel as dot

__all__ = ["CONTACT_MODELS", "contact_point", "friction_moment", "line_offset"]

CONTACT_MODELS = ("soft", "hard")
_REGION_TOL = 1e-9  # m; slack on the piece boundaries (seam at z = L, rim at z = 0)
_T27 = 134217729.0  # 2^27 + 1, Veltkamp's constant: splits a double into two halves
_DBL_MIN = 2.2250738585072014e-308  # the smallest normal double

#: What ``contact_point`` found (its ``status``): a contact on the skin, a pull on the skin,
#: or a line of action that misses it by more than the noise allows.
FOUND, PULLS, MISSES = 0, 1, 2


@kernel()
def _hypot(x, y):
    """``math.hypot(x, y)`` to the bit: CPython 3.11's ``vector_norm`` of two coordinates
    (scaled to below 1, squared exactly in two halves, summed with their rounding errors,
    one differential correction). numba's ``math.hypot`` is libm's, which differs in the
    last bit for about one pair in 700. Other CPython versions compute ``math.hypot``
    otherwise; this stays 3.11's on every version, so the sensing does not move with them."""
    ax, ay = abs(x), abs(y)
    big = ay if ay > ax else ax
    if math.isinf(big):
        return big
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    if big == 0.0:
        return big
    exponent = math.frexp(big)[1]
    if exponent < -1023:  # subnormal: ldexp(1, -exponent) would overflow
        return _DBL_MIN * _hypot(ax / _DBL_MIN, ay / _DBL_MIN)
    scale = math.ldexp(1.0, -exponent)
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    for v in (ax, ay):
        v *= scale
        t = v * _T27
        hi = t - (t - v)
        lo = v - hi
        v = hi * hi
        old = csum
        csum += v
        frac1 += (old - csum) + v
        v = 2.0 * hi * lo
        old = csum
        csum += v
        frac2 += (old - csum) + v
        frac3 += lo * lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = h * _T27
    hi = t - (t - h)
    lo = h - hi
    v = -hi * hi
    old = csum
    csum += v
    frac1 += (old - csum) + v
    v = -2.0 * hi * lo
    old = csum
    csum += v
    frac2 += (old - csum) + v
    v = -lo * lo
    old = csum
    csum += v
    frac3 += (old - csum) + v
    v = csum - 1.0 + (frac1 + frac2 + frac3)
    return (h + v / (2.0 * h)) / scale


@kernel()
def _clip(x, low, high):
    """``min(max(x, low), high)`` as Python evaluates it (NaN passes through)."""
    x = low if low > x else x
    return high if high < x else x


@kernel()
def _sphere_soft(f, u, fnorm, m, radius, length):
    """Soft-finger solutions on the full sphere, (found, pushing, pulling), each solution
    (r, n, sigma); found is False when the force is tangent to the sphere.

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
    s = _clip(s, 0.0, 1.0)
    if s < 1e-24:  # force tangent to the sphere: neither pushes nor pulls
        none = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0
        return False, none, none
    ux_m = cross(u, mperp)
    a = math.sqrt(s)
    push = _sphere_soft_solution(-a, k, u, mperp, ux_m, big_f, f2, radius, length)
    return True, push, _sphere_soft_solution(a, k, u, mperp, ux_m, big_f, f2, radius, length)


@kernel()
def _sphere_soft_solution(a, k, u, mperp, ux_m, big_f, f2, radius, length):
    """One root a of ``_sphere_soft``: (r, n, sigma)."""
    sigma = k / a
    den = sigma * sigma + f2
    n = (
        a * u[0] + (sigma * mperp[0] + big_f * ux_m[0]) / den,
        a * u[1] + (sigma * mperp[1] + big_f * ux_m[1]) / den,
        a * u[2] + (sigma * mperp[2] + big_f * ux_m[2]) / den,
    )
    nn = math.sqrt(dot(n, n))
    n = (n[0] / nn, n[1] / nn, n[2] / nn)
    return (radius * n[0], radius * n[1], length + radius * n[2]), n, sigma


@kernel()
def _cylinder_soft(f, m, radius):
    """Soft-finger solutions on the infinite cylinder, (found, pushing, pulling), each
    solution (r, n, sigma).

    With n = (cos t, sin t, 0) and r = R n + z e_z, the z row of m - r x f = sigma n gives
    R h sin(phi - t) = m_z (h = |f_xy|, phi its azimuth); cos(phi - t) < 0 pushes. The row
    along e_z x n gives z = (m . (e_z x n) + R f_z) / (f . n), and sigma = m . n + z m_z / R.
    """
    none = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0
    h = _hypot(f[0], f[1])
    if h < 1e-12:
        return False, none, none
    sin_psi = m[2] / (radius * h)
    if abs(sin_psi) > 1.0:
        return False, none, none
    cos_abs = math.sqrt(1.0 - sin_psi * sin_psi)
    if cos_abs < 1e-12:
        return False, none, none
    cphi, sphi = f[0] / h, f[1] / h
    push = _cylinder_soft_solution(-cos_abs, sin_psi, cphi, sphi, f, m, radius)
    return True, push, _cylinder_soft_solution(cos_abs, sin_psi, cphi, sphi, f, m, radius)


@kernel()
def _cylinder_soft_solution(cos_psi, sin_psi, cphi, sphi, f, m, radius):
    """One root cos(phi - t) of ``_cylinder_soft``: (r, n, sigma)."""
    nx = cphi * cos_psi + sphi * sin_psi
    ny = sphi * cos_psi - cphi * sin_psi
    fn = f[0] * nx + f[1] * ny
    z = (-m[0] * ny + m[1] * nx + radius * f[2]) / fn
    sigma = m[0] * nx + m[1] * ny + z * m[2] / radius
    return (radius * nx, radius * ny, z), (nx, ny, 0.0), sigma


@kernel()
def _sphere_hard(r0, u, radius, length):
    """Line r0 + t u against the full sphere, (found, entry, exit), each (r, n, 0.0); the
    entry pushes."""
    d = (r0[0], r0[1], r0[2] - length)
    beta = dot(d, u)
    disc = beta * beta - (dot(d, d) - radius * radius)
    if disc < 0.0:
        none = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0
        return False, none, none
    sq = math.sqrt(disc)
    entry = _sphere_hard_point(r0, u, -beta - sq, radius, length)
    return True, entry, _sphere_hard_point(r0, u, -beta + sq, radius, length)


@kernel()
def _sphere_hard_point(r0, u, t, radius, length):
    r = (r0[0] + t * u[0], r0[1] + t * u[1], r0[2] + t * u[2])
    return r, (r[0] / radius, r[1] / radius, (r[2] - length) / radius), 0.0


@kernel()
def _cylinder_hard(r0, u, radius):
    """Line r0 + t u against the infinite cylinder, (found, entry, exit), each (r, n, 0.0);
    the entry pushes."""
    none = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0
    a = u[0] * u[0] + u[1] * u[1]
    if a < 1e-24:
        return False, none, none
    b = r0[0] * u[0] + r0[1] * u[1]
    disc = b * b - a * (r0[0] * r0[0] + r0[1] * r0[1] - radius * radius)
    if disc < 0.0:
        return False, none, none
    sq = math.sqrt(disc)
    entry = _cylinder_hard_point(r0, u, -(b + sq) / a)
    return True, entry, _cylinder_hard_point(r0, u, (sq - b) / a)


@kernel()
def _cylinder_hard_point(r0, u, t):
    r = (r0[0] + t * u[0], r0[1] + t * u[1], r0[2] + t * u[2])
    rho = _hypot(r[0], r[1])
    return r, (r[0] / rho, r[1] / rho, 0.0), 0.0


@kernel()
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


@kernel()
def _project_to_skin(p, radius, length):
    """Skin point closest to the point p, its normal and the distance, m."""
    s = _clip(p[2], 0.0, length)
    r, n = _radially_out(s, (p[0], p[1], p[2] - s), radius)
    w = (r[0] - p[0], r[1] - p[1], r[2] - p[2])
    return r, n, math.sqrt(dot(w, w))


@kernel()
def _closest_to_line(r0, u, radius, length):
    """Skin point closest to the line r0 + t u, its normal and its distance to the line, m.

    It lies radially out from the point of S closest to the line; since r0 is perpendicular
    to u, that point is s = r0_z / (1 - u_z^2), clamped to [0, L].
    """
    g2 = 1.0 - u[2] * u[2]
    s = length if g2 < 1e-12 else _clip(r0[2] / g2, 0.0, length)
    v = (r0[0] + s * u[2] * u[0], r0[1] + s * u[2] * u[1], r0[2] + s * (u[2] * u[2] - 1.0))
    r, n = _radially_out(s, v, radius)
    w = (r[0] - r0[0], r[1] - r0[1], r[2] - r0[2])
    t = dot(w, u)
    d2 = dot(w, w) - t * t
    return r, n, math.sqrt(0.0 if 0.0 > d2 else d2)


@kernel()
def contact_point(f, m, fnorm, soft, radius, length, sigma_f, sigma_m):
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
        soft: the soft model (else the hard one, ``CONTACT_MODELS``).
        radius: outer skin radius R, m.
        length: cylinder length L (hemisphere centre height), m.
        sigma_f: force noise per axis, N.
        sigma_m: moment noise per axis, N m.

    Returns:
        (status, r, n, on_sphere, on_surface, miss, tolerance): ``FOUND`` with the contact
        point (3,) and outward normal (3,), whether r is on the hemisphere, and False for a
        fallback point; or, when no contact explains the wrench, ``PULLS`` (a pulling
        solution lies on the skin) or ``MISSES``, with how far the nearest fallback lies
        from the line of action and the noise tolerance, m.
    """
    u = (f[0] / fnorm, f[1] / fnorm, f[2] / fnorm)
    r0 = cross(f, m)
    r0 = (r0[0] / (fnorm * fnorm), r0[1] / (fnorm * fnorm), r0[2] / (fnorm * fnorm))
    # The pieces' solutions, folded in order: the hemisphere's, then the cylinder's (the
    # hard model's line enters the sphere first where it can).
    if soft:
        found, push, pull = _sphere_soft(f, u, fnorm, m, radius, length)
    else:
        found, push, pull = _sphere_hard(r0, u, radius, length)
    state = _classify(found, push, pull, True, length, _NO_CONTACT)
    if soft:
        found, push, pull = _cylinder_soft(f, m, radius)
        state = _classify(found, push, pull, False, length, state)
    elif not state[0]:
        found, push, pull = _cylinder_hard(r0, u, radius)
        state = _classify(found, push, pull, False, length, state)
    has_best, _, r, n, on_sphere, outside, pulls = state
    tol = 3.0 * (sigma_m + (length + radius) * sigma_f) / fnorm
    if has_best:
        return FOUND, r, n, on_sphere, True, 0.0, tol
    # Fallbacks, nearest first (the first of equals): a pushing solution just off the skin,
    # moved onto it; or, when the line of action touches no skin at all, the skin point
    # closest to it. A pulling solution on the skin beats a pushing one farther off than
    # the noise allows.
    count, first, second = outside
    dist = math.inf
    if count > 0:
        r, n, dist = _project_to_skin(first, radius, length)
    if count > 1:
        rc, nc, dc = _project_to_skin(second, radius, length)
        if dc < dist:
            r, n, dist = rc, nc, dc
    if not pulls:
        rc, nc, dc = _closest_to_line(r0, u, radius, length)
        if count == 0 or dc < dist:
            r, n, dist = rc, nc, dc
    if dist > tol:
        return (PULLS if pulls else MISSES), r, n, False, False, dist, tol
    return FOUND, r, n, r[2] >= length, False, dist, tol


#: The fold of ``_classify`` before any solution: (has_best, |torsion|, r, n, on_sphere,
#: (count, point, point) of the pushing solutions outside their piece, pulls).
_NO_CONTACT = (
    False, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), False,
    (0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), False,
)  # fmt: skip


@kernel()
def _classify(found, push, pull, on_sphere, length, state):
    """Fold one skin piece's pushing and pulling solutions (r, n, torsion) into the state
    (``_NO_CONTACT``): a solution is inside its piece when z >= L (hemisphere) or
    0 <= z <= L (cylinder), with ``_REGION_TOL`` of slack. The pushing one inside replaces
    the best when its |torsion| is smaller (the soft model's choice between the pieces); one
    outside is kept for the fallbacks; a pulling one inside sets ``pulls``."""
    has_best, best_torsion, best_r, best_n, best_sphere, outside, pulls = state
    if not found:
        return state
    r, n, torsion = push
    if not _inside(r[2], on_sphere, length):
        count, first, second = outside
        if count == 0:
            outside = (1, r, second)
        else:
            outside = (2, first, r)
    elif not has_best or abs(torsion) < best_torsion:
        has_best, best_torsion, best_r, best_n, best_sphere = True, abs(torsion), r, n, on_sphere
    if _inside(pull[0][2], on_sphere, length):
        pulls = True
    return has_best, best_torsion, best_r, best_n, best_sphere, outside, pulls


@kernel()
def _inside(z, on_sphere, length):
    if on_sphere:
        return z >= length - _REGION_TOL
    return -_REGION_TOL <= z <= length + _REGION_TOL


@kernel()
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


@kernel()
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
