"""Ground truth stays out of the measurement path: an audit of every read of the truth.

The simulator's truth may feed the reward, ``info``, termination and tests; never a policy,
the sensing, the gate, the estimator or the start pose. Every truth accessor of ``ProbeScene``
is wrapped here; each read records the call stack, and a read fails the test when

* the function that made it is not named as truth code (``true_...``, ``_true_...``,
  ``..._error``, ``turn_by_hand``), or
* any function on the stack belongs to the measurement path: the sensing, estimation and
  perception packages (touch sensing, tare, gate, measurement pipeline), the log replay, the
  env's observation codec and skills, a policy, or the paper's finger (``agents.paper_finger``,
  which Table I's protocols drive).

Episodes of every id with the scripted, random and primitive policies run under the audit,
and so does a reduced Table I reproduction.
"""

from __future__ import annotations

import functools
import re
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym
from agents.policies import make_policy
from tactile_gym.sim import ProbeScene

TRUTH = (
    "true_axis",
    "true_joint_type",
    "edge_line",
    "object_config",
    "true_wrench",
    "contact",
    "contact_centroid",
    "joint_angle",
    "object",
)
ALLOWED_NAME = re.compile(r"^(_?true_\w*|\w*_error|\w+_by_hand)$")
ROOT = Path(tactile_gym.__file__).resolve().parents[1]
FORBIDDEN = (
    "tactile_gym/sensing/",
    "tactile_gym/estimation/",
    "tactile_gym/perception/",
    "tactile_gym/replay.py",
    "tactile_gym/envs/observation.py",
    "tactile_gym/envs/skills.py",
    "agents/scripted.py",
    "agents/joint_scripted.py",
    "agents/paper_finger.py",
)
SCENE_FILE = "tactile_gym/sim/scene.py"


@functools.cache  # resolving every frame's file on every read took most of the audit's time
def _relative(filename: str) -> str:
    try:
        return Path(filename).resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return filename


@pytest.fixture
def audit(monkeypatch):
    """Wrap the truth accessors; yield the list of violations found."""
    violations: list[str] = []
    reads: list[str] = []

    def wrap(name: str, prop: property) -> property:
        def getter(self):
            frame = sys._getframe(1)
            # The scene's own methods may use their own state (read_wrench is the sensor
            # model: the true wrench plus noise); only reads from outside are judged.
            if _relative(frame.f_code.co_filename) != SCENE_FILE:
                caller = frame.f_code.co_name
                reads.append(f"{name} <- {caller}")
                if not ALLOWED_NAME.match(caller):
                    violations.append(f"{name} read by {caller} ({frame.f_code.co_filename})")
                f = frame
                while f is not None:
                    path = _relative(f.f_code.co_filename)
                    if any(path.startswith(p) for p in FORBIDDEN):
                        violations.append(f"{name} read under {f.f_code.co_name} ({path})")
                        break
                    f = f.f_back
            return prop.fget(self)

        return property(getter)

    for name in TRUTH:
        monkeypatch.setattr(ProbeScene, name, wrap(name, getattr(ProbeScene, name)))
    yield violations, reads


class _Random:
    def __init__(self, env):
        self.space = env.action_space
        self.space.seed(0)

    def reset(self):
        pass

    def get_action(self, obs):
        return self.space.sample()


@pytest.mark.parametrize("env_id", tactile_gym.ENV_IDS + tactile_gym.JOINT_ENV_IDS)
@pytest.mark.parametrize("policy", ["scripted", "random"])
def test_episodes_never_feed_truth_to_the_measurement_path(audit, env_id, policy):
    violations, reads = audit
    env = gym.make(env_id, max_steps=80)
    agent = make_policy("scripted", env) if policy == "scripted" else _Random(env)
    obs, _ = env.reset(seed=3)
    agent.reset()
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(agent.get_action(obs))
        done = terminated or truncated
    env.close()
    assert not violations, violations[:5]
    assert any(r.startswith("true_axis") for r in reads)  # the audit did see the reward's reads


def test_the_audit_catches_a_leak(audit):
    """The check can fail: a gate that peeks at the joint angle is reported."""
    violations, _ = audit
    env = gym.make("tactile_gym/HingeProbe-v2", max_steps=3)
    env.reset(seed=0)
    gate = env.unwrapped.gate
    offer = gate.offer

    def leaky_offer(*args):
        env.unwrapped.scene.joint_angle  # noqa: B018 - the leak under test
        return offer(*args)

    gate.offer = leaky_offer
    env.step(np.zeros(7, np.float32))
    env.close()
    assert any("joint_angle read by leaky_offer" in v for v in violations)


def test_start_pose_does_not_depend_on_the_truth_beyond_the_documented_start():
    """Same generator state, two objects whose edges point differently: the finger's lean is
    the same draw, so it carries no information about the edge direction."""
    from tactile_gym.envs.scenarios import ScenarioConfig, sample_scenario
    from tactile_gym.sensing import FingertipGeometry
    from tactile_gym.spatial import quaternion_to_matrix

    geometry = FingertipGeometry()
    cfg = ScenarioConfig(joint_angle_range=(0.3, 0.3))
    a = sample_scenario(np.random.default_rng(9), ("scissors",), cfg, geometry)
    cfg_b = ScenarioConfig(joint_angle_range=(-0.3, -0.3))
    b = sample_scenario(np.random.default_rng(9), ("scissors",), cfg_b, geometry)
    axis_a = quaternion_to_matrix(a.fingertip_orientation)[:, 2]
    axis_b = quaternion_to_matrix(b.fingertip_orientation)[:, 2]
    # The lean is drawn relative to the edge's frame, so it turns with the link: what the
    # first observation shows of it is a random azimuth (test_env_parts checks uniformity).
    assert not np.allclose(axis_a, axis_b)


def test_table1_reads_truth_only_by_hand_and_for_the_error(audit):
    """The paper's protocol: the edge is found by touch and the press stops on the noisy
    reading; only ``turn_by_hand``, ``true_...`` and ``..._error`` may read the truth."""
    from agents import reproduce_paper

    violations, reads = audit
    results = reproduce_paper.reproduce(trials=1, schemes=("paper",))
    assert len(results) == 2
    assert not violations, violations[:5]
    assert any("turn_by_hand" in r for r in reads)


def test_drawer_table_reads_truth_only_by_hand_and_for_the_error(audit):
    """The drawer's protocol likewise: only the hand that carries the finger with the
    drawer (``carried_by_hand``) and the error may read the truth."""
    from agents import reproduce_drawer

    violations, reads = audit
    results = reproduce_drawer.reproduce(trials=1)
    assert len(results) == 2
    assert not violations, violations[:5]
    assert any("carried_by_hand" in r for r in reads)
