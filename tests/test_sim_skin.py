"""Physical validation of the Winkler skin: force-indentation, friction, wrench bookkeeping."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from tactile_gym.sim import (
    ObjectConfig,
    ProbeScene,
    SkinConfig,
    _kernels,
    _pose_kernels,
    _step_kernels,
)
from tactile_gym.sim.scene import PHYSICS
from tactile_gym.spatial import rotation_z, rotvec_to_matrix

DOWN = np.array([1.0, 0.0, 0.0, 0.0])  # sensor z along world -z
FAR = np.array([0.25, -0.15])  # table spot far from the object, m


@pytest.fixture(scope="module", params=PHYSICS)
def scene(request):
    s = ProbeScene(ObjectConfig.scissors(), physics=request.param)
    yield s
    s.close()


def _tip_height(scene) -> float:
    g = scene.geometry
    return g.cylinder_length + g.outer_radius


def _press_table(scene, depth: float, steps: int = 10) -> None:
    top = _tip_height(scene)
    scene.reset(0.0, [*FAR, top + 0.001], DOWN)
    for k in range(1, steps + 1):
        z = top + 0.001 - (0.001 + depth) * k / steps
        scene.control_step([*FAR, z], DOWN)
    scene.control_step([*FAR, top - depth], DOWN)  # hold: no damping left


@pytest.mark.parametrize("depth", [0.0005, 0.001, 0.0013])
def test_force_indentation_matches_winkler_integral(scene, depth):
    """Sphere pressed on a plane: F = k_n * integral(delta dA) = pi R k_n D^2."""
    _press_table(scene, depth)
    info_force = scene.true_wrench[:3]
    k_n = scene.skin_config.normal_stiffness
    analytic = np.pi * scene.geometry.outer_radius * k_n * depth**2
    # On the skin, the table pushes along world +z, i.e. sensor -z.
    assert -info_force[2] == pytest.approx(analytic, rel=0.05)
    assert np.linalg.norm(info_force[:2]) < 1e-6 * analytic
    assert not scene.contact.n_active == 0


def test_friction_sliding_ratio_is_mu_and_small_shear_sticks(scene):
    depth = 0.001
    _press_table(scene, depth)
    top = _tip_height(scene)
    mu = scene.skin_config.friction
    fn0 = -scene.true_wrench[2]
    area = scene.skin.areas[scene.contact.nodes].sum()
    # Small shear: sticks; the traction is the tangential spring, below mu * normal.
    shift = 2e-5
    scene.control_step([FAR[0] + shift, FAR[1], top - depth], DOWN)
    scene.control_step([FAR[0] + shift, FAR[1], top - depth], DOWN)
    ft = np.linalg.norm(scene.true_wrench[:2])
    assert ft < 0.5 * mu * fn0
    assert ft == pytest.approx(scene.skin_config.k_t * area * shift, rel=0.15)
    # Sliding 5 mm: the ratio tends to mu.
    ratios = []
    for k in range(1, 21):
        scene.control_step([FAR[0] + shift + 0.00025 * k, FAR[1], top - depth], DOWN)
        w = scene.true_wrench
        ratios.append(np.linalg.norm(w[:2]) / -w[2])
    assert np.mean(ratios[-5:]) == pytest.approx(mu, rel=0.03)
    assert max(ratios) <= mu * 1.05


def test_wrench_is_sum_of_node_forces_and_matches_reaction(scene):
    ep, ed = scene.edge_line
    g = scene.geometry
    n = np.array([0.0, -np.sin(0.3), np.cos(0.3)])
    c = ep + 0.05 * ed + (g.outer_radius - 0.0015) * n
    quat_axis = -n
    x = np.array([1.0, 0.0, 0.0])
    y = np.cross(quat_axis, x)
    from tactile_gym.spatial import matrix_to_quaternion

    q = matrix_to_quaternion(np.column_stack([x, y, quat_axis]))
    scene.reset(0.0, c - g.cylinder_length * quat_axis, q)
    info = scene.control_step(c - g.cylinder_length * quat_axis + [0, -0.0003, 0], q)
    assert info.n_active_nodes > 10
    contact = scene.contact
    f = contact.forces_sensor()
    r = contact.points_sensor()
    w = scene.true_wrench
    np.testing.assert_allclose(w[:3], f.sum(0), atol=1e-9)
    np.testing.assert_allclose(w[3:], np.cross(r, f).sum(0), atol=1e-11)
    # Newton's third law: the reaction on the free link is minus the skin's wrench.
    force, torque, com = scene.last_reaction
    f_world = scene.sensor_to_world_vector(w[:3])
    m_world = scene.sensor_to_world_vector(w[3:])  # about the sensor origin
    np.testing.assert_allclose(force, -f_world, atol=1e-9)
    p0 = scene.fingertip_position
    np.testing.assert_allclose(torque + np.cross(com - p0, force), -m_world, atol=1e-10)


def test_shell_contact_is_flagged(scene):
    top = _tip_height(scene)
    scene.reset(0.0, [*FAR, top - 0.006], DOWN)  # deeper than the 5 mm skin
    info = scene.control_step([*FAR, top - 0.006], DOWN)
    assert info.shell_contact
    assert info.max_penetration > scene.geometry.skin_thickness


def test_guarded_move_stops_at_force_limit(scene):
    top = _tip_height(scene)
    scene.reset(0.0, [*FAR, top + 0.001], DOWN)
    limited = False
    for _ in range(20):
        info = scene.control_step([*FAR, top - 0.004], DOWN)
        limited |= info.force_limited
        assert info.max_force <= scene.force_limit + 1e-9
    assert limited
    assert np.linalg.norm(scene.true_wrench[:3]) > 0.75 * scene.force_limit
    # Retreat is allowed.
    scene.control_step([*FAR, top + 0.01], DOWN)
    assert scene.fingertip_position[2] > top - 0.004 + 0.001


def test_read_wrench_uses_only_the_given_generator(scene):
    _press_table(scene, 0.001, steps=4)
    state = np.random.get_state()  # noqa: NPY002 - checking the global one stays untouched
    a = scene.read_wrench(np.random.default_rng(3))
    b = scene.read_wrench(np.random.default_rng(3))
    assert np.random.get_state()[1].tolist() == state[1].tolist()  # noqa: NPY002
    np.testing.assert_array_equal(a, b)
    noise = np.array([scene.read_wrench(np.random.default_rng(i)) for i in range(400)])
    noise -= scene.true_wrench
    assert noise[:, :3].std() == pytest.approx(scene.sensor_config.force_noise_std, rel=0.15)
    assert noise[:, 3:].std() == pytest.approx(scene.sensor_config.moment_noise_std, rel=0.15)


def test_default_spacing_is_fine_enough():
    assert SkinConfig().node_spacing <= 0.0007


def test_reaction_is_consistent_and_contact_views_match(scene):
    """prim_wrench sums to the wrench; the per-node views are those of the kernel's output."""
    _press_table(scene, 0.001, steps=4)
    c = scene.contact
    np.testing.assert_allclose(sum(c.prim_wrench.values()), c.wrench, atol=1e-12)
    assert c.force_norm == pytest.approx(np.linalg.norm(c.wrench[:3]), rel=1e-12)
    assert c.max_penetration == c.delta.max()
    assert c.local.shape == c.normal.shape == c.anchor.shape == (3, c.n_active)
    np.testing.assert_allclose(c.point_local, c.local + c.delta * c.normal, atol=1e-15)
    assert c.reaction(0) is None  # the free link is not touched on the table
    assert not c.shell_contact


def _press_in_worker(depth: float, physics: str) -> np.ndarray:
    with ProbeScene(ObjectConfig.scissors(), physics=physics) as s:
        _press_table(s, depth, steps=4)
        return s.true_wrench


def test_kernels_compile_once_and_work_in_spawned_workers(scene):
    """Stable argument types: one compiled signature per kernel; a spawned process (as in an
    async vector env) gets the same wrench."""
    _press_table(scene, 0.001, steps=4)
    for kernel in (_kernels.select, _kernels.evaluate, _kernels.commit):
        assert len(kernel.signatures) == 1, kernel
    step = _kernels.substep if scene.physics == "v2" else _step_kernels.control_step
    assert len(step.signatures) == 1
    compiled_when_needed = (
        _pose_kernels.advance,
        _pose_kernels.link_pose,
        _step_kernels.narrow,
        _step_kernels.hinge_step,
    )
    for kernel in compiled_when_needed:
        assert len(kernel.signatures) <= 1, kernel
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(1) as pool:
        remote = pool.apply(_press_in_worker, (0.001, scene.physics))
    np.testing.assert_array_equal(remote, _press_in_worker(0.001, scene.physics))


@pytest.mark.parametrize("keys", ["spread", "rounded", "equal", "empty"])
def test_broad_phase_order_is_numpys_stable_argsort(keys):
    """The broad phase's candidate order (which sets the order of the force sums) is the
    stable sort's, ties in index order, also with many equal distances."""
    rng = np.random.default_rng(5)
    n = 0 if keys == "empty" else 1500
    values = {
        "spread": rng.normal(0.0, 1e-3, n),
        "rounded": np.round(rng.normal(0.0, 1e-3, n), 4),
        "equal": np.full(n, 2e-3),
        "empty": np.zeros(0),
    }[keys]
    padded = np.concatenate([values, rng.normal(size=7)])  # only the first n count
    np.testing.assert_array_equal(
        _kernels.stable_order(padded, n), np.argsort(values, kind="stable")
    )


def test_substep_pose_arithmetic_is_numpys_to_the_bit():
    """The compiled substep poses the free link (H @ Rz(q), pin + R c) and turns the fingertip
    (step_R @ R) with the very bits of the NumPy products it replaced: a last-bit difference
    grows through the joint's stick-slip friction into a different trajectory
    (docs/design.md 3.5)."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        hinge = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        pin, centre = rng.normal(size=3), rng.normal(size=3)
        angle = rng.uniform(-3.0, 3.0)
        pose = _pose_kernels.link_pose(np.concatenate([hinge, [pin, centre]]), angle)
        rotation = hinge @ rotation_z(angle)
        np.testing.assert_array_equal(pose[:3], rotation)
        np.testing.assert_array_equal(pose[3], pin + rotation @ centre)
        tip = np.concatenate([np.linalg.qr(rng.normal(size=(3, 3)))[0], [rng.normal(size=3)]])
        step = np.concatenate([rotvec_to_matrix(rng.normal(0.0, 0.01, 3)), [rng.normal(size=3)]])
        moved = tip.copy()
        _pose_kernels.advance(moved, step, True, 1)
        np.testing.assert_array_equal(moved[:3], step[:3] @ tip[:3])
        np.testing.assert_array_equal(moved[3], tip[3] + step[3])


def test_a_narrowed_broad_phase_is_the_fresh_one():
    """``SoftSkin.narrow`` (the v3 step's broad phase, made again from its own candidates after
    the fingertip moved s) finds what ``select`` finds afresh with the reach less s: the same
    candidates, distances and order."""
    with ProbeScene(ObjectConfig.scissors()) as s:
        skin, prims = s.skin, s._prims
        ep, ed = s.edge_line
        g = s.geometry
        start = ep + 0.05 * ed + [0.0, 0.003, g.outer_radius + g.cylinder_length + 0.001]
        rotation = np.diag([1.0, -1.0, -1.0])
        sel = skin.select(prims, rotation, start, 0.004)
        moved = 0.0015
        after = start + moved * np.array([0.6, 0.0, -0.8])
        narrowed = skin.narrow(sel, prims, rotation, after, sel.reach - moved)
        fresh = skin.select(prims, rotation, after, sel.reach - moved - skin.config.margin)
        assert 100 < len(narrowed.nodes) < len(sel.nodes)
        np.testing.assert_array_equal(narrowed.nodes, fresh.nodes)
        np.testing.assert_array_equal(narrowed.distance, fresh.distance)
        np.testing.assert_array_equal(narrowed.points, fresh.points)
