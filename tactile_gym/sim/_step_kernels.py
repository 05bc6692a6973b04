"""Compiled control step of the v3 physics (``docs/design.md`` 3.6, 3.7): the joint and the
skin's substeps in one call.

The v2 step calls PyBullet three or four times per substep (the joint angle, the reaction,
``stepSimulation``) and the skin's kernel once; here the substeps of a control step run in
one compiled loop, and the free link's one degree of freedom is integrated in it
(``hinge_step``) with the scheme PyBullet's multibody applies to a revolute or prismatic
joint on a fixed base: semi-implicit Euler, the viscous damping as an explicit torque (force),
the holding friction as a velocity motor whose impulse is clamped to ``holding_torque`` times
the step. Away from the joint's limits this gives PyBullet's joint coordinate to rounding
(``tests/test_sim_hinge.py``); at a limit it is a hard stop, where PyBullet's limit lets the
link sink in and pushes it back over several steps. A fixed joint never moves.

Frames and units: world frame, SI (rad, rad/s, N m for a revolute joint; m, m/s, N for a
prismatic one; s). ``link`` (6, 3) is the free link as ``_pose_kernels.joint_frame`` takes
it: the hinge frame's axes as columns (rows 0-2, the joint's axis or direction of travel is
column 2), the pin, the free box's centre in the link frame (its centre of mass), and the
joint's kind (row 5, column 0: ``_pose_kernels.REVOLUTE``, ``PRISMATIC`` or ``FIXED``; a link
of five rows is revolute). ``hinge`` (8,): the inertia about the axis (kg m^2; prismatic: the
link's mass, kg), viscous damping (N m s/rad; N s/m), holding torque (N m; N), lower and upper
limit (rad; m), the link's weight m g (3, N).
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.sim import _kernels
from tactile_gym.sim._pose_kernels import FIXED, PRISMATIC, REVOLUTE, advance_into, joint_frame

#: Entries of ``hinge`` (module docstring); ``WEIGHT`` is the first of three.
INERTIA, DAMPING, HOLDING, LOWER, UPPER, WEIGHT = 0, 1, 2, 3, 4, 5

#: Columns of ``control_step``'s ``stats``: the guard held the fingertip back, some node
#: reached the shell, the largest penetration (m) and |f| (N) over the substeps, the link was
#: pushed in the last substep, the bound on node motion since the selection (m), the
#: substeps that evaluated the skin.
LIMITED, SHELL, MAX_PEN, MAX_FORCE, PUSHED, TIP_MOVED, EVALUATED = 0, 1, 2, 3, 4, 5, 6
STATS_COLS = 7


@kernel(inline="always")
def joint_kind(link):
    """The joint's kind of a link array (module docstring)."""
    return link[5, 0] if link.shape[0] > 5 else REVOLUTE


@kernel()
def hinge_step(hinge, link, link_pose, joint, torque, dt):
    """One step of the free link along its joint: ``joint`` (coordinate, velocity) in place.

    Args:
        hinge: (8,) the joint's dynamics (module docstring).
        link: (6, 3) the free link (module docstring).
        link_pose: (4, 3) the free box's pose at the current coordinate (rotation, centre).
        joint: (2,) coordinate (rad or m) and velocity (rad/s or m/s), in/out.
        torque: applied torque about the joint axis, N m (prismatic: force along it, N).
        dt: time step, s.
    """
    kind = joint_kind(link)
    if kind == FIXED:
        return
    q, qd = joint[0], joint[1]
    inertia = hinge[INERTIA]
    g0, g1, g2 = hinge[WEIGHT], hinge[WEIGHT + 1], hinge[WEIGHT + 2]
    if kind == PRISMATIC:
        # The weight's part along the direction of travel: a . m g.
        gravity = link[0, 2] * g0 + link[1, 2] * g1 + link[2, 2] * g2
    else:
        # The weight's torque about the axis: a . ((centre - pin) x m g).
        l0 = link_pose[3, 0] - link[3, 0]
        l1 = link_pose[3, 1] - link[3, 1]
        l2 = link_pose[3, 2] - link[3, 2]
        gravity = (
            link[0, 2] * (l1 * g2 - l2 * g1)
            + link[1, 2] * (l2 * g0 - l0 * g2)
            + link[2, 2] * (l0 * g1 - l1 * g0)
        )
    v = qd + dt * (torque + gravity - hinge[DAMPING] * qd) / inertia
    # The holding friction: a motor toward zero velocity whose impulse is at most
    # holding_torque * dt.
    hold = hinge[HOLDING] * dt / inertia
    if v > hold:
        v -= hold
    elif v < -hold:
        v += hold
    else:
        v = 0.0
    q += dt * v
    if q < hinge[LOWER]:
        q, v = hinge[LOWER], 0.0
    elif q > hinge[UPPER]:
        q, v = hinge[UPPER], 0.0
    joint[0], joint[1] = q, v


@kernel()
def axial_torque(link, reaction):
    """Torque about the joint axis of ``reaction`` (3, 3): a force, a torque about a point,
    that point (``_kernels.substep``'s output), N m."""
    l0 = reaction[2, 0] - link[3, 0]
    l1 = reaction[2, 1] - link[3, 1]
    l2 = reaction[2, 2] - link[3, 2]
    f0, f1, f2 = reaction[0, 0], reaction[0, 1], reaction[0, 2]
    t0 = reaction[1, 0] + l1 * f2 - l2 * f1
    t1 = reaction[1, 1] + l2 * f0 - l0 * f2
    t2 = reaction[1, 2] + l0 * f1 - l1 * f0
    return link[0, 2] * t0 + link[1, 2] * t1 + link[2, 2] * t2


@kernel()
def joint_load(link, reaction):
    """What ``reaction`` (3, 3; ``axial_torque``) drives the joint with: the torque about a
    revolute joint's axis (N m), the force along a prismatic joint's direction (N), 0 for a
    fixed joint."""
    kind = joint_kind(link)
    if kind == FIXED:
        return 0.0
    if kind == PRISMATIC:
        f = reaction[0]
        return link[0, 2] * f[0] + link[1, 2] * f[1] + link[2, 2] * f[2]
    return axial_torque(link, reaction)


@kernel()
def narrow(points, areas, nodes, poses, shapes, prim_info, reach):
    """The candidates of a broad phase whose signed distance to its primitives, posed now, is
    below ``reach``, nearest first (ties in the given order), with those distances.

    A broad phase made with reach R, after a relative motion of at most s, holds every node
    within R - s of its primitives (signed distances are 1-Lipschitz), so for ``reach`` up to
    R - s this is the broad phase made afresh, at the cost of its candidates only.

    Args:
        points, areas, nodes: (M, 3), (M,), (M,) the candidates (``Selection``).
        poses, shapes, prim_info: the fingertip and the candidates' primitives, posed now
            (``_kernels.select``).
        reach: distance bound, m.

    Returns:
        (nodes, points, areas, distance) of the kept candidates.
    """
    _kernels.check_poses(poses)
    if not reach >= 0.0:
        raise ValueError("the broad phase's reach must be a number >= 0 m")
    frames = _kernels._frames(poses)
    count = 0
    kept = np.empty(nodes.shape[0], dtype=np.int64)
    dist = np.empty(nodes.shape[0])
    for i in range(nodes.shape[0]):
        best = np.inf
        for j in range(prim_info.shape[0]):
            x0, x1, x2 = _kernels._to_local(frames, j, points[i, 0], points[i, 1], points[i, 2])
            best = min(best, _kernels._distance(shapes, prim_info[j, 1], j, x0, x1, x2))
        if best < reach:
            kept[count] = i
            dist[count] = best
            count += 1
    order = _kernels.stable_order(dist, count)
    out_nodes = np.empty(count, dtype=np.int64)
    out_points = np.empty((count, 3))
    out_areas = np.empty(count)
    out_dist = np.empty(count)
    for k in range(count):
        i = kept[order[k]]
        out_nodes[k] = nodes[i]
        for r in range(3):
            out_points[k, r] = points[i, r]
        out_areas[k] = areas[i]
        out_dist[k] = dist[order[k]]
    return out_nodes, out_points, out_areas, out_dist


@kernel(inline="always")
def _same_pose(a, b):
    for r in range(4):
        for c in range(3):
            if a[r, c] != b[r, c]:
                return False
    return True


@kernel()
def _same_state(new, last, last_count):
    """Whether evaluation ``new`` committed the skin's state that evaluation ``last`` left
    (``last_count`` nodes in contact; ``last`` is the empty tuple if it was made before this
    call, and then only an empty contact compares): the same nodes on the same primitives,
    anchors and penetrations."""
    count = new[0]
    if count != last_count:
        return False
    if count == 0:
        return True
    if last[0] != count:
        return False
    new_data, new_ids, last_data, last_ids = new[6], new[7], last[6], last[7]
    for i in range(count):
        if new_ids[i, 0] != last_ids[i, 0] or new_ids[i, 1] != last_ids[i, 1]:
            return False
        if new_data[i, _kernels.DELTA] != last_data[i, _kernels.DELTA]:
            return False
        for c in range(_kernels.ANCHOR, _kernels.ANCHOR + 3):
            if new_data[i, c] != last_data[i, c]:
                return False
    return True


@kernel()
def control_step(
    selection,
    old_ids,
    old_count,
    f_prev,
    pose,
    motion,
    turning,
    step_len,
    substeps,
    link,
    link_row,
    hinge,
    joint,
    link_pose,
    q_selected,
    link_reach,
    reach,
    limit,
    damping_rate,
    dt,
    reaction,
    stats,
):
    """Up to ``substeps`` physics substeps: the skin (``_kernels.substep``) against the free
    link posed at the joint's angle, then the joint (``hinge_step``) under the skin's
    reaction.

    A substep whose motion bound since the selection (``stats[TIP_MOVED]`` plus the link's
    turn since ``q_selected`` times ``link_reach``, plus this substep's ``step_len``) reaches
    the selection's ``reach`` is not run: the caller selects again and calls for the rest.
    Without candidates the skin is skipped (nothing is within reach) and a contact left from
    before is released.

    Args:
        selection: ``_kernels.substep``'s first sixteen arguments, fixed for a broad phase
            (``Selection.kernel_args``).
        old_ids, old_count, f_prev: the committed contact's node ids, count and |f| (N).
        pose, motion, turning, step_len: as in ``_kernels.substep``; ``pose`` in/out.
        substeps: how many substeps to run at most.
        link, link_row: the free link and its row in the selection (-1: not in it).
        hinge, joint: the joint's dynamics and its (coordinate, velocity), in/out.
        link_pose: (4, 3) out: the free box's pose at the coordinate reached.
        q_selected, link_reach: the coordinate at the selection (rad or m) and the largest
            motion of a point of the free box per unit of it (m/rad: its largest distance
            from the pin; 1 for a prismatic link, 0 for a fixed one).
        reach: the selection's reach, m.
        limit, damping_rate, dt: the guard's |f| limit (N), the skin's damping over the step
            (Pa/m), the time step (s).
        reaction: (3, 3) out, as in ``_kernels.substep``: valid if ``stats[PUSHED]``.
        stats: (STATS_COLS,) in/out: ``TIP_MOVED`` in, the rest accumulated from zero.

    Returns:
        (substeps run, released, evaluated, the last evaluation): ``evaluated`` if the last
        evaluation is now the committed contact; else ``released`` if the contact was let go
        (it is empty), and neither if the call left the contact as it was.
    """
    nodes, prim_info, state_prim = selection[2], selection[7], selection[9]
    empty = (
        0,
        0.0,
        False,
        0.0,
        np.zeros(6),
        np.zeros((prim_info.shape[0], _kernels.PRIM_COLS)),
        np.zeros((0, _kernels.NODE_COLS)),
        np.zeros((0, 2), dtype=np.int64),
    )
    for r in range(4):
        for c in range(3):
            if not (math.isfinite(pose[r, c]) and math.isfinite(motion[r, c])):
                raise ValueError("the fingertip's pose and motion must be finite")
    if not (math.isfinite(joint[0]) and math.isfinite(joint[1])):
        raise ValueError("the joint's angle and velocity must be finite")
    out = empty
    evaluated = released = False
    free = nodes.shape[0] == 0
    # The last substep left the fingertip where it was (held still, or the guard refused the
    # whole motion) and committed the skin's state it started from, at the joint angle of the
    # evaluation before: the next one, at the same angle, would repeat it to the bit.
    settled = limited_evaluated = False
    q_evaluated = np.nan
    torque_evaluated = 0.0
    before = np.empty((4, 3))
    tip_moved = stats[TIP_MOVED]
    for k in range(substeps):
        q = joint[0]
        moved = tip_moved + step_len + abs(q - q_selected) * link_reach
        if not moved < reach:
            joint_frame(link, q, link_pose)
            stats[TIP_MOVED] = tip_moved
            return k, released, evaluated, out
        joint_frame(link, q, link_pose)
        torque = 0.0
        if free:
            stats[PUSHED] = 0.0
            if old_count:
                for i in range(old_count):
                    state_prim[old_ids[i, 0]] = -1
                old_count = 0
                f_prev = 0.0
                released = True
                evaluated = False
                out = empty
            cand = np.empty((4, 3))
            advance_into(pose, motion, turning, cand)
            pose[:] = cand
            tip_moved += step_len
        elif settled and q == q_evaluated:
            torque = torque_evaluated
            if limited_evaluated:
                stats[LIMITED] = 1.0
        else:
            before[:] = pose
            new, limited, travelled, pushed = _kernels.substep(
                *selection, old_ids, old_count, moved, pose, motion, turning, step_len, link,
                link_row, q, f_prev, limit, damping_rate, reaction,
            )  # fmt: skip
            stats[EVALUATED] += 1.0
            settled = (
                q == q_evaluated and _same_pose(pose, before) and _same_state(new, out, old_count)
            )
            q_evaluated = q
            limited_evaluated = limited
            out = new
            evaluated = True
            tip_moved += travelled
            old_count, f_prev, old_ids = out[0], out[3], out[7]
            if limited:
                stats[LIMITED] = 1.0
            if out[2]:
                stats[SHELL] = 1.0
            stats[MAX_PEN] = max(stats[MAX_PEN], out[1])
            stats[MAX_FORCE] = max(stats[MAX_FORCE], f_prev)
            stats[PUSHED] = 1.0 if pushed else 0.0
            if pushed:
                torque = joint_load(link, reaction)
            torque_evaluated = torque
        hinge_step(hinge, link, link_pose, joint, torque, dt)
    joint_frame(link, joint[0], link_pose)
    stats[TIP_MOVED] = tip_moved
    return substeps, released, evaluated, out
