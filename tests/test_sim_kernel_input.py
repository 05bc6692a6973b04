"""The skin's kernels on degenerate input: no candidates, every node in contact, a pose with a
NaN. They return a flagged result or raise a clear error, and never index past an array: the
debug build (``TACTILE_GYM_BOUNDSCHECK=1``, ``tactile_gym/_jit.py``) checks every index,
and a subprocess runs these cases under it."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sim import ObjectConfig, ProbeScene, SkinConfig, _kernels, _step_kernels
from tactile_gym.sim.primitives import RoundedBox
from tactile_gym.sim.skin import SoftSkin

DT = 1.0 / 240.0
UP = np.eye(3)  # sensor z up: the hemisphere's lowest point is the sensor origin's far side


@pytest.fixture(scope="module")
def skin():
    return SoftSkin(FingertipGeometry(), SkinConfig())


def _box(half: float) -> RoundedBox:
    return RoundedBox(np.full(3, half), 0.0, np.zeros(3), np.eye(3))


def test_no_candidates_give_an_empty_contact(skin):
    """Far from everything: no candidate, an evaluation without contact, a clearance."""
    prims = [_box(0.01)]
    far = np.array([0.0, 0.0, 1.0])
    sel = skin.select(prims, UP, far, 0.0)
    assert len(sel.nodes) == 0
    assert sel.reach > 0.9  # the clearance: about 1 m less the fingertip's size
    contact = skin.evaluate(sel, prims, UP, far, DT)
    assert contact.n_active == 0 and not contact.wrench.any()
    empty = np.zeros(0)
    out = _step_kernels.narrow(
        sel.points, sel.areas, sel.nodes, sel.poses, sel.shapes, sel.prim_info, 0.01
    )
    assert [len(a) for a in out] == [0, 0, 0, 0]
    assert _kernels.stable_order(empty, 0).shape == (0,)


def test_every_node_in_contact_is_flagged_as_shell_contact(skin):
    """The fingertip buried in a box: every node is a candidate and in contact, the node
    arrays hold them all, and the rigid shell's contact is flagged."""
    skin.reset()
    prims = [_box(0.2)]
    centre = np.zeros(3)
    sel = skin.select(prims, UP, centre, 0.0)
    assert len(sel.nodes) == skin.n_nodes
    contact = skin.evaluate(sel, prims, UP, centre, DT)
    assert contact.n_active == skin.n_nodes
    assert contact.shell_contact and contact.max_penetration > skin.thickness
    assert np.isfinite(contact.wrench).all()
    skin.commit(contact)
    assert skin.n_active == skin.n_nodes
    skin.reset()


@pytest.mark.parametrize("where", ["rotation", "position"])
def test_a_nan_pose_raises_a_clear_error(skin, where):
    prims = [_box(0.01)]
    rotation, position = UP.copy(), np.array([0.0, 0.0, 0.0105])  # just above the box
    sel = skin.select(prims, rotation, position, 0.001)
    assert len(sel.nodes)
    (rotation if where == "rotation" else position)[0] = np.nan
    with pytest.raises(ValueError, match="poses must be finite"):
        skin.select(prims, rotation, position, 0.001)
    with pytest.raises(ValueError, match="poses must be finite"):
        skin.evaluate(sel, prims, rotation, position, DT)
    with pytest.raises(ValueError, match="poses must be finite"):
        skin.narrow(sel, prims, rotation, position, 0.001)


def test_a_nan_reach_raises(skin):
    with pytest.raises(ValueError, match="reach must be a number"):
        skin.select([_box(0.01)], UP, np.array([0.0, 0.0, 0.05]), np.nan)


def test_the_v3_step_refuses_a_nan_joint_state():
    """The lean step's kernel takes the joint's state from its caller; a NaN there stops the
    step with an error, not a silently frozen link."""
    with ProbeScene(ObjectConfig.scissors(), physics="v3") as scene:
        scene.reset(0.0, [0.05, 0.05, 0.1], np.eye(3))
        sel = scene.skin.select(scene._prims, np.eye(3), np.array([0.05, 0.05, 0.1]), 0.001)
        obj = scene.object
        args = dict(
            selection=sel,
            pose=np.concatenate([np.eye(3), [[0.05, 0.05, 0.1]]]),
            motion=np.concatenate([np.eye(3), np.zeros((1, 3))]),
            turning=False,
            step_len=1e-9,
            substeps=12,
            link=obj.link,
            link_row=-1,
            hinge=obj.hinge,
            joint=np.array([0.0, np.nan]),
            link_pose=np.zeros((4, 3)),
            q_selected=0.0,
            link_reach=0.1,
            limit=8.0,
            dt=DT,
            reaction=np.zeros((3, 3)),
            stats=np.zeros(_step_kernels.STATS_COLS),
        )
        with pytest.raises(ValueError, match="joint's angle and velocity must be finite"):
            scene.skin.run(**args)
        args["joint"] = np.zeros(2)
        args["pose"][3, 2] = np.inf
        with pytest.raises(ValueError, match="fingertip's pose and motion must be finite"):
            scene.skin.run(**args)


_DEBUG_RUN = textwrap.dedent(
    """
    import numpy as np
    from tactile_gym import _jit
    from tactile_gym.sim import ObjectConfig, ProbeScene, _kernels

    assert _jit.BOUNDSCHECK
    # The degenerate cases of this file and a press in both steps, all index-checked.
    for physics in ("v2", "v3"):
        with ProbeScene(ObjectConfig.scissors(), physics=physics) as scene:
            ep, ed = scene.edge_line
            g = scene.geometry
            top = ep + 0.05 * ed + [0.0, 0.003, g.outer_radius + g.cylinder_length]
            scene.reset(0.0, top + [0.0, 0.0, 0.001], np.diag([1.0, -1.0, -1.0]))
            for k in range(8):
                scene.control_step(top - [0.0, 0.0, 0.0002 * k], np.diag([1.0, -1.0, -1.0]))
            assert scene.contact.n_active > 0
    # An out-of-range node id is caught, not written past the state arrays.
    prim = np.full(4, -1, dtype=np.int64)
    ids = np.array([[7, 0]], dtype=np.int64)
    try:
        _kernels.commit(
            prim, np.zeros((4, 3)), np.zeros(4), np.zeros((1, 4, 3)), ids, 0, ids,
            np.zeros((1, _kernels.NODE_COLS)), 1, np.zeros((1, _kernels.PRIM_COLS)),
            np.zeros(1, dtype=np.int64),
        )
    except IndexError:
        print("caught")
    # The sensing's and the gate's kernels: contacts on both pieces and both models, a
    # tangent force, a miss, the hold rule's windows and the gate's stillness, all
    # index-checked; a wrench of three numbers, which the checked API refuses before the
    # kernel, is caught inside it too.
    from tactile_gym.perception.gate import _motion
    from tactile_gym.sensing import (
        FingertipGeometry, SensorConfig, TouchSensor, estimate_contact, predicted_edge_std,
    )
    from tactile_gym.sensing.contact import contact_core

    for f, m, kw in (
        ([0.5, -0.3, -5.0], [0.01, 0.02, 0.0005], {}),
        ([-5.0, 0.2, 0.1], [0.0, -0.05, 0.001], {"model": "hard", "skin_stiffness": 8.8e7}),
        ([0.0, 5.0, 0.0], [0.0, 0.0, 0.0], {"contact_shape": "edge", "skin_stiffness": 8.8e7}),
        ([0.0, 0.0, -5.0], [1.0, 1.0, 0.0], {}),
    ):
        estimate_contact(f, m, **kw)
    touch = TouchSensor(FingertipGeometry(), SensorConfig(), 8.8e7)
    window = np.array([0.5, -0.3, -5.0, 0.01, 0.02, 0.0005]) + np.zeros((60, 1))
    for n in (1, 2, 60):
        predicted_edge_std(touch, window[:n])
    _motion(np.eye(3), np.zeros(3), np.eye(3), np.ones(3), np.ones(3))
    try:
        contact_core(np.ones(3), touch._parameters, 1.0)
    except IndexError:
        print("caught")
    """
)


@pytest.mark.slow
def test_kernels_check_their_indices_in_the_debug_build(tmp_path):
    """``TACTILE_GYM_BOUNDSCHECK=1``: the kernels compile with index checks (not cached), a
    press in both steps and the sensing's and gate's kernels run clean, and a bad index
    raises instead of writing past an array. About 25 s of compiling."""
    script = tmp_path / "debug_run.py"
    script.write_text(_DEBUG_RUN)
    test_file = os.path.abspath(__file__)
    env = {**os.environ, "TACTILE_GYM_BOUNDSCHECK": "1", "NUMBA_CACHE_DIR": str(tmp_path)}
    run = subprocess.run(
        [sys.executable, str(script)],
        env=env,
        cwd=os.path.dirname(os.path.dirname(test_file)),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("caught") == 2 and run.stdout.strip().endswith("caught")
