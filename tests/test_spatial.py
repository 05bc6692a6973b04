"""tactile_gym.spatial: rotations checked against scipy, and the one edge-sign rule."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tactile_gym.spatial import (
    matrix_to_quaternion,
    matrix_to_rotvec,
    orient_edges,
    orient_like,
    quaternion_to_matrix,
    rotation_z,
    rotvec_to_matrix,
    z_to,
)


@pytest.fixture(scope="module")
def rotations() -> Rotation:
    rng = np.random.default_rng(0)
    # Random rotations plus the awkward ones: identity, half turns about each axis.
    half_turns = Rotation.from_rotvec(np.pi * np.eye(3))
    return Rotation.concatenate(
        [Rotation.random(200, random_state=rng), Rotation.identity(), half_turns]
    )


def test_quaternions_and_matrices_match_scipy(rotations):
    for r in rotations:
        m = r.as_matrix()
        q = r.as_quat()
        np.testing.assert_allclose(quaternion_to_matrix(q), m, atol=1e-12)
        mine = matrix_to_quaternion(m)
        assert mine[3] >= 0.0
        assert abs(np.dot(mine, q)) == pytest.approx(1.0, abs=1e-12)  # same rotation, +-q


def test_rotation_vectors_match_scipy(rotations):
    for r in rotations:
        v = r.as_rotvec()
        np.testing.assert_allclose(rotvec_to_matrix(v), r.as_matrix(), atol=1e-12)
        back = Rotation.from_rotvec(matrix_to_rotvec(r.as_matrix()))
        assert (back * r.inv()).magnitude() < 1e-9


def test_rotation_z_and_z_to():
    np.testing.assert_allclose(rotation_z(np.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    rng = np.random.default_rng(1)
    for d in [*rng.normal(size=(50, 3)), [0, 0, 1], [0, 0, -2], [1e-9, 0, -1]]:
        r = z_to(d)
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(r @ [0, 0, 1], np.asarray(d) / np.linalg.norm(d), atol=1e-12)
    with pytest.raises(ValueError, match="direction must be a finite non-zero"):
        z_to([0, 0, 0])


def test_orient_like_follows_the_best_aligned_reference():
    e = np.array([1.0, 0.1, 0.0])
    assert orient_like(e, [[-1.0, 0.0, 0.0]]) @ e < 0
    # The best-aligned of several references decides, not the last one.
    refs = [[-1.0, 0.0, 0.0], [0.1, 1.0, 0.0]]
    assert orient_like(e, refs) @ e < 0
    # No usable reference: largest component positive.
    np.testing.assert_array_equal(orient_like([0.2, -0.9, 0.1], []), [-0.2, 0.9, -0.1])
    np.testing.assert_array_equal(orient_like([0.2, -0.9, 0.1], [[0, 0, 0]]), [-0.2, 0.9, -0.1])


def test_orient_edges_survives_one_wild_edge():
    angles = np.deg2rad([0.0, 10.0, 20.0, 30.0, 40.0])
    edges = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(5)])
    signs = np.array([1, -1, 1, -1, -1])
    mixed = edges * signs[:, None]
    mixed[2] = [0.0, 0.0, 1.0]  # a wild edge, perpendicular to the others
    out = orient_edges(mixed)
    keep = [0, 1, 3, 4]
    assert np.all(np.einsum("ij,ij->i", out[keep], edges[keep]) > 0)
    with pytest.raises(ValueError, match="edges must have shape"):
        orient_edges(np.zeros((3, 2)))
