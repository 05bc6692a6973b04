"""The v3 step's hinge (``_step_kernels.hinge_step``) against PyBullet, which integrates the
joint in the v2 step, and against closed forms (docs/design.md 3.6)."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from tactile_gym.sim import ObjectConfig, _pose_kernels, _step_kernels
from tactile_gym.sim.objects import HingedObject
from tactile_gym.sim.world import World


def _torques(seed: int, holding: float, n: int) -> np.ndarray:
    """About the joint axis, N m: a slow swing through the holding torque (sticking and
    slipping) with noise, and pauses."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    torque = 1.1 * holding * np.sin(k / 20.0) + 0.2 * holding * rng.standard_normal(n)
    torque[(k % 400) > 300] = 0.0
    return torque


@pytest.mark.parametrize("family", ["scissors", "door", "tilted"])
def test_hinge_follows_pybullet_away_from_the_limits(family):
    """Torques through the holding friction, for 2000 steps: PyBullet's joint angle and
    velocity to rounding (gravity turns the tilted link too). The torque is applied as a
    torque: a force at a point is the same torque in the v3 step, but PyBullet takes the lever
    from the link's pose one step back (docs/design.md 3.6)."""
    with World() as world:
        obj = HingedObject(world, ObjectConfig.family_default(family), 0.0)
        cid, axis = world.client_id, obj.axis
        joint = np.zeros(2)
        angles = []
        for torque in _torques(0, obj.config.holding_torque, 2000):
            p.applyExternalTorque(
                obj.body_id, 0, (torque * axis).tolist(), p.WORLD_FRAME, physicsClientId=cid
            )
            p.stepSimulation(physicsClientId=cid)
            pose = _pose_kernels.link_pose(obj.link, joint[0])
            _step_kernels.hinge_step(obj.hinge, obj.link, pose, joint, torque, world.time_step)
            obj.sync()
            np.testing.assert_allclose(joint, [obj.joint_angle, obj.joint_velocity], atol=1e-11)
            angles.append(joint[0])
    lo, hi = obj.config.lower_limit, obj.config.upper_limit
    assert lo < min(angles) < max(angles) < hi  # away from the limits ...
    assert np.ptp(angles) > 0.3  # ... and it turned, stuck and slipped


def test_hinge_holds_below_the_holding_torque():
    """A torque below the holding friction never moves the link, to the bit."""
    config = ObjectConfig.scissors()
    with World() as world:
        obj = HingedObject(world, config, 0.2)
    joint = np.array([0.2, 0.0])
    pose = _pose_kernels.link_pose(obj.link, 0.2)
    for torque in np.linspace(-0.99, 0.99, 50) * config.holding_torque:
        _step_kernels.hinge_step(obj.hinge, obj.link, pose, joint, torque, 1.0 / 240.0)
        assert joint.tolist() == [0.2, 0.0]


def test_hinge_slips_at_the_closed_form_rate():
    """A constant torque tau above the holding torque h, from rest, with viscous damping d:
    I dv/dt = tau - h - d v, so the link slips at (tau - h) / d once the transient (I / d,
    12 ms here) has passed."""
    config = ObjectConfig.scissors(damping=0.01)
    with World() as world:
        obj = HingedObject(world, config, 0.0)
    tau = 1.5 * config.holding_torque
    joint = np.zeros(2)
    for _ in range(24):  # 0.1 s
        pose = _pose_kernels.link_pose(obj.link, joint[0])
        _step_kernels.hinge_step(obj.hinge, obj.link, pose, joint, tau, 1.0 / 240.0)
    assert joint[1] == pytest.approx((tau - config.holding_torque) / config.damping, rel=1e-3)
    assert 0.0 < joint[0] < config.upper_limit


def test_lid_stops_at_its_limit():
    """Pressed shut, the lid stops at its lower limit and stays there at rest: a hard stop
    (PyBullet's limit lets it sink in and pushes it back over several steps)."""
    config = ObjectConfig.lid()
    with World() as world:
        obj = HingedObject(world, config, 0.0)
    joint = np.zeros(2)
    for _ in range(100):
        pose = _pose_kernels.link_pose(obj.link, joint[0])
        _step_kernels.hinge_step(obj.hinge, obj.link, pose, joint, -0.5, 1.0 / 240.0)
    assert joint.tolist() == [config.lower_limit, 0.0]


def test_axial_torque_is_the_reactions_moment_about_the_axis():
    rng = np.random.default_rng(1)
    with World() as world:
        obj = HingedObject(world, ObjectConfig.tilted(), 0.0)
    for _ in range(50):
        reaction = rng.normal(size=(3, 3))
        moment = reaction[1] + np.cross(reaction[2] - obj.pin, reaction[0])
        assert _step_kernels.axial_torque(obj.link, reaction) == pytest.approx(
            moment @ obj.axis, abs=1e-12
        )
