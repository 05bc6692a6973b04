"""Compiled hot path of the Winkler skin (:mod:`tactile_gym.sim.skin`).

The skin touches a few hundred nodes per substep; written as NumPy array expressions that
was ~60 calls per substep whose fixed per-call cost dominated. Here the broad phase
(``select``, once per control step), the per-substep evaluation (``evaluate``) and
committing the state (``commit``) are numba kernels with plain loops over the nodes, so the
cost is the arithmetic. The physics is documented in ``skin.py``; this module only restates
what each loop computes.

Type stability: every argument is a C-contiguous float64 or int64 array or a Python
float/int, so each kernel compiles exactly once (``tests/test_sim_skin.py`` checks this).
``cache=True`` stores the machine code in ``__pycache__`` next to this file, keyed on this
file's source and the CPU: processes started later (also the forked or spawned workers of a
vector env) load it instead of compiling. Numba writes cache files atomically, so workers
that compile at the same time do not corrupt each other.

Layouts (P primitives, M candidate nodes):

* ``poses`` (P + 1, 4, 3): row 0 is the fingertip (rotation sensor to world, then position),
  rows 1..P the primitives (rotation with the local axes as columns, then centre), world
  frame.
* ``shapes`` (P, 4): a box's inner half extents (half extents minus rounding) and rounding
  radius, or, for the plane, (0, 0, 0, height).
* ``prim_info`` (P, 2) int64: index of the primitive in the scene's list, kind (``BOX`` or
  ``PLANE``).
* ``frames`` (P, 4, 3): (A, b) with x_primitive = A x_sensor + b, as the 3 rows of A, then b.
  ``prev_frames`` (P_all, 4, 3): the same for every primitive of the scene (indexed by
  ``prim_info[:, 0]``) at the last committed pose: where a node came from.
* ``node_data`` (M, NODE_COLS): per node in contact, in its primitive's frame, columns
  ``LOCAL``, ``NORMAL``, ``ANCHOR``, ``FORCE``, ``POINT`` (3 each), then ``DELTA``,
  ``PRESSURE``; ``node_ids`` (M, 2) int64: node index, primitive index.
* ``prim_data`` (P, PRIM_COLS): per primitive, ``WRENCH`` (6, on the skin, sensor frame,
  moment about the sensor origin), ``REACTION`` (6, on the primitive, world frame, torque
  about its centre), ``FRAME`` (12, ``frames`` flattened), ``COUNT`` (nodes touching it).
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.sim._pose_kernels import advance_into, joint_frame, matvec_entry, sum_fma

BOX = 0
PLANE = 1

LOCAL, NORMAL, ANCHOR, FORCE, POINT = 0, 3, 6, 9, 12
DELTA, PRESSURE = 15, 16
NODE_COLS = 17

WRENCH, REACTION, FRAME, COUNT = 0, 6, 12, 24
PRIM_COLS = 25


@kernel(inline="always")
def check_poses(poses):
    """Raise a ValueError if a pose holds a NaN or an infinity. Every comparison with NaN is
    false: a broad phase would find nothing in reach, forever, and an evaluation no contact,
    without a word."""
    for i in range(poses.shape[0]):
        for r in range(poses.shape[1]):
            for c in range(3):
                if not math.isfinite(poses[i, r, c]):
                    raise ValueError("the fingertip's and the primitives' poses must be finite")


@kernel()
def _frames(poses):
    """(P, 4, 3) frames: A = Rb^T R, b = Rb^T (p - c) for each primitive."""
    n_prim = poses.shape[0] - 1
    frames = np.empty((n_prim, 4, 3))
    for j in range(n_prim):
        for r in range(3):
            for c in range(3):
                s = 0.0
                for k in range(3):
                    s += poses[j + 1, k, r] * poses[0, k, c]
                frames[j, r, c] = s
            s = 0.0
            for k in range(3):
                s += poses[j + 1, k, r] * (poses[0, 3, k] - poses[j + 1, 3, k])
            frames[j, 3, r] = s
    return frames


# Point helpers take and return coordinates as scalars (tuples), which stay in registers.


@kernel(inline="always")
def _to_local(frames, j, x0, x1, x2):
    """A_j x + b_j: a sensor-frame point in primitive j's frame."""
    return (
        frames[j, 0, 0] * x0 + frames[j, 0, 1] * x1 + frames[j, 0, 2] * x2 + frames[j, 3, 0],
        frames[j, 1, 0] * x0 + frames[j, 1, 1] * x1 + frames[j, 1, 2] * x2 + frames[j, 3, 1],
        frames[j, 2, 0] * x0 + frames[j, 2, 1] * x1 + frames[j, 2, 2] * x2 + frames[j, 3, 2],
    )


@kernel(inline="always")
def _distance(shapes, kind, j, x0, x1, x2):
    """Signed distance of a point in primitive j's frame (negative inside), m."""
    if kind == PLANE:
        return x2 - shapes[j, 3]
    q0 = abs(x0) - shapes[j, 0]
    q1 = abs(x1) - shapes[j, 1]
    q2 = abs(x2) - shapes[j, 2]
    qmax = max(max(q0, q1), q2)
    p0, p1, p2 = max(q0, 0.0), max(q1, 0.0), max(q2, 0.0)
    return math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) + min(qmax, 0.0) - shapes[j, 3]


@kernel(inline="always")
def _normal(shapes, kind, j, x0, x1, x2):
    """Outward unit normal at a point in primitive j's frame: for a box, from the inner box's
    nearest point, or along the nearest face's axis inside the inner box."""
    if kind == PLANE:
        return 0.0, 0.0, 1.0
    q0 = abs(x0) - shapes[j, 0]
    q1 = abs(x1) - shapes[j, 1]
    q2 = abs(x2) - shapes[j, 2]
    p0, p1, p2 = max(q0, 0.0), max(q1, 0.0), max(q2, 0.0)
    # Off an edge's rounding only one of them is positive: the normal is that axis, which the
    # general branch gives too, to the bit (sqrt(x * x) is x in binary floating point).
    if p0 == 0.0 and p1 == 0.0 and p2 > 1e-12:
        return math.copysign(0.0, x0), math.copysign(0.0, x1), math.copysign(1.0, x2)
    if p1 == 0.0 and p2 == 0.0 and p0 > 1e-12:
        return math.copysign(1.0, x0), math.copysign(0.0, x1), math.copysign(0.0, x2)
    if p0 == 0.0 and p2 == 0.0 and p1 > 1e-12:
        return math.copysign(0.0, x0), math.copysign(1.0, x1), math.copysign(0.0, x2)
    outer = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    if outer > 1e-12:
        n0, n1, n2 = p0 / outer, p1 / outer, p2 / outer
    elif q0 >= q1 and q0 >= q2:
        n0, n1, n2 = 1.0, 0.0, 0.0
    elif q1 >= q2:
        n0, n1, n2 = 0.0, 1.0, 0.0
    else:
        n0, n1, n2 = 0.0, 0.0, 1.0
    return math.copysign(n0, x0), math.copysign(n1, x1), math.copysign(n2, x2)


@kernel(inline="always")
def _project(shapes, kind, j, x0, x1, x2):
    """Nearest point of primitive j's surface to a point outside it (for a point inside, of
    the nearest face), and the outward normal there, primitive j's frame."""
    d = _distance(shapes, kind, j, x0, x1, x2)
    n0, n1, n2 = _normal(shapes, kind, j, x0, x1, x2)
    return x0 - d * n0, x1 - d * n1, x2 - d * n2, n0, n1, n2


@kernel(inline="always")
def _entry(shapes, j, y0, y1, y2, x0, x1, x2):
    """Where the straight path from y to x, a point inside box j, entered the box's surface.

    Returns (found, point): found is False if y is inside the box too (no history).

    A slab test finds where the path enters the un-rounded outer box (half extents h + r).
    On a face's flat part that is the box's surface; elsewhere it is in a rounded edge's or
    corner's region, within (sqrt(3) - 1) r of the surface, and a few steps of sphere
    tracing (the distance is exact outside, so they never overshoot) close in on it before
    the projection onto the surface.
    """
    if not _distance(shapes, BOX, j, y0, y1, y2) > 0.0:
        return False, 0.0, 0.0, 0.0
    r = shapes[j, 3]
    t = 0.0
    for ya, xa, h in ((y0, x0, shapes[j, 0]), (y1, x1, shapes[j, 1]), (y2, x2, shapes[j, 2])):
        outer = h + r
        if abs(ya) > outer:
            # |x_a| <= h + r < |y_a|: the denominator is positive.
            t = max(t, (abs(ya) - outer) / (abs(ya) - math.copysign(xa, ya)))
    v0, v1, v2 = x0 - y0, x1 - y1, x2 - y2
    length = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    for _ in range(4):
        d = _distance(shapes, BOX, j, y0 + t * v0, y1 + t * v1, y2 + t * v2)
        if not d > 1e-9:
            break
        t += d / length
    a0, a1, a2, _, _, _ = _project(shapes, BOX, j, y0 + t * v0, y1 + t * v1, y2 + t * v2)
    return True, a0, a1, a2


@kernel()
def stable_order(keys, count):
    """The permutation that sorts ``keys[:count]`` ascending, ties in index order: the one
    ``np.argsort(kind="stable")`` gives (a stable sort's permutation is unique).

    Linear time for spread keys, where a merge sort was a third of ``select``: a counting
    sort into about count / 4 buckets of equal width (the bucket index is monotone in the
    key), then an insertion sort within each bucket.
    """
    order = np.empty(count, dtype=np.int64)
    if count == 0:
        return order
    lo = hi = keys[0]
    for i in range(count):
        lo = min(lo, keys[i])
        hi = max(hi, keys[i])
    n_buckets = count // 4 + 1
    scale = (n_buckets - 1) / (hi - lo) if hi > lo else 0.0
    bucket = np.empty(count, dtype=np.int64)
    start = np.zeros(n_buckets + 1, dtype=np.int64)
    for i in range(count):
        b = min(int((keys[i] - lo) * scale), n_buckets - 1)
        bucket[i] = b
        start[b + 1] += 1
    for b in range(n_buckets):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    for i in range(count):
        b = bucket[i]
        order[fill[b]] = i
        fill[b] += 1
    for b in range(n_buckets):
        for k in range(start[b] + 1, start[b + 1]):
            item = order[k]
            key = keys[item]
            j = k - 1
            while j >= start[b] and keys[order[j]] > key:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = item
    return order


@kernel()
def select(
    points,
    areas,
    cluster_center,
    cluster_radius,
    cluster_start,
    bound_center,
    bound_radius,
    poses,
    shapes,
    prim_info,
    reach,
    slot,
):
    """Nodes whose signed distance to some primitive is below ``reach``, nearest first.

    Bounding spheres prune first: the fingertip's against each primitive, then each node
    cluster's (signed distances are 1-Lipschitz, so nothing within reach is lost).

    Args:
        points, areas: (N, 3), (N,) node positions (sensor frame, grouped by cluster) and
            areas.
        cluster_center, cluster_radius: (C, 3), (C,) bounding spheres of the clusters.
        cluster_start: (C + 1,) first node of each cluster, then N.
        bound_center, bound_radius: (3,), float: the fingertip's bounding sphere.
        poses, shapes, prim_info: the fingertip and all primitives (module docstring).
        reach: distance bound, m.
        slot: (N,) int64 scratch, all -1 on entry and on return.

    Returns:
        (nodes (M,), their points (M, 3), areas (M,) and distances (M,), ascending, the
        smallest over the primitives; hits (P,): how many nodes are within reach of each
        primitive; frames (P, 4, 3) of all primitives at this pose; clearance: a lower bound
        on every node's distance to every primitive, m, from the bounds the pruning computed).
    """
    check_poses(poses)
    if not reach >= 0.0:
        raise ValueError("the broad phase's reach must be a number >= 0 m")
    frames = _frames(poses)
    n_prim = prim_info.shape[0]
    found = np.empty(points.shape[0], dtype=np.int64)
    dist = np.empty(points.shape[0])
    hits = np.zeros(n_prim, dtype=np.int64)
    count = 0
    clearance = np.inf
    for j in range(n_prim):
        kind = prim_info[j, 1]
        x0, x1, x2 = _to_local(frames, j, bound_center[0], bound_center[1], bound_center[2])
        d = _distance(shapes, kind, j, x0, x1, x2)
        if not d < bound_radius + reach:
            clearance = min(clearance, d - bound_radius)
            continue
        for k in range(cluster_radius.shape[0]):
            c = cluster_center[k]
            x0, x1, x2 = _to_local(frames, j, c[0], c[1], c[2])
            d = _distance(shapes, kind, j, x0, x1, x2)
            if not d < cluster_radius[k] + reach:
                clearance = min(clearance, d - cluster_radius[k])
                continue
            for i in range(cluster_start[k], cluster_start[k + 1]):
                x0, x1, x2 = _to_local(frames, j, points[i, 0], points[i, 1], points[i, 2])
                d = _distance(shapes, kind, j, x0, x1, x2)
                clearance = min(clearance, d)
                if not d < reach:
                    continue
                hits[j] += 1
                s = slot[i]
                if s < 0:
                    slot[i] = count
                    found[count] = i
                    dist[count] = d
                    count += 1
                elif d < dist[s]:
                    dist[s] = d
    for i in range(count):
        slot[found[i]] = -1
    order = stable_order(dist, count)
    nodes = np.empty(count, dtype=np.int64)
    cand_points = np.empty((count, 3))
    cand_areas = np.empty(count)
    cand_dist = np.empty(count)
    for k in range(count):
        i = found[order[k]]
        nodes[k] = i
        for r in range(3):
            cand_points[k, r] = points[i, r]
        cand_areas[k] = areas[i]
        cand_dist[k] = dist[order[k]]
    return nodes, cand_points, cand_areas, cand_dist, hits, frames, clearance


@kernel()
def evaluate(
    points,
    areas,
    nodes,
    distance,
    moved,
    poses,
    prev_frames,
    shapes,
    prim_info,
    state_prim,
    state_anchor,
    state_delta,
    k_n,
    damping_rate,
    k_t,
    mu,
    thickness,
):
    """Contact forces of the candidate nodes at one fingertip pose; reads the skin state only.

    Args:
        points: (M, 3) candidate node positions, sensor frame, sorted by ``distance``.
        areas: (M,) node areas. nodes: (M,) node indices. distance: (M,) ascending distance
            of each candidate at selection; only those with ``distance <= moved`` can touch.
        poses, shapes, prim_info: the fingertip and candidate primitives (module docstring).
        prev_frames: (P_all, 4, 3) frames of all the scene's primitives (indexed by
            ``prim_info[:, 0]``) at the last committed pose.
        state_prim, state_anchor, state_delta: (N,), (N, 3), (N,) committed primitive index
            (-1: not in contact), anchor (on the primitive's surface, its frame) and
            penetration of every node.
        k_n, damping_rate, k_t, mu, thickness: normal stiffness (Pa/m), normal damping over
            the time step (Pa/m), tangential stiffness (Pa/m), friction coefficient, skin
            thickness (m).

    Returns:
        (count, max_penetration, shell, |force|, wrench (6,), prim_data, node_data,
        node_ids); the first ``count`` rows of the node arrays are valid.
    """
    check_poses(poses)
    if not moved >= -np.inf:
        raise ValueError("the motion since the broad phase must be a number, got NaN")
    n_prim = prim_info.shape[0]
    # Candidates that may touch after a motion of ``moved`` (searchsorted, side="right").
    lo, hi = 0, distance.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if distance[mid] <= moved:
            lo = mid + 1
        else:
            hi = mid
    m = lo

    frames = _frames(poses)
    node_data = np.empty((m, NODE_COLS))
    node_ids = np.empty((m, 2), dtype=np.int64)
    prim_data = np.zeros((n_prim, PRIM_COLS))
    force_sum = np.zeros((n_prim, 3))
    moment_sum = np.zeros((n_prim, 3))
    count = 0
    max_pen = 0.0
    for i in range(m):
        # Narrow phase: the primitive that penetrates the node most (the first one on ties),
        # each measured from the tangent plane at the node's anchor on it (module docstring).
        p0, p1, p2 = points[i, 0], points[i, 1], points[i, 2]
        node = nodes[i]
        best_d = 0.0
        best_j = -1
        l0 = l1 = l2 = a0 = a1 = a2 = n0 = n1 = n2 = 0.0
        for j in range(n_prim):
            kind = prim_info[j, 1]
            x0, x1, x2 = _to_local(frames, j, p0, p1, p2)
            if not _distance(shapes, kind, j, x0, x1, x2) < 0.0:
                continue
            prim = prim_info[j, 0]
            if state_prim[node] == prim:
                b0, b1, b2 = state_anchor[node, 0], state_anchor[node, 1], state_anchor[node, 2]
            elif kind == PLANE:
                b0, b1, b2 = x0, x1, shapes[j, 3]
            else:
                y0, y1, y2 = _to_local(prev_frames, prim, p0, p1, p2)
                found, b0, b1, b2 = _entry(shapes, j, y0, y1, y2, x0, x1, x2)
                if not found:
                    b0, b1, b2, _, _, _ = _project(shapes, kind, j, x0, x1, x2)
            m0, m1, m2 = _normal(shapes, kind, j, b0, b1, b2)
            # A tangent plane of a convex body: d <= the node's signed distance < 0.
            d = (x0 - b0) * m0 + (x1 - b1) * m1 + (x2 - b2) * m2
            if d < best_d:
                best_d, best_j = d, j
                l0, l1, l2, a0, a1, a2, n0, n1, n2 = x0, x1, x2, b0, b1, b2, m0, m1, m2
        if best_j < 0:
            continue
        j = best_j
        delta = -best_d
        prim = prim_info[j, 0]
        # p = k_n delta + c d(delta)/dt, no adhesion; a new contact starts undamped.
        # u: tangential offset of the node from its anchor.
        delta_prev = state_delta[node] if state_prim[node] == prim else delta
        pressure = max((delta - delta_prev) * damping_rate + k_n * delta, 0.0)
        u0, u1, u2 = l0 - a0 + delta * n0, l1 - a1 + delta * n1, l2 - a2 + delta * n2
        u_sq = u0 * u0 + u1 * u1 + u2 * u2
        # Coulomb cap: slip moves the anchor along the surface so that k_t |u| = mu p.
        cap = mu * pressure
        if k_t * k_t * u_sq > cap * cap:
            slip = 1.0 - cap / (k_t * math.sqrt(u_sq))
            a0, a1, a2, _, _, _ = _project(
                shapes, prim_info[j, 1], j, a0 + slip * u0, a1 + slip * u1, a2 + slip * u2
            )
            u0 -= slip * u0
            u1 -= slip * u1
            u2 -= slip * u2
        fn = pressure * areas[i]
        ft = k_t * areas[i]
        f0, f1, f2 = n0 * fn - u0 * ft, n1 * fn - u1 * ft, n2 * fn - u2 * ft
        # The force acts at the deformed point: on the tangent plane at the anchor, which is
        # the primitive's surface for a face.
        c0, c1, c2 = l0 + delta * n0, l1 + delta * n1, l2 + delta * n2
        row = node_data[count]
        row[LOCAL], row[LOCAL + 1], row[LOCAL + 2] = l0, l1, l2
        row[NORMAL], row[NORMAL + 1], row[NORMAL + 2] = n0, n1, n2
        row[ANCHOR], row[ANCHOR + 1], row[ANCHOR + 2] = a0, a1, a2
        row[FORCE], row[FORCE + 1], row[FORCE + 2] = f0, f1, f2
        row[POINT], row[POINT + 1], row[POINT + 2] = c0, c1, c2
        row[DELTA] = delta
        row[PRESSURE] = pressure
        force_sum[j, 0] += f0
        force_sum[j, 1] += f1
        force_sum[j, 2] += f2
        # Moment about the primitive frame's origin; shifted to the sensor origin below.
        moment_sum[j, 0] += c1 * f2 - c2 * f1
        moment_sum[j, 1] += c2 * f0 - c0 * f2
        moment_sum[j, 2] += c0 * f1 - c1 * f0
        node_ids[count, 0] = node
        node_ids[count, 1] = prim
        prim_data[j, COUNT] += 1.0
        max_pen = max(max_pen, delta)
        count += 1

    wrench = np.zeros(6)
    rot = poses[0, :3]
    for j in range(n_prim):
        out = prim_data[j]
        for r in range(3):
            for c in range(3):
                out[FRAME + 3 * r + c] = frames[j, r, c]
            out[FRAME + 9 + r] = frames[j, 3, r]
        if out[COUNT] == 0.0:
            continue
        # On the skin, sensor frame: sum (x - b) x f = sum x x f - b x F, rotated by A^T.
        fx, fy, fz = force_sum[j, 0], force_sum[j, 1], force_sum[j, 2]
        b = frames[j, 3]
        mx = moment_sum[j, 0] - (b[1] * fz - b[2] * fy)
        my = moment_sum[j, 1] - (b[2] * fx - b[0] * fz)
        mz = moment_sum[j, 2] - (b[0] * fy - b[1] * fx)
        for c in range(3):
            out[WRENCH + c] = fx * frames[j, 0, c] + fy * frames[j, 1, c] + fz * frames[j, 2, c]
            out[WRENCH + 3 + c] = mx * frames[j, 0, c] + my * frames[j, 1, c] + mz * frames[j, 2, c]
        for c in range(6):
            wrench[c] += out[WRENCH + c]
        # On the primitive (Newton's third law), world frame, torque about its centre:
        # -R f and -R m - (p - centre) x (R f).
        for r in range(3):
            fw = rot[r, 0] * out[WRENCH] + rot[r, 1] * out[WRENCH + 1] + rot[r, 2] * out[WRENCH + 2]
            mw = rot[r, 0] * out[WRENCH + 3] + rot[r, 1] * out[WRENCH + 4]
            mw += rot[r, 2] * out[WRENCH + 5]
            out[REACTION + r] = -fw
            out[REACTION + 3 + r] = -mw
        for r in range(3):
            r1, r2 = (r + 1) % 3, (r + 2) % 3
            lever1 = poses[0, 3, r1] - poses[j + 1, 3, r1]
            lever2 = poses[0, 3, r2] - poses[j + 1, 3, r2]
            # -(lever x R f) = lever x reaction force.
            out[REACTION + 3 + r] += lever1 * out[REACTION + r2] - lever2 * out[REACTION + r1]
    force = math.sqrt(wrench[0] * wrench[0] + wrench[1] * wrench[1] + wrench[2] * wrench[2])
    return (
        count,
        max_pen,
        max_pen > thickness,
        force,
        wrench,
        prim_data,
        node_data,
        node_ids,
    )


@kernel()
def commit(
    state_prim,
    state_anchor,
    state_delta,
    prev_frames,
    old_ids,
    old_count,
    node_ids,
    node_data,
    count,
    prim_data,
    prim_rows,
):
    """Make a contact the skin's state: forget the nodes of the previous one, store this one's
    primitive, anchor and penetration per node, and its frames as the primitives' previous
    ones (``prim_rows``: the scene's index of each row of ``prim_data``; other arrays as in
    ``evaluate``)."""
    for i in range(old_count):
        state_prim[old_ids[i, 0]] = -1
    for i in range(count):
        node = node_ids[i, 0]
        state_prim[node] = node_ids[i, 1]
        for r in range(3):
            state_anchor[node, r] = node_data[i, ANCHOR + r]
        state_delta[node] = node_data[i, DELTA]
    for k in range(prim_rows.shape[0]):
        for r in range(4):
            for c in range(3):
                prev_frames[prim_rows[k], r, c] = prim_data[k, FRAME + 3 * r + c]


@kernel()
def substep(
    points,
    areas,
    nodes,
    distance,
    poses,
    prev_frames,
    shapes,
    prim_info,
    prim_rows,
    state_prim,
    state_anchor,
    state_delta,
    k_n,
    k_t,
    mu,
    thickness,
    old_ids,
    old_count,
    moved,
    pose,
    motion,
    turning,
    step_len,
    link,
    link_row,
    angle,
    f_prev,
    limit,
    damping_rate,
    reaction,
):
    """One physics substep of the skin: move, evaluate with the guarded move, commit.

    The primitive on the jointed link (row ``link_row`` of the candidate primitives, -1 if
    not among them) is posed at ``angle``; the fingertip advances from the committed ``pose``
    by ``motion`` (rows 0-2 the per-substep rotation, applied when ``turning``; row 3 the
    translation). If that raises |f| above ``limit`` (and above ``f_prev``), the guarded move
    keeps the sideways part of the translation and the fraction of the advancing part that
    linear interpolation puts at the limit, without rotation; if that is still above, the
    fingertip stays. The result is committed (``commit``) and written to ``pose``.

    Args:
        points ... thickness, moved, damping_rate: as in ``evaluate`` and ``commit`` (the
            first sixteen are fixed for a selection, so the caller keeps them as one tuple).
        old_ids, old_count: the committed contact's node ids and count.
        pose: (4, 3) committed fingertip pose, in/out.
        motion: (4, 3) per-substep rotation and translation. turning: apply the rotation.
        step_len: bound on any node's displacement by one substep of ``motion``, m.
        link, link_row, angle: the jointed link (``joint_frame``) and its coordinate, rad or
            m.
        f_prev: |f| of the committed contact, N. limit: the guard's |f| limit, N.
        reaction: (3, 3) out: force and torque (about its centre) on the link's primitive,
            world frame, and that centre; valid when the returned ``pushed`` is True.

    Returns:
        (evaluate's tuple, limited, travelled, pushed): whether the guard held the fingertip
        back, the bound on node displacement to add to the motion since ``select`` (m), and
        whether the link's primitive is touched.
    """
    if link_row >= 0:
        joint_frame(link, angle, poses[link_row + 1])
    cand = np.empty((4, 3))
    advance_into(pose, motion, turning, cand)
    poses[0] = cand
    out = evaluate(
        points, areas, nodes, distance, moved, poses, prev_frames, shapes, prim_info,
        state_prim, state_anchor, state_delta, k_n, damping_rate, k_t, mu, thickness,
    )  # fmt: skip
    f_new = out[3]
    limited = False
    held = not turning
    if f_new > limit and f_new > f_prev:
        limited = True
        held = True
        wrench = out[4]
        f_dir = np.empty(3)
        for r in range(3):
            f_dir[r] = matvec_entry(
                pose[r, 0], wrench[0], pose[r, 1], wrench[1], pose[r, 2], wrench[2]
            )
            f_dir[r] /= f_new
        push = min(
            sum_fma(motion[3, 0], f_dir[0], motion[3, 1], f_dir[1], motion[3, 2], f_dir[2]),
            0.0,
        )
        frac = 0.9 * max(0.0, (limit - f_prev) / (f_new - f_prev))
        scale = (1.0 - frac) * push
        for r in range(3):
            cand[3, r] = pose[3, r] + motion[3, r] - scale * f_dir[r]
            for c in range(3):
                cand[r, c] = pose[r, c]
        poses[0] = cand
        out = evaluate(
            points, areas, nodes, distance, moved, poses, prev_frames, shapes, prim_info,
            state_prim, state_anchor, state_delta, k_n, damping_rate, k_t, mu, thickness,
        )  # fmt: skip
        f_new = out[3]
        if f_new > limit and f_new > f_prev:
            for r in range(3):
                cand[3, r] = pose[3, r]
            poses[0] = cand
            out = evaluate(
                points, areas, nodes, distance, moved, poses, prev_frames, shapes, prim_info,
                state_prim, state_anchor, state_delta, k_n, damping_rate, k_t, mu, thickness,
            )  # fmt: skip
    if held:
        d0, d1, d2 = cand[3, 0] - pose[3, 0], cand[3, 1] - pose[3, 1], cand[3, 2] - pose[3, 2]
        travelled = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    else:
        travelled = step_len
    pose[:] = cand
    count, _, _, _, _, prim_data, node_data, node_ids = out
    commit(
        state_prim, state_anchor, state_delta, prev_frames, old_ids, old_count,
        node_ids, node_data, count, prim_data, prim_rows,
    )  # fmt: skip
    pushed = link_row >= 0 and prim_data[link_row, COUNT] > 0.0
    if pushed:
        for r in range(3):
            reaction[0, r] = prim_data[link_row, REACTION + r]
            reaction[1, r] = prim_data[link_row, REACTION + 3 + r]
            reaction[2, r] = poses[link_row + 1, 3, r]
    return out, limited, travelled, pushed
