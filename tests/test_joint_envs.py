"""The joint ids (docs/design.md 7.12): families, bad input, the task's error, the pipeline's
labels from the stream alone, and the scripted baseline."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym
from agents.joint_scripted import joint_policy
from agents.scripted import scripted_policy
from tactile_gym.envs.joint_config import JointProbeConfig
from tactile_gym.envs.joint_task import JointStepFacts, JointTypeTask
from tactile_gym.envs.task import TaskConfig
from tactile_gym.estimation import JOINT_TYPES, OUTCOMES, JointTypeEstimator
from tactile_gym.perception import JointPipeline, LabelConfig, Sample
from tactile_gym.sensing import FingertipGeometry

PLANAR, SPATIAL = (e for e in tactile_gym.JOINT_ENV_IDS if "Primitive" in e)


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("env_id", ["tactile_gym/HingeProbe-v2", tactile_gym.JOINT_ENV_IDS[0]])
def test_an_unknown_family_names_itself_and_the_allowed_ones(env_id):
    with pytest.raises(ValueError, match=r"families.*'drawr'") as error:
        gym.make(env_id, families=("scissors", "drawr"))
    assert "scissors" in str(error.value)


def test_a_family_of_another_joint_is_refused_by_the_hinge_ids():
    for family in ("slider", "drawer", "tilted_drawer", "block"):
        with pytest.raises(ValueError, match=f"'{family}' has a .* joint.*revolute"):
            gym.make("tactile_gym/HingeProbe3D-v2", families=(family,))


def test_the_planar_joint_id_refuses_families_off_the_table():
    with pytest.raises(ValueError, match="planar"):
        gym.make("tactile_gym/JointProbe-v0", families=("drawer",))
    with pytest.raises(ValueError, match="joint_prior"):
        JointProbeConfig(joint_prior={"axis": None})
    with pytest.raises(ValueError, match="reward_source"):
        JointProbeConfig(task={"reward_source": "predicted"})


@pytest.mark.parametrize("env_id", tactile_gym.JOINT_ENV_IDS)
def test_each_reset_draws_a_family_of_the_id_and_says_its_type(env_id):
    env = gym.make(env_id, max_steps=5)
    families = set(gym.spec(env_id).kwargs["families"])
    seen = {}
    for seed in range(40):
        _, info = env.reset(seed=seed)
        config = env.unwrapped.scene.object_config
        assert config.family in families
        seen[config.family] = int(info["joint_type"])
    env.close()
    assert set(seen) == families
    expected = {"scissors": 1, "door": 1, "tilted": 1, "slider": 2, "drawer": 2}
    expected |= {"tilted_drawer": 2, "block": 0}
    assert all(seen[f] == expected[f] for f in seen)


def test_the_start_pose_does_not_tell_the_types_apart():
    """Over the reset distribution, the fingertip's start height has the same range for every
    family of the 3D id (the probed edge's height is drawn for all), and the planar id's
    families all lie on the table."""
    for env_id in ("tactile_gym/JointProbe3D-v0", "tactile_gym/JointProbe-v0"):
        env = gym.make(env_id, max_steps=5)
        heights: dict[str, list[float]] = {}
        for seed in range(60):
            obs, _ = env.reset(seed=seed)
            family = env.unwrapped.scene.object_config.family
            heights.setdefault(family, []).append(float(obs["fingertip_pose"][2]))
        env.close()
        lows = [min(h) for h in heights.values()]
        highs = [max(h) for h in heights.values()]
        spread = 0.1 if "3D" in env_id else 0.01
        assert max(lows) - min(lows) < spread and max(highs) - min(highs) < spread, heights


# --------------------------------------------------------------------------- the task


def _facts(joint_type: str, p_true: float, position: float, angle: float) -> JointStepFacts:
    probabilities = np.full(len(OUTCOMES), (1.0 - p_true) / (len(OUTCOMES) - 1))
    probabilities[OUTCOMES.index(joint_type)] = p_true
    return JointStepFacts(
        position_error=position,
        angle_error=angle,
        max_force=0.0,
        force_limit=8.0,
        shell_contact=False,
        hinge_distance=0.05,
        action=np.zeros(7),
        measurements=3,
        joint_type=joint_type,
        type_probabilities=probabilities,
    )


def test_the_joint_error_includes_the_type_and_confidence_in_a_wrong_one_costs():
    task = JointTypeTask(TaskConfig())
    cap, scale = task.config.error_cap, task.config.error_angle_scale
    # E = (1 - p) E_max + p E_params, the axis task's E for a hinge, L times the direction
    # error for a slide, 0 for a rigid link.
    facts = _facts("revolute", 0.8, 0.003, 0.02)
    assert task.joint_error(facts) == pytest.approx(0.2 * cap + 0.8 * (0.003 + scale * 0.02))
    assert task.joint_error(_facts("prismatic", 0.5, 0.0, 0.1)) == pytest.approx(
        0.5 * cap + 0.5 * scale * 0.1
    )
    assert task.joint_error(_facts("rigid", 1.0, 0.0, 0.0)) == 0.0
    # Never lower for less confidence in the truth, whatever the parameters' errors: a wrong
    # type held confidently costs nearly the cap, exact parameters or not.
    for params in ((0.0, 0.0), (0.05, 0.3), (1.0, 3.0)):
        errors = [task.joint_error(_facts("revolute", p, *params)) for p in np.linspace(0, 1, 11)]
        assert np.all(np.diff(errors) <= 1e-15)
        assert errors[0] == pytest.approx(cap)


def test_a_tie_is_not_a_correct_type_and_success_needs_the_type():
    task = JointTypeTask(TaskConfig())
    uniform = JointStepFacts(**{**_facts("rigid", 0.33, 0.0, 0.0).__dict__})
    tie = np.array([0.33, 0.33, 0.33, 0.01])
    object.__setattr__(uniform, "type_probabilities", tie)
    info = task.info(uniform)
    assert not info["type_correct"] and not info["is_success"]
    info = task.info(_facts("prismatic", 0.95, 0.0, np.radians(1.0)))
    assert info["type_correct"] and info["is_success"] and info["joint_type"] == 2
    info = task.info(_facts("prismatic", 0.2, 0.0, np.radians(1.0)))
    assert not info["is_success"]


@pytest.mark.parametrize("env_id", [PLANAR, SPATIAL])
def test_info_says_the_true_types_errors_and_e(env_id):
    env = gym.make(env_id, max_primitives=6)
    policy = joint_policy(env)
    obs, info = env.reset(seed=11)
    policy.reset()
    task = env.unwrapped.control_env.task
    total = 0.0
    first = info["joint_error"]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy.get_action(obs))
        total += info["reward_error_reduction"]
        done = terminated or truncated
        joint = JOINT_TYPES[int(info["joint_type"])]
        if joint != "revolute":
            assert info["position_error"] == 0.0
        if joint == "rigid":
            assert info["angle_error"] == 0.0
        facts = _facts(joint, 0.0, float(info["position_error"]), float(info["angle_error"]))
        object.__setattr__(facts, "type_probabilities", info["type_probabilities"])
        assert info["joint_error"] == pytest.approx(task.joint_error(facts))
    # The return's error reduction telescopes to the error removed from the prior's.
    assert total == pytest.approx((first - info["joint_error"]) / task.config.error_scale)
    env.close()


def test_the_v1_faces_are_at_least_17_mm_wide_and_v0_keeps_its_own():
    """v1 widens the faces narrower than a contact patch (docs/design.md 7.12): the door and
    its frame, the slider's rail; v0 keeps its objects."""
    widths = {"door": lambda c: (c.free_link_size[1], c.fixed_link_size[1]),
              "slider": lambda c: (c.fixed_link_size[0],)}  # fmt: skip
    for name, family in (("JointProbe3D", "door"), ("JointProbe", "slider")):
        for version, wide in (("v1", True), ("v0", False)):
            env = gym.make(f"tactile_gym/{name}-{version}", families=(family,))
            env.reset(seed=0)
            face = min(widths[family](env.unwrapped.scene.object_config))
            assert (face >= 0.017) if wide else (face <= 0.010), (name, version, face)
            env.close()


# --------------------------------------------------------------------------- labels


def test_a_drag_starts_a_configuration_and_a_press_does_not():
    env = gym.make(PLANAR, families=("slider",))
    env.reset(seed=3)
    pipeline = env.unwrapped.pipeline
    for action in ([-1.0, 0.0, 0.0], [-1.0, 0.05, 0.0], [-1.0, 0.0, 0.0]):
        env.step(np.array(action, np.float32))
    assert pipeline.configuration == 0
    env.step(np.array([1.0, 0.8, 0.0], np.float32))  # a 16 mm drag across the edge
    assert pipeline.configuration == 1
    env.close()


def _replay(samples, config: JointProbeConfig) -> JointPipeline:
    """A pipeline built from the env's configuration alone, fed a log of samples."""
    pipeline = config.pipeline(FingertipGeometry())
    pipeline.reset(samples[0])
    for sample in samples[1:]:
        pipeline.step(sample)
    return pipeline


def test_the_labels_come_from_the_stream_alone():
    """A robot's log of the same samples gets the same labels and the same estimate: the
    labels are made from readings and poses, as the env hands them to the pipeline."""
    env = gym.make(PLANAR, families=("slider",), max_primitives=24)
    samples = []
    env.unwrapped.pipeline.recorder = samples.append
    policy = joint_policy(env)
    obs, _ = env.reset(seed=5)
    policy.reset()
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy.get_action(obs))
        done = terminated or truncated
    live = env.unwrapped.pipeline
    replayed = _replay(samples, env.unwrapped.control_env.config)
    assert live.configuration >= 2 and len(live.lines) >= 2
    assert replayed.measurement_labels == live.measurement_labels
    np.testing.assert_allclose(
        replayed.joint_estimate.probabilities, live.joint_estimate.probabilities, atol=1e-9
    )
    env.close()


def test_the_same_edge_test_keeps_a_corner_out_of_a_line():
    """At a configuration where A and B were both pressed at 90 deg, a press 30 deg off B
    (a corner's false edge) does not join B, nor a press parallel to A 10 mm off it A."""
    pipeline = _replay_stub()
    from tactile_gym.perception.gate import Measurement

    def m(point, edge):
        e = np.asarray(edge, float) / np.linalg.norm(edge)
        return Measurement(np.asarray(point, float), e, 1e-3, np.radians(1.5), np.eye(3) * 1e-4)

    a, b = m([0, 0, 0], [1, 0, 0]), m([0.02, 0.01, 0], [0, 1, 0])
    for config in (0, 1):
        pipeline.configuration = config
        pipeline._admit(a)
        pipeline._admit(b)
    pipeline.configuration = 2
    pipeline._admit(a)
    corner = m([0.02, 0.01, 0], [-np.sin(np.radians(30)), np.cos(np.radians(30)), 0])
    assert pipeline._line_of(corner) is None
    assert pipeline._line_of(m([0.01, 0.0, 0], [1, 0.01, 0])).label == 0
    assert pipeline._line_of(m([0.01, 0.01, 0], [1, 0.0, 0])) is None  # parallel, 10 mm off
    assert pipeline._line_of(m([0.02, 0.03, 0], [0.01, 1, 0])).label == 1


def _replay_stub(labels: LabelConfig = LabelConfig()) -> JointPipeline:  # noqa: B008
    config = JointProbeConfig(physics="v3")
    pipeline = JointPipeline(
        FingertipGeometry(),
        config.sensor_config,
        config.skin_config.normal_stiffness,
        config.gate_config,
        JointTypeEstimator("planar"),
        labels,
    )
    pipeline.reset(Sample(0.0, np.zeros(6), np.array([0, 0, 0.1]), np.eye(3), tare=True))
    return pipeline


def _press(point, edge):
    """A measurement of 1.5 deg and 1 mm."""
    from tactile_gym.perception.gate import Measurement

    e, std = np.asarray(edge, float) / np.linalg.norm(edge), np.radians(1.5)
    return Measurement(np.asarray(point, float), e, 1e-3, std, np.eye(3) * std**2 / 2)


def _turned(degrees: float) -> list[float]:
    return [np.cos(np.radians(degrees)), np.sin(np.radians(degrees)), 0.0]


def test_a_press_is_held_until_a_press_along_its_line_agrees():
    """With ``confirm_spacing`` a press enters once a second one at least that far along its
    line agrees with the chord between them; a corner's false edge (15 deg off the edge it
    lies beside) never finds one, and the presses that do enter together. Without it (v0)
    every press enters at once."""
    assert [len(_replay_stub()._admit(_press([0, 0, 0], [1, 0, 0]))) for _ in range(2)] == [1, 1]
    pipeline = _replay_stub(LabelConfig(confirm_spacing=0.006))
    corner = _press([0.0, 0.0, 0.0], _turned(15.0))
    assert pipeline._admit(corner) == ()
    assert pipeline.gate.last_rule == "unconfirmed"
    near = _press([0.003, 0.0, 0.0], [1, 0, 0])  # agrees, but only 3 mm along
    assert pipeline._admit(near) == ()
    good = _press([0.012, 0.0002, 0.0], _turned(1.0))  # the chord to the corner: 15 deg off
    entered = pipeline._admit(good)
    assert [m is p for m, p in zip(entered, (near, good), strict=True)] == [True, True]
    assert len(pipeline.measurement_labels) == 2
    assert pipeline.estimator.n_measurements == 2
    # On a line that took a press at this configuration, a press that lies on it enters.
    assert len(pipeline._admit(_press([0.02, 0.0, 0.0], [1, 0, 0]))) == 1


def test_a_held_press_that_enters_is_recorded_as_accepted():
    """The pipeline's press records: a held press reads ``unconfirmed`` until its partner
    comes, then accepted; the measurements and the perceived acceptance name both."""
    pipeline = _replay_stub(LabelConfig(confirm_spacing=0.006))
    first, second = _press([0, 0, 0], [1, 0, 0]), _press([0.01, 0, 0], [1, 0, 0])
    for m in (first, second):
        pipeline.gate.offer = lambda *args, m=m: [m]
        pipeline.step(
            Sample(len(pipeline.presses) + 1.0, np.zeros(6), np.array([0, 0, 0.1]), np.eye(3))
        )
    assert [p.accepted for p in pipeline.presses] == [True, True]
    assert pipeline.measurements == [first, second]


def test_a_press_at_a_new_configuration_enters_if_it_keeps_its_lines_direction():
    """At a new configuration a press on a line confirmed before enters alone when it keeps
    the line's direction (a slide, or a link that did not move); a turned one waits for a
    partner (a hinge whose axis is not known yet)."""
    pipeline = _replay_stub(LabelConfig(confirm_spacing=0.006))
    pipeline._admit(_press([0, 0, 0], [1, 0, 0]))
    assert len(pipeline._admit(_press([0.01, 0, 0], [1, 0, 0]))) == 2
    pipeline.configuration = 1
    assert len(pipeline._admit(_press([0.005, 0.004, 0], [1, 0, 0]))) == 1  # slid 4 mm
    pipeline.configuration = 2
    assert pipeline._admit(_press([0.005, 0.004, 0], _turned(20.0))) == ()


# --------------------------------------------------------------------------- the baseline


def test_the_hinge_baseline_refuses_a_joint_id_and_points_to_its_own():
    env = gym.make(PLANAR)
    with pytest.raises(ValueError, match="joint_policy"):
        scripted_policy(env)
    env.close()


@pytest.mark.parametrize(("env_id", "seed"), [(PLANAR, 1000), (PLANAR, 1001), (SPATIAL, 1003)])
def test_the_scripted_baseline_identifies_the_joint(env_id, seed):
    env = gym.make(env_id)
    policy = joint_policy(env)
    obs, info = env.reset(seed=seed)
    policy.reset()
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
        done = terminated or truncated
    assert not terminated
    assert info["type_correct"] and info["type_probabilities"][info["joint_type"]] > 0.8
    env.close()
