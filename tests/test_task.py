"""The task object: reward terms, the prior baseline, success and every termination reason."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_gym.envs.task import (
    REWARD_TERMS,
    TERMINATION_REASONS,
    AxisEstimationTask,
    StepFacts,
    TaskConfig,
)


def reward_of(task: AxisEstimationTask, step: StepFacts) -> tuple[float, dict[str, float]]:
    """The step's reward as the env takes it: termination judged once, then the reward."""
    return task.get_reward(step, any(task.get_termination(step).values()))


def facts(**kw) -> StepFacts:
    base = dict(
        position_error=0.01,
        angle_error=0.0,
        max_force=5.0,
        force_limit=8.0,
        shell_contact=False,
        hinge_distance=0.05,
        action=np.zeros(6),
        measurements=1,
    )
    return StepFacts(**{**base, **kw})


def test_return_telescopes_from_the_prior_error():
    task = AxisEstimationTask(TaskConfig())
    task.initialize_episode(facts(position_error=0.008, angle_error=np.deg2rad(1.0)))
    e0 = 0.008 + 0.05 * np.deg2rad(1.0)
    errors = [(0.02, 0.3), (np.inf, np.pi / 2), (0.004, 0.01), (0.001, 0.002)]
    total = sum(reward_of(task, facts(position_error=p, angle_error=a))[0] for p, a in errors)
    final = 0.001 + 0.05 * 0.002
    assert total == pytest.approx((e0 - final) / 0.01)


def test_a_worse_first_estimate_costs_reward():
    """No jump: an estimate worse than the prior earns a negative reward."""
    task = AxisEstimationTask(TaskConfig())
    task.initialize_episode(facts(position_error=0.006, angle_error=0.0))
    reward, terms = reward_of(task, facts(position_error=0.05))
    assert reward < 0 and terms["reward_error_reduction"] == pytest.approx(-4.4)


def test_reward_is_the_sum_of_its_terms_and_penalties_bite():
    task = AxisEstimationTask(TaskConfig())
    task.initialize_episode(facts(position_error=0.01, angle_error=0.0))
    reward, terms = reward_of(task, facts(max_force=12.0, action=np.ones(6)))
    assert tuple(terms) == REWARD_TERMS  # the names the primitive ids sum over a primitive
    assert reward == pytest.approx(sum(terms.values()))
    assert terms["reward_force_penalty"] == pytest.approx(-0.1 * 4.0 / 8.0)
    assert terms["reward_action_cost"] == pytest.approx(-0.006)


@pytest.mark.parametrize(
    "reason, kw",
    [
        ("left_workspace", {"hinge_distance": 0.26}),
        ("shell_contact", {"shell_contact": True}),
        ("overloaded", {"max_force": 31.0}),
    ],
)
def test_each_termination_reason_fires_alone(reason, kw):
    task = AxisEstimationTask(TaskConfig())
    out = task.get_termination(facts(**kw))
    assert set(out) == set(TERMINATION_REASONS)
    assert out == {r: r == reason for r in TERMINATION_REASONS}
    assert not any(task.get_termination(facts()).values())


def test_success_needs_both_errors_small():
    task = AxisEstimationTask(TaskConfig())
    assert task.is_success(0.0019, np.deg2rad(1.9))
    assert not task.is_success(0.0021, 0.0)
    assert not task.is_success(0.0, np.deg2rad(2.1))


@pytest.mark.parametrize("reason", TERMINATION_REASONS)
def test_a_failing_step_pays_the_termination_penalty(reason):
    kw = {
        "left_workspace": {"hinge_distance": 0.26},
        "shell_contact": {"shell_contact": True},
        "overloaded": {"max_force": 31.0},
    }[reason]
    task = AxisEstimationTask(TaskConfig(termination_penalty=0.5))
    task.initialize_episode(facts(position_error=0.01, angle_error=0.0))
    reward, terms = reward_of(task, facts(**kw))
    assert terms["reward_termination"] == -0.5
    assert reward == pytest.approx(sum(terms.values()))
    assert reward_of(task, facts())[1]["reward_termination"] == 0.0


def test_the_termination_penalty_is_off_by_default_and_validated():
    task = AxisEstimationTask(TaskConfig())
    task.initialize_episode(facts(position_error=0.01, angle_error=0.0))
    assert reward_of(task, facts(shell_contact=True))[1]["reward_termination"] == 0.0
    with pytest.raises(ValueError, match="termination_penalty"):
        TaskConfig(termination_penalty=-0.1)


def test_prior_error_scores_the_prior_by_a_fixed_error():
    """With prior_error the prior's steps earn nothing whatever its true error, and the return
    is (prior_error - E_T) / E_scale: the default return less the episode's E_0 - prior_error."""
    errors = [(0.012, 0), (0.012, 0), (0.004, 2), (0.0015, 5)]  # (position error, measurements)
    returns = {}
    for prior_error in (None, 0.01):
        task = AxisEstimationTask(TaskConfig(prior_error=prior_error))
        task.initialize_episode(facts(position_error=0.012, angle_error=0.0, measurements=0))
        rewards = [reward_of(task, facts(position_error=p, measurements=m))[0] for p, m in errors]
        returns[prior_error] = sum(rewards)
        if prior_error is not None:
            assert rewards[:2] == [0.0, 0.0]
    assert returns[0.01] == pytest.approx((0.01 - 0.0015) / 0.01)
    assert returns[None] - returns[0.01] == pytest.approx((0.012 - 0.01) / 0.01)


@pytest.mark.parametrize("value", [0.0, -0.01, 0.2])
def test_prior_error_is_validated(value):
    with pytest.raises(ValueError, match="prior_error"):
        TaskConfig(prior_error=value)


def test_the_predicted_reward_scores_the_estimators_own_uncertainty_not_the_truth():
    """reward_source='predicted': the return telescopes to (U_0 - U_T) / E_scale, with
    U = position std + L * angle std, and no true error moves it."""
    task = AxisEstimationTask(TaskConfig(reward_source="predicted"))
    stds = [(0.008, 0.05), (0.004, 0.02), (0.006, 0.03), (0.002, 0.01)]
    returns = []
    for truth in (0.001, 0.05):  # two very different true errors, the same predictions
        task.initialize_episode(facts(position_error=truth, position_std=0.01, angle_std=0.1))
        total = 0.0
        for k, (p, a) in enumerate(stds):
            step = facts(position_error=truth * (k + 2), position_std=p, angle_std=a)
            total += reward_of(task, step)[1]["reward_error_reduction"]
        returns.append(total)
    u_0, u_t = 0.01 + 0.05 * 0.1, 0.002 + 0.05 * 0.01
    assert returns[0] == returns[1] == pytest.approx((u_0 - u_t) / 0.01)
    info = task.info(facts(position_std=0.002, angle_std=0.01))
    assert info["predicted_error"] == pytest.approx(u_t)
    assert info["position_error"] == 0.01  # the truth stays in info, for evaluation


def test_the_reward_source_is_validated():
    with pytest.raises(ValueError, match="reward_source"):
        TaskConfig(reward_source="oracle")


def test_the_workspace_is_centred_on_the_hinge_or_where_the_episode_started():
    """workspace_center='start' judges the fingertip's distance from its start (what a robot
    knows), not from the true hinge."""
    far_from_hinge = facts(hinge_distance=0.3, start_distance=0.1)
    far_from_start = facts(hinge_distance=0.1, start_distance=0.3)
    hinge = AxisEstimationTask(TaskConfig())
    start = AxisEstimationTask(TaskConfig(workspace_center="start"))
    assert hinge.get_termination(far_from_hinge)["left_workspace"]
    assert not hinge.get_termination(far_from_start)["left_workspace"]
    assert start.get_termination(far_from_start)["left_workspace"]
    assert not start.get_termination(far_from_hinge)["left_workspace"]
    with pytest.raises(ValueError, match="workspace_center"):
        TaskConfig(workspace_center="table")
