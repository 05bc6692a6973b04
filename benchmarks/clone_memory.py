"""Which memory lets a clone of the skill executor act on a 6-D id (docs/design.md 12).

The scripted skill executor's next action depends on its phase within a probe or a turn,
which one observation does not show. This clones its demonstrations into three policies and
measures each:

* ``mlp``: PPO's policy on the current observation (``agents.warmstart``'s clone);
* ``history``: an MLP on the last ``--history`` observations and actions, stacked (zeros
  before the episode's start), fitted by the same loss;
* ``lstm``: RecurrentPPO's ``MultiInputLstmPolicy``, cloned through whole episodes with the
  LSTM state carried (``agents.warmstart``).

For each: the negative log-likelihood per action (nats; the deviation held at 0.2, so a
perfect fit of the 7 components scores -4.83) on the fitted and on held-out demonstration
episodes, and, with the clone alone acting (mean actions), the accepted measurements per
episode and the final position error, on episodes from the selection range
(``agents.seeds``), beside the scripted policy on the same episodes.

With ``--deadband W`` the clones act through an action deadband (components below ``W`` act
as 0, ``agents.policies.deadband``), as the recurrent recipe's models do.

Run: ``python benchmarks/clone_memory.py [--env ID] [--demos N] [--held-out N]
[--episodes N] [--history K] [--epochs N] [--lstm-size N] [--clones ...] [--deadband W]``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

# Measure the checkout this file is in (git worktrees share one virtual environment).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.cli import make_env  # noqa: E402
from agents.demonstrations import Demos, record_demos  # noqa: E402
from agents.episodes import run_episode  # noqa: E402
from agents.policies import deadband  # noqa: E402
from agents.resources import torch_threads  # noqa: E402
from agents.scripted import scripted_policy  # noqa: E402
from agents.seeds import DEMO_SEED, SELECTION_SEED  # noqa: E402
from agents.warmstart import WarmStart, action_nll, normalise_from_demos, warm_start  # noqa: E402

ACTION_STD = 0.2


class SB3Clone:
    """A warm-started SB3 model acting with its mean action, its LSTM state (if any) carried
    from the episode's start."""

    def __init__(self, model) -> None:
        self.model = model
        self.normalizer = model.get_vec_normalize_env()
        self.reset()

    def reset(self) -> None:
        self.state, self.start = None, np.ones(1, dtype=bool)

    def get_action(self, obs):
        action, self.state = self.model.predict(
            self.normalizer.normalize_obs(obs), self.state, self.start, deterministic=True
        )
        self.start = np.zeros(1, dtype=bool)
        return action


class HistoryClone:
    """An MLP on the last ``k`` normalised observations and actions, stacked."""

    def __init__(self, normalizer, keys: list[str], n_actions: int, k: int, arch: list[int]):
        import torch

        self.normalizer, self.keys, self.k, self.n_actions = normalizer, keys, k, n_actions
        size = k * (self.obs_size + n_actions)
        layers, width = [], size
        for hidden in arch:
            layers += [torch.nn.Linear(width, hidden), torch.nn.Tanh()]
            width = hidden
        self.net = torch.nn.Sequential(*layers, torch.nn.Linear(width, n_actions))
        self.reset()

    @property
    def obs_size(self) -> int:
        return sum(int(np.prod(self.normalizer.observation_space[k].shape)) for k in self.keys)

    def flat(self, obs: dict) -> np.ndarray:
        normal = self.normalizer.normalize_obs(obs)
        return np.concatenate(
            [np.asarray(normal[k], dtype=np.float32).reshape(len(normal[self.keys[0]]), -1)
             for k in self.keys], axis=1
        )  # fmt: skip

    def stacked(self, demos: Demos) -> np.ndarray:
        """Each step's input: its own and the ``k - 1`` earlier observations, and the ``k``
        actions before it, zeros before the episode's start."""
        obs = self.flat(demos.obs)
        previous = np.zeros_like(demos.acts)
        previous[1:] = demos.acts[:-1]
        first = np.r_[True, demos.episode[1:] != demos.episode[:-1]]
        previous[first] = 0.0
        rows = []
        for lag in range(self.k):
            o, a = np.zeros_like(obs), np.zeros_like(previous)
            o[lag:], a[lag:] = obs[: len(obs) - lag], previous[: len(obs) - lag]
            same = np.zeros(len(obs), dtype=bool)
            same[lag:] = demos.episode[lag:] == demos.episode[: len(obs) - lag]
            o[~same], a[~same] = 0.0, 0.0
            rows += [o, a]
        return np.concatenate(rows, axis=1)

    def fit(self, demos: Demos, epochs: int, batch: int, lr: float, seed: int) -> list[float]:
        import torch

        x = torch.as_tensor(self.stacked(demos))
        y = torch.as_tensor(demos.acts)
        generator = torch.Generator().manual_seed(seed)
        optimizer = torch.optim.Adam(self.net.parameters(), lr=lr)
        losses = []
        for _ in range(epochs):
            total = 0.0
            for index in torch.randperm(len(x), generator=generator).split(batch):
                loss = self.nll(x[index], y[index])
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                total += float(loss.detach()) * len(index)
            losses.append(total / len(x))
        return losses

    def nll(self, x, y):
        import torch

        normal = torch.distributions.Normal(self.net(x), ACTION_STD)
        return -normal.log_prob(y).sum(-1).mean()

    def held_out(self, demos: Demos) -> float:
        import torch

        with torch.no_grad():
            x, y = torch.as_tensor(self.stacked(demos)), torch.as_tensor(demos.acts)
            return float(self.nll(x, y))

    def reset(self) -> None:
        self.obs = np.zeros((self.k, self.obs_size), dtype=np.float32)
        self.acts = np.zeros((self.k, self.n_actions), dtype=np.float32)

    def get_action(self, obs):
        import torch

        single = {k: np.asarray(v)[None] for k, v in obs.items()}
        self.obs = np.roll(self.obs, 1, axis=0)
        self.obs[0] = self.flat(single)[0]
        x = np.concatenate([np.concatenate([self.obs[i], self.acts[i]]) for i in range(self.k)])
        with torch.no_grad():
            action = np.clip(self.net(torch.as_tensor(x[None]))[0].numpy(), -1.0, 1.0)
        self.acts = np.roll(self.acts, 1, axis=0)
        self.acts[0] = action
        return action.astype(np.float32)


def sb3_model(kind: str, env_id: str, lstm_size: int):
    from sb3_contrib import RecurrentPPO
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: make_env(env_id)]))
    if kind == "lstm":
        kwargs = {"net_arch": [128, 128], "lstm_hidden_size": lstm_size}
        return RecurrentPPO("MultiInputLstmPolicy", venv, policy_kwargs=kwargs, seed=0)
    return PPO("MultiInputPolicy", venv, policy_kwargs={"net_arch": [128, 128]}, seed=0)


class Deadband:
    """``policy``'s actions with every component smaller than ``width`` in magnitude executed
    as 0: the gate counts a step as still only below 1 % of a unit translation and 0.4 % of
    a unit rotation (``GateConfig.still_translation``, ``still_rotation``)."""

    def __init__(self, policy, width: float) -> None:
        self.policy, self.width = policy, width

    def reset(self) -> None:
        self.policy.reset()

    def get_action(self, obs):
        return deadband(np.asarray(self.policy.get_action(obs), dtype=np.float32), self.width)


def play(policy, env_id: str, seeds: range) -> tuple[float, float, float]:
    """Mean accepted measurements, mean final position error (mm) and failure rate."""
    env = make_env(env_id)
    try:
        records = [run_episode(env, policy, seed) for seed in seeds]
    finally:
        env.close()
    return (
        float(np.mean([r.n_measurements for r in records])),
        1e3 * float(np.mean([r.position_error[-1] for r in records])),
        float(np.mean([r.terminated for r in records])),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="tactile_gym/HingeProbe-v2")
    parser.add_argument("--demos", type=int, default=20, help="episodes fitted")
    parser.add_argument("--held-out", type=int, default=10, help="episodes held out")
    parser.add_argument("--episodes", type=int, default=30, help="episodes each clone acts")
    parser.add_argument("--history", type=int, default=8, help="stacked steps of 'history'")
    parser.add_argument("--epochs", type=int, default=50, help="cloning passes")
    parser.add_argument("--lstm-size", type=int, default=128, help="LSTM hidden units")
    parser.add_argument("--clones", nargs="+", default=["mlp", "history", "lstm"])
    parser.add_argument(
        "--deadband", type=float, default=0.0, help="clone action components below it act as 0"
    )
    args = parser.parse_args()
    start = time.monotonic()
    fitted = record_demos(args.env, args.demos, DEMO_SEED)
    held = record_demos(args.env, args.held_out, DEMO_SEED + args.demos)
    print(
        f"{args.env}: {args.demos} demonstrations fitted ({len(fitted)} steps), "
        f"{args.held_out} held out (seeds {DEMO_SEED + args.demos}..), recorded in "
        f"{time.monotonic() - start:.0f} s; clones act on seeds {SELECTION_SEED}.."
        f"{SELECTION_SEED + args.episodes - 1}",
        flush=True,
    )
    seeds = range(SELECTION_SEED, SELECTION_SEED + args.episodes)
    perfect = fitted.acts.shape[1] * (math.log(ACTION_STD) + 0.5 * math.log(2 * math.pi))
    recipe = WarmStart(demos=1, bc_epochs=args.epochs, value_epochs=0)
    env = make_env(args.env)
    rows = [("scripted", "-", "-", "-", *play(scripted_policy(env), args.env, seeds))]
    env.close()
    with torch_threads(1):
        for kind in args.clones:
            t0 = time.monotonic()
            if kind == "history":
                model = sb3_model("mlp", args.env, args.lstm_size)
                normalizer = model.get_vec_normalize_env()
                normalise_from_demos(normalizer, fitted)
                clone = HistoryClone(
                    normalizer, sorted(fitted.obs), fitted.acts.shape[1], args.history, [128, 128]
                )
                losses = clone.fit(fitted, args.epochs, recipe.batch_size, recipe.learning_rate, 0)
                fit, held_nll = losses[-1], clone.held_out(held)
            else:
                model = sb3_model(kind, args.env, args.lstm_size)
                fit = warm_start(model, fitted, recipe)["bc_loss"][-1]
                held_nll = action_nll(model, held, ACTION_STD)
                clone = SB3Clone(model)
            seconds = time.monotonic() - t0
            if args.deadband > 0.0:
                clone = Deadband(clone, args.deadband)
            rows.append((kind, f"{fit:.2f}", f"{held_nll:.2f}", f"{seconds:.0f}",
                         *play(clone, args.env, seeds)))  # fmt: skip
            print(f"  {kind} done ({time.monotonic() - start:.0f} s)", flush=True)
    print(f"\nperfect fit: {perfect:.2f} nats per action\n")
    print("| policy | NLL fitted | NLL held out | fit (s) | measurements / episode | "
          "final error (mm) | failures |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name, fit, held_nll, seconds, measured, error, failures in rows:
        print(f"| {name} | {fit} | {held_nll} | {seconds} | {measured:.1f} | {error:.2f} | "
              f"{100 * failures:.0f} % |")  # fmt: skip


if __name__ == "__main__":
    main()
