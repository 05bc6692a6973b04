"""The env's frame: its size, its framing, its overlays, and that rendering changes nothing and
reads no ground truth unless asked (``tactile_gym.envs.render``, ``docs/design.md`` 7.10)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pybullet as p
import pytest
from test_ground_truth import audit  # noqa: F401 - the truth-read audit, used as a fixture

from agents.scripted import scripted_policy
from tactile_gym import ENV_IDS
from tactile_gym.envs.render import COLOURS, FORCE_SCALE, Overlay, draw_overlay
from tactile_gym.sim.camera import frame_box

PLANAR, PRIMITIVE = ENV_IDS[0], ENV_IDS[2]
SMALL = {"render_width": 160, "render_height": 120}  # cheap frames where the size is not tested


def _run(env, steps: int, render: bool = False):
    """``steps`` scripted steps after ``reset(seed=5)``; the observations and rewards, and the
    frames when ``render``."""
    policy = scripted_policy(env)
    obs, _ = env.reset(seed=5)
    policy.reset()
    record, frames = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(policy.get_action(obs))
        record.append((obs, reward))
        if render:
            frames.append(env.render())
        if terminated or truncated:
            break
    return record, frames


@pytest.mark.parametrize("env_id", [PLANAR, PRIMITIVE])
def test_frame_size_follows_the_keywords(env_id):
    env = gym.make(env_id, render_mode="rgb_array", render_width=200, render_height=120)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (120, 200, 3) and frame.dtype == np.uint8
    env.close()


@pytest.mark.parametrize("env_id", [PLANAR, PRIMITIVE])
@pytest.mark.parametrize(
    ("field", "value"),
    [("render_width", 0), ("render_height", 2.5), ("render_width", True), ("render_truth", "yes")],
)
def test_bad_render_keywords_name_the_field(env_id, field, value):
    with pytest.raises(ValueError, match=field):
        gym.make(env_id, render_mode="rgb_array", **{field: value})


def test_the_object_fills_the_frame_and_projection_matches_pybullet():
    env = gym.make(PLANAR, render_mode="rgb_array", render_width=160, render_height=120)
    env.reset(seed=1)
    scene = env.unwrapped.scene
    image, camera = scene.render(160, 120)
    # PyBullet's own segmentation with the camera's matrices says where the object is.
    seg = np.asarray(
        p.getCameraImage(
            160,
            120,
            camera.view_list,
            camera.projection_list,
            renderer=p.ER_TINY_RENDERER,
            physicsClientId=scene.world.client_id,
        )[4]
    ).reshape(120, 160)
    body = scene.object.body_id
    rows, cols = np.nonzero(seg == body)
    assert np.ptp(cols) > 0.6 * 160 or np.ptp(rows) > 0.6 * 120  # fills most of the frame
    # The projection of the fixed link's centre lands on the object.
    pixels, in_front = camera.project(scene.object.fixed_box.center)
    x, y = pixels[0]
    assert in_front[0] and seg[int(y), int(x)] == body
    env.close()


def test_overlays_are_drawn_where_the_projection_says():
    camera = frame_box([0.0, 0.0, 0.0], [0.1, 0.05, 0.02], 320, 240)
    blank = np.zeros((240, 320, 3), dtype=np.uint8)
    centre = camera.target
    overlay = Overlay(
        step=3,
        force=np.array([0.0, 0.0, 4.0]),
        force_origin=centre + [0.03, 0.0, 0.0],
        points=np.array([centre - [0.03, 0.0, 0.0]]),
        edges=np.array([[0.0, 1.0, 0.0]]),
        axis=(centre + [0.0, 0.0, 0.5], np.array([0.0, 0.0, 1.0])),
        true_axis=(centre + [0.0, 0.02, 0.0], np.array([1.0, 0.0, 0.0])),
    )
    frame = draw_overlay(blank, camera, overlay)
    assert not blank.any()  # the input is left as it was

    def colours_at(point):
        """The colours within a pixel of where ``point`` projects."""
        pixels, in_front = camera.project(point)
        x, y = pixels[0].astype(int)
        assert in_front[0] and 1 <= x < 319 and 1 <= y < 239
        return {tuple(c) for c in frame[y - 1 : y + 2, x - 1 : x + 2].reshape(-1, 3)}

    # The estimated axis is drawn through its point nearest the target, i.e. the target.
    assert COLOURS["estimate"] in colours_at(centre)
    assert COLOURS["measurement"] in colours_at(overlay.points[0])
    assert COLOURS["measurement"] in colours_at(overlay.points[0] + [0.0, 0.008, 0.0])  # edge
    assert COLOURS["truth"] in colours_at(overlay.true_axis[0] - [0.015, 0.0, 0.0])
    arrow_middle = overlay.force_origin + 0.5 * FORCE_SCALE * overlay.force
    assert COLOURS["force"] in colours_at(arrow_middle)
    without_truth = draw_overlay(blank, camera, Overlay(**{**vars(overlay), "true_axis": None}))
    assert not np.all(without_truth == COLOURS["truth"], axis=-1).any()
    assert np.all(frame == COLOURS["truth"], axis=-1).any()


@pytest.mark.parametrize("env_id", [PLANAR, PRIMITIVE])
def test_rendering_does_not_change_a_rollout(env_id):
    steps = 40 if env_id == PLANAR else 3
    plain, _ = _run(gym.make(env_id, max_steps=200), steps)
    env = gym.make(env_id, max_steps=200, render_mode="rgb_array", **SMALL)
    rendered, frames = _run(env, steps, render=True)
    assert len(plain) == len(rendered) and frames and frames[-1].std() > 0
    for (obs_a, reward_a), (obs_b, reward_b) in zip(plain[1:], rendered[1:]):
        assert obs_a.keys() == obs_b.keys() and reward_a == reward_b
        for key in obs_a:
            np.testing.assert_array_equal(obs_a[key], obs_b[key])


@pytest.mark.parametrize("render_truth", [False, True])
def test_render_reads_truth_only_when_asked(audit, render_truth):  # noqa: F811 - fixture
    violations, reads = audit
    env = gym.make(PLANAR, render_mode="rgb_array", render_truth=render_truth, **SMALL)
    _run(env, 40)
    assert env.unwrapped.measurements  # the frame has measurements to draw
    reads.clear()
    env.render()
    if render_truth:
        assert reads == ["true_axis <- _true_axis_for_render"]
    else:
        assert reads == []
    assert violations == []
    env.close()
