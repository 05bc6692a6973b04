"""World, hinged objects and configs: construction, isolation, save/restore, holding friction."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from tactile_gym import sensing
from tactile_gym.sim import HingedObject, ObjectConfig, SensorConfig, World
from tactile_gym.sim.config import FAMILIES, family_joint_type


def world_aabb(box) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounding box of a RoundedBox in the world frame: (lower, upper), m."""
    ext = np.abs(box.rotation) @ box.half_extents
    return box.center - ext, box.center + ext


def test_close_twice_and_isolation():
    a, b = World(), World()
    assert a.client_id != b.client_id
    HingedObject(a, ObjectConfig.scissors())
    assert p.getNumBodies(physicsClientId=a.client_id) == 2
    assert p.getNumBodies(physicsClientId=b.client_id) == 1  # only its table
    a.close()
    a.close()
    assert not a.connected
    with pytest.raises(RuntimeError):
        a.step()
    b.step()
    b.close()


def test_save_restore_state():
    w = World()
    o = HingedObject(w, ObjectConfig.scissors(holding_torque=0.0, damping=0.0))
    sid = w.save_state()
    for _ in range(20):
        o.apply_wrench(np.zeros(3), 0.01 * o.axis)
        w.step()
    o.sync()
    assert o.joint_angle > 0.01
    w.restore_state(sid)
    o.sync()
    assert o.joint_angle == pytest.approx(0.0, abs=1e-12)
    w.close()


@pytest.mark.parametrize("family", [f for f in FAMILIES if family_joint_type(f) == "revolute"])
def test_families_geometry_matches_pybullet(family):
    cfg = ObjectConfig.family_default(family)
    w = World()
    o = HingedObject(w, cfg, joint_angle=0.4)
    lo, hi = p.getAABB(o.body_id, 0, physicsClientId=w.client_id)
    mlo, mhi = world_aabb(o.free_box)
    np.testing.assert_allclose(lo, mlo, atol=1e-6)
    np.testing.assert_allclose(hi, mhi, atol=1e-6)
    pin, u = o.true_axis
    assert np.linalg.norm(u) == pytest.approx(1.0)
    assert o.joint_angle == pytest.approx(0.4)

    # Turning about the true axis keeps the edge line's distance from the pin.
    def pin_to_edge() -> float:
        ep, ed = o.edge_line
        v = pin - ep
        return float(np.linalg.norm(v - (v @ ed) * ed))

    d0 = pin_to_edge()
    o.reset(-0.005 if family == "lid" else -0.3)
    assert pin_to_edge() == pytest.approx(d0, abs=1e-9)
    w.close()


def test_sensor_config_is_the_sensing_one():
    # One definition of the F/T noise defaults; the simulator re-exports it.
    assert SensorConfig is sensing.SensorConfig


def _apply_for(w, o, force, point, seconds):
    for _ in range(int(seconds / w.time_step)):
        p.applyExternalForce(
            o.body_id, 0, list(force), list(point), p.WORLD_FRAME, physicsClientId=w.client_id
        )
        w.step()
    o.sync()


def test_holding_friction_resists_a_press_but_not_a_push():
    """docs/design.md 3.3: a 5 N press mostly along -z on the rim holds, a push turns it."""
    w = World()
    cfg = ObjectConfig.scissors()
    o = HingedObject(w, cfg)
    ep, ed = o.edge_line
    rim = ep + 0.08 * ed
    press = np.array([0.0, 0.8, -5.0])  # 9 degrees off vertical, toward the link
    _apply_for(w, o, press, rim, 0.5)
    assert abs(np.rad2deg(o.joint_angle)) < 0.2
    mid = o.pin + 0.045 * ed + np.array([0.0, -0.01, 0.0])
    _apply_for(w, o, np.array([0.0, 3.0, 0.0]), mid, 0.5)
    assert np.rad2deg(o.joint_angle) > 10.0
    w.close()
