"""Refactors keep behaviour: fixed-seed rollouts of every id match a recording.

``tests/data/rollouts.npz`` holds, for every v2 and v1 id (``LEGACY_ENV_IDS``)
and two seeds, the scripted policy's and a random policy's episodes (observations, rewards,
terminations and the errors in ``info``): the v1 ids' recorded on main before the probing
stack was restructured, the v2 ids' before the perception layer moved out of the env. A
change that moves them on purpose re-records them (``PYTHONPATH=. python
tests/test_rollout_identity.py``, ``--v3`` for the current ids) and names the change in its
commit and in the ids' Version History.

``tests/data/rollouts_v3.npz`` holds the same for the current ids (``ENV_IDS``) and every
joint id (``JOINT_ENV_IDS`` and ``LEGACY_JOINT_ENV_IDS``), which models are trained on: the
scripted policy's episodes for three seeds and a random policy's for one, with every entry of
``info``; the v3 and v0 joint ids' recorded on main e83ad86 before the step's Python was cut
(issue 27, item 3), the v1 joint ids' when they were registered. They must match to the bit:
a speed-up that moves a bit of them is a new version. Re-record them the same way, on purpose
only; ``--v3 <ids>`` re-records only those ids' episodes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents.policies import make_policy
from tactile_gym import ENV_IDS, JOINT_ENV_IDS, LEGACY_ENV_IDS, LEGACY_JOINT_ENV_IDS

RECORDING = Path(__file__).parent / "data" / "rollouts.npz"
RECORDING_V3 = Path(__file__).parent / "data" / "rollouts_v3.npz"
SEEDS = (0, 1)
#: Control steps for the 6-D ids, primitives for the primitive ids.
STEPS = {True: 8, False: 60}
#: The current ids' episodes are longer, so that several measurements enter the estimate.
STEPS_V3 = {True: 12, False: 150}
#: Floating-point order may move the last bits (docs/design.md, "Versions"); nothing else.
TOLERANCE = 1e-9


def _key(env_id: str, policy: str, seed: int) -> str:
    return f"{env_id.split('/')[-1]}|{policy}|{seed}"


def rollout(
    env_id: str, policy: str, seed: int, steps: dict[bool, int] = STEPS, infos: bool = False
) -> dict[str, np.ndarray]:
    """One episode, cut at ``steps`` steps: flat observations, rewards, ends and errors, and
    with ``infos`` every entry of ``info`` (``info|<key>``, the reset's first)."""
    env = gym.make(env_id)
    primitive = env.action_space.shape == (3,)
    obs, info = env.reset(seed=seed)
    scripted = make_policy("scripted", env) if policy == "scripted" else None
    if scripted is not None:
        scripted.reset()
    env.action_space.seed(seed)
    flat, rewards, ends, errors, entries = [], [], [], [], [info]
    space = env.get_wrapper_attr("dict_observation_space")
    for _ in range(steps[primitive]):
        action = env.action_space.sample() if scripted is None else scripted.get_action(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        flat.append(gym.spaces.flatten(space, obs))
        rewards.append(reward)
        ends.append((terminated, truncated))
        errors.append((info["position_error"], info["angle_error"], info["n_measurements"]))
        entries.append(info)
        if terminated or truncated:
            break
    env.close()
    arrays = {
        "obs": np.asarray(flat, np.float64),
        "reward": np.asarray(rewards, np.float64),
        "ends": np.asarray(ends, bool),
        "errors": np.asarray(errors, np.float64),
    }
    if infos:
        for key in entries[0]:
            arrays[f"info|{key}"] = np.asarray([entry[key] for entry in entries])
    return arrays


CASES = [
    (env_id, policy, seed)
    for env_id in LEGACY_ENV_IDS
    for policy in ("scripted", "random")
    for seed in SEEDS
]
CASES_V3 = [
    (env_id, policy, seed)
    for env_id in (*ENV_IDS, *JOINT_ENV_IDS, *LEGACY_JOINT_ENV_IDS)
    for policy, seeds in (("scripted", (0, 1, 2)), ("random", (0,)))
    for seed in seeds
]


@pytest.mark.parametrize("env_id, policy, seed", CASES)
def test_rollout_matches_recording(env_id, policy, seed):
    recorded = np.load(RECORDING)
    key = _key(env_id, policy, seed)
    got = rollout(env_id, policy, seed)
    for field, value in got.items():
        want = recorded[f"{key}|{field}"]
        assert value.shape == want.shape, f"{key} {field}: {value.shape} != {want.shape}"
        if value.dtype == bool:
            np.testing.assert_array_equal(value, want, err_msg=f"{key} {field}")
        else:
            np.testing.assert_allclose(
                value, want, rtol=0, atol=TOLERANCE, err_msg=f"{key} {field}"
            )


@pytest.mark.parametrize("env_id, policy, seed", CASES_V3)
def test_current_rollout_matches_recording_to_the_bit(env_id, policy, seed):
    recorded = np.load(RECORDING_V3)
    key = _key(env_id, policy, seed)
    got = rollout(env_id, policy, seed, STEPS_V3, infos=True)
    fields = {name.removeprefix(f"{key}|") for name in recorded.files if name.startswith(key)}
    assert set(got) == fields, f"{key}: fields {sorted(got)} != recorded {sorted(fields)}"
    for field, value in got.items():
        np.testing.assert_array_equal(value, recorded[f"{key}|{field}"], err_msg=f"{key} {field}")


def record() -> None:
    """Record the v2 and v1 ids' rollouts (``RECORDING``); with ``--v3``, the current and
    joint ids' (``RECORDING_V3``), and with ids after it only theirs, keeping the others'."""
    current = "--v3" in sys.argv
    cases, path = (CASES_V3, RECORDING_V3) if current else (CASES, RECORDING)
    only = sys.argv[sys.argv.index("--v3") + 1 :] if current else []
    unknown = sorted(set(only) - {env_id for env_id, _, _ in cases})
    if unknown:
        raise SystemExit(f"not among the recorded ids: {unknown}")
    arrays = {}
    if only:
        kept = np.load(path)
        arrays = {
            name: kept[name]
            for name in kept.files
            if name.split("|")[0] not in {env_id.split("/")[-1] for env_id in only}
        }
        cases = [case for case in cases if case[0] in only]
    for env_id, policy, seed in cases:
        if current:
            got = rollout(env_id, policy, seed, STEPS_V3, infos=True)
        else:
            got = rollout(env_id, policy, seed)
        for field, value in got.items():
            arrays[f"{_key(env_id, policy, seed)}|{field}"] = value
    path.parent.mkdir(exist_ok=True)
    np.savez_compressed(path, **arrays)
    print(f"recorded {len(cases)} rollouts in {path}")


if __name__ == "__main__":
    sys.exit(record())
