"""Compiled pose arithmetic of a substep: the fingertip's motion and a jointed link's pose.

These replaced NumPy products in :mod:`tactile_gym.sim._kernels`' substep and give their
results to the bit (``docs/design.md`` 3.5), so the lean step keeps the trajectories of the
NumPy code it replaced. Poses are (4, 3): a rotation (body to world), then a position, world
frame, metres.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import intrinsic

from tactile_gym._jit import kernel

#: The joint kinds, as the last row of a link array holds them (``HingedObject.link``, row 5,
#: column 0); a link array of five rows is a revolute link's.
REVOLUTE, PRISMATIC, FIXED = 0.0, 1.0, 2.0


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c rounded once (LLVM's ``llvm.fma``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


# The pose arithmetic of a substep replaced NumPy products; these give their results to the
# bit, as NumPy's OpenBLAS computes them on x86-64 with FMA (docs/design.md 3.5): a 3x3
# matrix product and a dot product sum the terms in order with fused multiply-adds, a
# matrix-vector product starts from the middle term.


@kernel(inline="always")
def sum_fma(a0, b0, a1, b1, a2, b2):
    """An entry of a 3x3 @ 3x3 product, or a 3-vector dot product, as NumPy computes it."""
    return fma(a2, b2, fma(a1, b1, a0 * b0))


@kernel(inline="always")
def matvec_entry(a0, b0, a1, b1, a2, b2):
    """An entry of a 3x3 @ 3-vector product, as NumPy computes it."""
    return fma(a2, b2, fma(a0, b0, a1 * b1))


@kernel(inline="always")
def turned_frame(link, angle, out):
    """Pose of a primitive on a revolute link into ``out`` (4, 3): rotation H Rz(angle), then
    centre pin + R c. ``link`` (5, 3): H (the hinge frame's axes as columns, world frame),
    the pin, c (the primitive's centre in the link frame)."""
    c, s = math.cos(angle), math.sin(angle)
    for r in range(3):
        h0, h1, h2 = link[r, 0], link[r, 1], link[r, 2]
        out[r, 0] = sum_fma(h0, c, h1, s, h2, 0.0)
        out[r, 1] = sum_fma(h0, -s, h1, c, h2, 0.0)
        out[r, 2] = sum_fma(h0, 0.0, h1, 0.0, h2, 1.0)
    for r in range(3):
        out[3, r] = link[3, r] + matvec_entry(
            out[r, 0], link[4, 0], out[r, 1], link[4, 1], out[r, 2], link[4, 2]
        )


@kernel(inline="always")
def slid_frame(link, travel, out):
    """Pose of a primitive on a prismatic link into ``out`` (4, 3): rotation H, then centre
    pin + H c + travel a, with a the joint's direction (H's third column). ``link`` as for
    ``turned_frame``."""
    for r in range(3):
        for c in range(3):
            out[r, c] = link[r, c]
    for r in range(3):
        out[3, r] = (
            link[3, r]
            + matvec_entry(link[r, 0], link[4, 0], link[r, 1], link[4, 1], link[r, 2], link[4, 2])
            + travel * link[r, 2]
        )


@kernel(inline="always")
def joint_frame(link, q, out):
    """Pose of the primitive on a jointed link at joint coordinate ``q`` (rad or m) into
    ``out`` (4, 3): ``slid_frame`` for a prismatic link (row 5 of ``link``), else
    ``turned_frame`` (a fixed link stays at ``q`` = 0, where the revolute pose is H itself)."""
    if link.shape[0] > 5 and link[5, 0] == PRISMATIC:
        slid_frame(link, q, out)
    else:
        turned_frame(link, q, out)


@kernel()
def link_pose(link, angle):
    """(4, 3) pose of a primitive on a jointed link at ``angle`` (rad or m; ``joint_frame``)."""
    out = np.empty((4, 3))
    joint_frame(link, angle, out)
    return out


@kernel(inline="always")
def advance_into(pose, motion, turning, out):
    """One substep of the fingertip's motion from ``pose`` into ``out`` (both (4, 3):
    rotation, then position): position + step, and rotation step_R @ R when ``turning``."""
    for r in range(3):
        out[3, r] = pose[3, r] + motion[3, r]
    for r in range(3):
        for c in range(3):
            if turning:
                out[r, c] = sum_fma(
                    motion[r, 0], pose[0, c], motion[r, 1], pose[1, c], motion[r, 2], pose[2, c]
                )
            else:
                out[r, c] = pose[r, c]


@kernel()
def advance(pose, motion, turning, count):
    """Apply ``count`` substeps of the fingertip's motion to ``pose`` in place (free air)."""
    tmp = np.empty((4, 3))
    for _ in range(count):
        advance_into(pose, motion, turning, tmp)
        pose[:] = tmp
