"""Bad input raises ValueError naming the field; the package imports without pybullet.

The ground truth comes from ``estimation_cases``: an edge line of a link rotating about a
known axis, with the contact point sliding along the edge between measurements.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from estimation_cases import (
    PAPER_AXIS,
    make_planar,
    tilted_case,
)

from tactile_gym.estimation import (
    JointAxisEstimator,
    axis_error,
    fit_axis_3d,
    fit_axis_planar,
    fit_axis_simple,
)


@pytest.mark.parametrize(
    "call",
    [
        lambda: fit_axis_planar(np.zeros((4, 4)), np.ones((4, 2))),
        lambda: fit_axis_planar(np.zeros((4, 2)), np.ones((3, 2))),
        lambda: fit_axis_planar([[0, 0], [1, np.nan], [0, 1]], np.ones((3, 2))),
        lambda: fit_axis_planar(np.zeros((3, 2)), [[1, 0], [0, 0], [0, 1]]),
        lambda: fit_axis_planar(np.zeros((3, 2)), np.ones((3, 2)), weights=[1, -1, 1]),
        lambda: fit_axis_planar(np.zeros((3, 2)), np.ones((3, 2)), point_std=-1, edge_std=0.1),
        lambda: fit_axis_planar(np.zeros((3, 2)), np.ones((3, 2)), point_std=1e-3),
        lambda: fit_axis_simple(np.zeros((3, 1))),
        lambda: fit_axis_simple([[0, 0], [np.inf, 0], [1, 1]]),
        lambda: fit_axis_3d(np.zeros((4, 2)), np.ones((4, 2))),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), loss="l1"),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), f_scale=-1.0),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), point_std=1e-3, edge_std=-1),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.zeros((4, 3))),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), edge_std=0.01),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), edge_cov=np.zeros((4, 3, 3))),
        lambda: fit_axis_3d(
            np.zeros((4, 3)), np.ones((4, 3)), point_std=1e-3, edge_std=0.01, edge_cov=_COVS
        ),
        lambda: fit_axis_3d(np.zeros((4, 3)), np.ones((4, 3)), point_std=1e-3, edge_cov=_COVS[0]),
        lambda: fit_axis_planar(np.zeros((4, 3)), np.ones((4, 3)), point_std=1e-3),
        lambda: fit_axis_planar(np.zeros((4, 2)), np.ones((4, 2)), loss="l1"),
        lambda: fit_axis_planar(np.zeros((4, 2)), np.ones((4, 2)), loss="huber", f_scale=0.0),
        lambda: JointAxisEstimator().add([0, 0, 0], [1, 0, 0], 1e-3, 0.01, edge_cov=np.eye(2)),
        lambda: JointAxisEstimator(mode="2d"),
        lambda: JointAxisEstimator(loss="l2"),
        lambda: JointAxisEstimator(min_measurements=2),
        lambda: JointAxisEstimator().add([0, 0, 0], [1, 0, 0], -1e-3, 0.01),
        lambda: JointAxisEstimator().add([0, 0, 0], [0, 0, 1], 1e-3, 0.01),
        lambda: JointAxisEstimator().add([0, 0, np.nan], [1, 0, 0], 1e-3, 0.01),
        lambda: JointAxisEstimator("3d").add([0, 0], [1, 0], 1e-3, 0.01),
        lambda: axis_error(None, [0, 0], [0, 0, 1]),
        lambda: axis_error(None, [0, 0, 0], [0, 0, 0]),
    ],
)
def test_bad_input_raises_value_error(call) -> None:
    with pytest.raises(ValueError):
        call()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize(
    "fit, dims, where",
    [
        (fit_axis_planar, 2, "points"),
        (fit_axis_planar, 2, "edges"),
        (fit_axis_planar, 3, "edges"),
        (fit_axis_3d, 3, "points"),
        (fit_axis_3d, 3, "edges"),
        (fit_axis_simple, 2, "points"),
    ],
)
def test_inf_is_rejected_like_nan(fit, dims: int, where: str, bad: float) -> None:
    """A non-finite entry in row 2 is a ValueError naming the input and the row."""
    p, u, pts, eds = tilted_case(np.random.default_rng(0), n=6)
    pts, eds = pts[:, :dims].copy(), eds[:, :dims].copy()
    {"points": pts, "edges": eds}[where][2, 0] = bad
    with pytest.raises(ValueError, match=rf"{where} must be finite.*rows \[2\]"):
        fit(pts) if fit is fit_axis_simple else fit(pts, eds)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_online_rejects_non_finite_values(bad: float) -> None:
    for mode in ("planar", "3d"):
        est = JointAxisEstimator(mode)
        with pytest.raises(ValueError, match="finite"):
            est.add([0.0, bad, 0.0], [1.0, 0.0, 0.0], 1e-3, 0.01)
        with pytest.raises(ValueError, match="finite"):
            est.add([0.0, 0.0, 0.0], [1.0, bad, 0.0], 1e-3, 0.01)
        with pytest.raises(ValueError, match="edge_std"):
            est.add([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1e-3, bad)
        assert est.n_measurements == 0
    with pytest.raises(ValueError, match="min_measurements"):
        JointAxisEstimator(min_measurements=bad)


def test_planar_overflow_is_a_value_error() -> None:
    pts = np.array([[1e308, 0.0], [0.0, 1e308], [-1e308, 1e308]])
    with pytest.raises(ValueError, match="overflow"):
        fit_axis_planar(pts, [[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])


_COVS = np.stack([1e-4 * np.eye(3)] * 4)


@pytest.mark.parametrize(
    "bad, why",
    [
        (np.array([[1e-4, 1e-5, 0], [0, 1e-4, 0], [0, 0, 1e-4]]), "not symmetric"),
        (-1e-4 * np.eye(3), "negative"),
        (np.diag([1e-4, -1e-3, 1e-4]), "indefinite"),
        (np.diag([1e-4, np.nan, 1e-4]), "NaN"),
        (np.diag([1e-4, np.inf, 1e-4]), "inf"),
    ],
)
def test_bad_edge_cov_is_a_value_error_naming_the_row(bad: np.ndarray, why: str) -> None:
    edges = np.array([[1.0, 0, 0], [0, 1.0, 0], [1.0, 1.0, 0], [1.0, -1.0, 0]])
    pts = np.array([[0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0], [0.2, 0, 0]])
    covs = _COVS.copy()
    covs[2] = bad
    for fit in (fit_axis_3d, fit_axis_planar):
        with pytest.raises(ValueError, match=r"edge_cov.*rows \[2\]"):
            fit(pts, edges, point_std=1e-3, edge_cov=covs)
    for mode in ("planar", "3d"):
        online = JointAxisEstimator(mode)
        with pytest.raises(ValueError, match=r"edge_cov"):
            online.add(pts[2], edges[2], 1e-3, 0.01, edge_cov=bad)
        assert online.n_measurements == 0


def test_axis_error_ignores_direction_sign_and_uses_reference_point() -> None:
    pts, eds = make_planar(np.random.default_rng(0), sigma_x=0, sigma_e=0)
    est = fit_axis_planar(pts, eds)
    pos, ang = axis_error(est, PAPER_AXIS + [0, 0, 5.0], [0, 0, -2.0], [0.5, 0.5, 0.1])
    assert pos < 1e-9 and ang == 0.0
    assert axis_error(None, PAPER_AXIS, [0, 0, 1]) == (math.inf, math.pi / 2)


def test_import_without_pybullet() -> None:
    # A finder that refuses them, as on a machine without them. (Setting their
    # sys.modules entries to None instead breaks scipy.stats, which probes sys.modules.)
    code = (
        "import sys\n"
        "class Refuse:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('pybullet', 'torch'):\n"
        "            raise ImportError(name)\n"
        "sys.meta_path.insert(0, Refuse())\n"
        "import tactile_gym.estimation as m\n"
        "assert 'pybullet' not in [k for k, v in sys.modules.items() if v is not None]\n"
        "print(m.fit_axis_planar.__name__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
