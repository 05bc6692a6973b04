"""A warm start for PPO from demonstrations: behaviour cloning, then the value function
pre-fitted to the demonstrations' returns (``docs/design.md``, Learning).

:func:`warm_start` takes a freshly built PPO model and ``agents.demos`` demonstrations and

1. sets the ``VecNormalize`` statistics from the demonstrations: the observation mean and
   variance of their observations, and the return variance from their running discounted
   rewards, exactly as ``VecNormalize`` would have accumulated them while stepping;
2. clones the policy: maximises the log-likelihood of the demonstrated actions under the
   policy's Gaussian (``ActorCriticPolicy.evaluate_actions``) over the actor's parameters,
   with the standard deviation held at ``action_std``. A fitted deviation collapses towards
   zero on the action components the script keeps constant, after which PPO's fine-tuning
   cannot explore them; with it fixed, the loss is a scaled squared error of the mean and
   ``action_std`` is the exploration fine-tuning starts from;
3. fits the critic (``predict_values``) to the discounted returns of the normalised rewards,
   so that PPO's first advantages measure the clone's actions rather than an untrained
   critic's noise.

A recurrent policy (sb3-contrib's ``RecurrentPPO``) is cloned through whole episodes: each
demonstrated episode is one sequence, the LSTM state carried from its first step to its last
and started from zero, as it is when the policy acts, so the clone can hold what the
demonstrator's own hidden state (the skill executor's phase) carried. The critic is fitted
the same way.

An off-policy actor-critic (sb3-contrib's ``TQC``, SB3's ``SAC``) gets the same three steps in
its own terms: its squashed Gaussian's mean action cloned by the same fixed-deviation
likelihood and its log standard deviation fitted to ``action_std``; every critic's every
quantile (or Q-value) fitted to the demonstrations' discounted returns at the demonstrated
actions, then copied into the target critics; and the demonstrated transitions are written
into its replay buffer, so the first updates learn from them.

With ``anchor_epochs`` the demonstrations also hold PPO's fine-tuning near the clone: after
each PPO update, that many passes of the same fixed-deviation likelihood over them, at PPO's
own learning rate (:class:`agents.callbacks.DemoAnchor`). It is the demonstration term of
DAPG (Rajeswaran et al., 2018) taken as separate steps rather than as a term of PPO's loss,
so SB3's ``train`` stays as it is; ``docs/design.md`` 12.4 says why and what it measured.

The recipe is a short loop of our own over the SB3 policy rather than the ``imitation``
library's BC: imitation's release pins Gymnasium 0.29 and Stable-Baselines3 2.2.

The recipe of a run is :class:`WarmStart`, read from the ``warm_start`` table of
``configs/train/ppo.yml`` (keyed by env id, beside the entries rl_zoo3 reads) by
``agents.train``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from tactile_gym.presets import load_yaml

from .demonstrations import Demos
from .progress import ProgressLines, clock

__all__ = [
    "WarmStart",
    "action_nll",
    "behaviour_clone",
    "clone_actions",
    "fit_values",
    "load_recipe",
    "normalise_from_demos",
    "run_recipe",
    "warm_start",
]


@dataclass(frozen=True)
class WarmStart:
    """The warm-start recipe.

    Attributes:
        demos: episodes of the scripted policy to record (seeds from ``agents.seeds``), or
            the path of an ``agents.demos`` file; 0 runs no warm start.
        bc_epochs: passes over the demonstrations that clone the policy.
        value_epochs: passes over the demonstrations that fit the critic.
        batch_size: samples per gradient step.
        learning_rate: Adam's step size for both fits.
        action_std: the policy's standard deviation during and after cloning, in units of
            the normalised action.
        freeze_statistics: keep the ``VecNormalize`` statistics set from the demonstrations
            for the whole run instead of updating them from its rollouts: a clone whose
            actions must stay within a deadband (the 6-D ids, ``docs/design.md`` 12.1) acts
            otherwise once its inputs' scaling drifts.
        anchor_epochs: passes over the demonstrations after each PPO update that pull the
            actor's mean back towards the demonstrated actions (module docstring); 0: none.
            Only a feed-forward PPO policy takes it.
    """

    demos: int | str = 0
    bc_epochs: int = 50
    value_epochs: int = 50
    batch_size: int = 128
    learning_rate: float = 1e-3
    action_std: float = 0.2
    freeze_statistics: bool = False
    anchor_epochs: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.demos, bool) or not isinstance(self.demos, (int, str)):
            raise ValueError(
                f"warm_start.demos must be a number of episodes or a path, got {self.demos!r}"
            )
        if isinstance(self.demos, int) and self.demos < 0:
            raise ValueError(f"warm_start.demos must be >= 0 episodes, got {self.demos}")
        for name in ("bc_epochs", "value_epochs", "batch_size", "anchor_epochs"):
            value = getattr(self, name)
            low = 1 if name == "batch_size" else 0
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"warm_start.{name} must be an integer >= {low}, got {value!r}")
        for name in ("learning_rate", "action_std"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ValueError(f"warm_start.{name} must be a number > 0, got {value!r}")
        freeze = self.freeze_statistics
        if not isinstance(freeze, bool):
            raise ValueError(f"warm_start.freeze_statistics must be true or false, got {freeze!r}")

    @property
    def enabled(self) -> bool:
        """Whether the recipe runs at all."""
        return self.demos != 0

    @classmethod
    def from_mapping(cls, table: Mapping[str, Any] | None) -> WarmStart:
        """The recipe of a config's mapping.

        Raises:
            ValueError: an unknown key, naming it and the allowed ones, or a bad value.
        """
        table = dict(table or {})
        allowed = [f.name for f in fields(cls)]
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise ValueError(f"unknown warm_start keys {unknown}; allowed: {', '.join(allowed)}")
        return cls(**table)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def normalise_from_demos(vec_normalize, demos: Demos) -> None:
    """Set a ``VecNormalize``'s observation and return statistics from the demonstrations,
    as if it had stepped through them (module docstring)."""
    if vec_normalize.norm_obs:
        if isinstance(demos.obs, dict):
            for key in vec_normalize.norm_obs_keys:
                vec_normalize.obs_rms[key].update(demos.obs[key])
        else:
            vec_normalize.obs_rms.update(demos.obs)
    running = np.zeros(len(demos))
    ahead = 0.0
    for t in range(len(demos)):
        first = t == 0 or demos.episode[t] != demos.episode[t - 1]
        ahead = demos.rews[t] + (0.0 if first else vec_normalize.gamma * ahead)
        running[t] = ahead
    vec_normalize.ret_rms.update(running)


def _batches(n: int, batch_size: int, generator):
    import torch

    order = torch.randperm(n, generator=generator)
    return [order[i : i + batch_size] for i in range(0, n, batch_size)]


def _subset(obs, index):
    return {k: v[index] for k, v in obs.items()} if isinstance(obs, dict) else obs[index]


def behaviour_clone(
    policy, obs, actions, epochs: int, batch_size: int, learning_rate: float, action_std: float,
    generator,
) -> list[float]:  # fmt: skip
    """Clone ``actions`` into the actor of an SB3 ``ActorCriticPolicy`` (module docstring).

    Args:
        policy: the PPO policy; its ``log_std`` is then set so that the actions' standard
            deviation is ``action_std`` (on average over ``obs`` for gSDE) and left there.
        obs: the observations as the policy sees them (tensors, normalised).
        actions: ``(T, A)`` tensor of the demonstrated actions.
        epochs, batch_size, learning_rate: the fit's passes, minibatch size and Adam step.
        action_std: the fixed standard deviation.
        generator: ``torch.Generator`` for the minibatch order.

    Returns:
        The mean negative log-likelihood of each epoch.
    """
    losses = clone_actions(
        policy, obs, actions, epochs, batch_size, learning_rate, action_std, generator
    )
    policy.log_std.data.fill_(math.log(action_std / _noise_scale(policy, obs)))
    return losses


def clone_actions(
    policy, obs, actions, epochs: int, batch_size: int, learning_rate: float, action_std: float,
    generator,
) -> list[float]:  # fmt: skip
    """:func:`behaviour_clone`'s fit of the actor's mean alone, the policy's ``log_std`` left
    as it is (``action_std`` only scales the loss); returns each epoch's mean loss."""
    import torch

    critic = ("value_net.", "mlp_extractor.value_net.")
    params = [
        p
        for name, p in policy.named_parameters()
        if name != "log_std" and not name.startswith(critic)
    ]

    def nll(index):
        mean = policy.get_distribution(_subset(obs, index)).distribution.mean
        normal = torch.distributions.Normal(mean, action_std)
        return -normal.log_prob(actions[index]).sum(dim=-1).mean()

    return _minimise(
        policy, params, nll, len(actions), epochs, batch_size, learning_rate, generator
    )


def _noise_scale(policy, obs) -> float:
    """What scales ``exp(log_std)`` into the actions' standard deviation: 1 for a Gaussian
    policy; for gSDE (``use_sde``), whose noise is the actor's latent features times a random
    matrix of that deviation, the root mean square norm of the latent over ``obs``."""
    import torch

    if not policy.use_sde:
        return 1.0
    with torch.no_grad():
        features = policy.extract_features(obs, policy.pi_features_extractor)
        latent = policy.mlp_extractor.forward_actor(features)
    return float(latent.pow(2).sum(dim=-1).mean().sqrt())


def fit_values(
    policy, obs, returns, epochs: int, batch_size: int, learning_rate: float, generator
) -> list[float]:
    """Fit the critic of an SB3 ``ActorCriticPolicy`` to ``returns`` (``(T,)`` tensor) by
    squared error, over the critic's own parameters; returns each epoch's mean loss."""
    import torch

    params = [*policy.mlp_extractor.value_net.parameters(), *policy.value_net.parameters()]

    def squared_error(index):
        values = policy.predict_values(_subset(obs, index)).flatten()
        return torch.nn.functional.mse_loss(values, returns[index])

    return _minimise(
        policy, params, squared_error, len(returns), epochs, batch_size, learning_rate, generator
    )


def _minimise(
    policy, params, loss_of, n: int, epochs: int, batch_size: int, learning_rate: float, generator
) -> list[float]:
    """Adam on ``params`` over shuffled minibatches of ``n`` samples, ``loss_of(index)`` the
    minibatch loss, with the policy in training mode; returns each epoch's mean loss."""
    import torch

    optimizer = torch.optim.Adam(params, lr=learning_rate)
    losses = []
    policy.set_training_mode(True)
    for _ in range(epochs):
        total = 0.0
        for index in _batches(n, batch_size, generator):
            loss = loss_of(index)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += float(loss.detach()) * len(index)
        losses.append(total / n)
    policy.set_training_mode(False)
    return losses


def warm_start(model, demos: Demos, recipe: WarmStart, seed: int = 0) -> dict[str, Any]:
    """Run the recipe on a new ``model`` (module docstring) and return what it measured:
    samples, episodes, the demonstrations' seed range, the first and last epochs' losses.

    Args:
        model: a PPO, RecurrentPPO, TQC or SAC model.
        demos: the demonstrations (``agents.demos``).
        recipe: the recipe.
        seed: seeds the minibatch order.

    Raises:
        ValueError: another kind of model (A2C shares PPO's policy and is cloned as it), or
            demonstrations whose actions do not fit the model's action space.
    """
    import torch

    kind = _model_kind(model)
    if recipe.anchor_epochs and kind != "on_policy":
        raise ValueError(
            f"warm_start.anchor_epochs needs a feed-forward PPO policy, got {kind} "
            f"{type(model).__name__} with anchor_epochs {recipe.anchor_epochs}"
        )
    if demos.acts.shape[1:] != model.action_space.shape:
        raise ValueError(
            f"the demonstrations' actions have shape {demos.acts.shape[1:]}, "
            f"the model's action space {model.action_space.shape}"
        )
    vec_normalize = model.get_vec_normalize_env()
    obs, rewards = demos.obs, demos.rews
    if vec_normalize is not None:
        normalise_from_demos(vec_normalize, demos)
        obs = vec_normalize.normalize_obs(obs)
        rewards = vec_normalize.normalize_reward(rewards)
        vec_normalize.training = not recipe.freeze_statistics
    generator = torch.Generator().manual_seed(seed)
    returns = demos.discounted_returns(model.gamma, rewards)
    if kind == "recurrent":
        bc, value = _warm_start_recurrent(model.policy, obs, demos, returns, recipe, generator)
    elif kind == "off_policy":
        bc, value = _warm_start_off_policy(model, obs, demos, returns, recipe, generator)
    else:
        policy = model.policy
        tensors, _ = policy.obs_to_tensor(obs)
        actions = torch.as_tensor(demos.acts, device=policy.device)
        bc = behaviour_clone(
            policy, tensors, actions, recipe.bc_epochs, recipe.batch_size,
            recipe.learning_rate, recipe.action_std, generator,
        )  # fmt: skip
        value = fit_values(
            policy, tensors, torch.as_tensor(returns, dtype=torch.float32, device=policy.device),
            recipe.value_epochs, recipe.batch_size, recipe.learning_rate, generator,
        )  # fmt: skip
    return {
        "samples": len(demos),
        "episodes": len(demos.seeds),
        "seeds": [int(demos.seeds.min()), int(demos.seeds.max())],
        "bc_loss": [bc[0], bc[-1]] if bc else [],
        "value_loss": [value[0], value[-1]] if value else [],
    }


def _model_kind(model) -> str:
    """``"recurrent"`` (an LSTM actor-critic), ``"on_policy"`` (a Gaussian actor-critic) or
    ``"off_policy"`` (an actor with critics and a replay buffer).

    Raises:
        ValueError: a model of none of these kinds.
    """
    from stable_baselines3.common.policies import ActorCriticPolicy

    policy = model.policy
    if hasattr(policy, "lstm_actor") and isinstance(policy, ActorCriticPolicy):
        if policy.use_sde:
            raise ValueError("warm_start clones a recurrent policy without gSDE (use_sde false)")
        return "recurrent"
    if isinstance(policy, ActorCriticPolicy) and hasattr(policy, "log_std"):
        return "on_policy"
    if hasattr(policy, "actor") and hasattr(policy, "critic") and hasattr(model, "replay_buffer"):
        if getattr(policy, "use_sde", False):
            raise ValueError("warm_start clones an off-policy actor without gSDE (use_sde false)")
        return "off_policy"
    raise ValueError(
        "warm_start needs a Gaussian actor-critic (ppo, recurrent_ppo) or an off-policy actor "
        f"with critics (tqc, sac), got {type(model).__name__}"
    )


# ------------------------------------------------------------------ through whole episodes
@dataclass
class Sequences:
    """Demonstrated episodes as padded sequences, one row per episode (``(E, L, ...)``), for
    a recurrent policy: the steps past an episode's end are zeros, masked out of every loss.

    Attributes:
        obs: the (normalised) observations, a dict of tensors or one tensor.
        values: per-step tensors by name (``(E, L, ...)``): ``actions``, ``returns``.
        mask: ``(E, L)``, 1 on the episode's steps.
    """

    obs: Any
    values: dict[str, Any]
    mask: Any

    @classmethod
    def of(cls, policy, obs, episode: np.ndarray, **values: np.ndarray) -> Sequences:
        """The demonstrations' steps (``obs``, ``values``), by their ``episode`` index."""
        import torch

        starts = np.flatnonzero(np.r_[True, episode[1:] != episode[:-1]])
        ends = np.r_[starts[1:], len(episode)]
        length = int((ends - starts).max())

        def padded(array: np.ndarray) -> np.ndarray:
            out = np.zeros((len(starts), length, *array.shape[1:]), dtype=np.float32)
            for row, (a, b) in enumerate(zip(starts, ends)):
                out[row, : b - a] = array[a:b]
            return out

        def tensor(array: np.ndarray):
            return torch.as_tensor(padded(array), device=policy.device)

        mask = np.zeros((len(starts), length), dtype=np.float32)
        for row, (a, b) in enumerate(zip(starts, ends)):
            mask[row, : b - a] = 1.0
        observed = (
            {k: tensor(np.asarray(v)) for k, v in obs.items()}
            if isinstance(obs, dict)
            else tensor(np.asarray(obs))
        )
        return cls(
            observed,
            {k: tensor(np.asarray(v, dtype=np.float32)) for k, v in values.items()},
            torch.as_tensor(mask, device=policy.device),
        )

    def __len__(self) -> int:
        return len(self.mask)

    def batch(self, index) -> tuple[Any, dict[str, Any], Any]:
        """The episodes ``index`` flattened episode by episode (``(n * L, ...)``), the order
        in which ``RecurrentActorCriticPolicy`` cuts a batch into ``n`` sequences."""

        def flat(t):
            return t[index].reshape(-1, *t.shape[2:])

        obs = self.obs
        obs = {k: flat(v) for k, v in obs.items()} if isinstance(obs, dict) else flat(obs)
        return obs, {k: flat(v) for k, v in self.values.items()}, flat(self.mask)


def _zero_states(policy, n: int):
    """LSTM states of ``n`` sequences at their start: zeros, as when the policy acts."""
    import torch

    layers, _, hidden = policy.lstm_hidden_state_shape
    zeros = torch.zeros((layers, n, hidden), device=policy.device)
    return zeros, zeros.clone()


def _sequence_nll(policy, sequences: Sequences, index, action_std: float):
    """Mean negative log-likelihood per demonstrated action of the episodes ``index``, the
    LSTM run through each from a zero state."""
    import torch

    obs, values, mask = sequences.batch(index)
    starts = torch.zeros(len(mask), device=policy.device)
    distribution, _ = policy.get_distribution(obs, _zero_states(policy, len(index)), starts)
    mean = distribution.distribution.mean
    log_prob = torch.distributions.Normal(mean, action_std).log_prob(values["actions"]).sum(-1)
    return -(log_prob * mask).sum() / mask.sum()


def _warm_start_recurrent(policy, obs, demos: Demos, returns, recipe: WarmStart, generator):
    """Clone the actor and fit the critic of a recurrent policy through whole episodes (module
    docstring); ``recipe.batch_size`` samples make ``ceil(batch_size / L)`` episodes a batch.
    Returns the two fits' losses per epoch."""
    import torch

    sequences = Sequences.of(
        policy, obs, demos.episode, actions=demos.acts, returns=np.asarray(returns)
    )
    per_batch = max(1, math.ceil(recipe.batch_size / sequences.mask.shape[1]))
    critic = ("value_net.", "mlp_extractor.value_net.", "lstm_critic.", "critic.")
    actor = [
        p
        for name, p in policy.named_parameters()
        if name != "log_std" and not name.startswith(critic)
    ]

    def nll(index):
        return _sequence_nll(policy, sequences, index, recipe.action_std)

    bc = _minimise(
        policy, actor, nll, len(sequences), recipe.bc_epochs, per_batch, recipe.learning_rate,
        generator,
    )  # fmt: skip
    policy.log_std.data.fill_(math.log(recipe.action_std))
    critic_params = [p for name, p in policy.named_parameters() if name.startswith(critic)]

    def squared_error(index):
        batch_obs, values, mask = sequences.batch(index)
        states = _zero_states(policy, len(index))
        starts = torch.zeros(len(mask), device=policy.device)
        predicted = policy.predict_values(batch_obs, states, starts).flatten()
        return ((predicted - values["returns"]) ** 2 * mask).sum() / mask.sum()

    value = _minimise(
        policy, critic_params, squared_error, len(sequences), recipe.value_epochs, per_batch,
        recipe.learning_rate, generator,
    )  # fmt: skip
    return bc, value


# ------------------------------------------------------------------------- off-policy
def _warm_start_off_policy(model, obs, demos: Demos, returns, recipe: WarmStart, generator):
    """Clone the actor, fit the critics (then their targets) and fill the replay buffer of an
    off-policy model (module docstring). Returns the two fits' losses per epoch."""
    import torch

    policy = model.policy
    tensors, _ = policy.obs_to_tensor(obs)
    targets = torch.as_tensor(np.asarray(returns), dtype=torch.float32, device=policy.device)

    acts = policy.scale_action(demos.acts) if policy.squash_output else demos.acts
    actions = torch.as_tensor(np.asarray(acts, dtype=np.float32), device=policy.device)
    target_log_std = math.log(recipe.action_std)

    def nll(index):
        mean, log_std, _ = policy.actor.get_action_dist_params(_subset(tensors, index))
        normal = torch.distributions.Normal(torch.tanh(mean), recipe.action_std)
        fit = -normal.log_prob(actions[index]).sum(dim=-1).mean()
        return fit + ((log_std - target_log_std) ** 2).mean()

    bc = _minimise(
        policy, list(policy.actor.parameters()), nll, len(demos), recipe.bc_epochs,
        recipe.batch_size, recipe.learning_rate, generator,
    )  # fmt: skip

    def squared_error(index):
        predicted = policy.critic(_subset(tensors, index), actions[index])
        if isinstance(predicted, tuple):  # SAC: one Q-value per critic
            predicted = torch.cat(predicted, dim=1)
        wanted = targets[index].reshape(-1, *([1] * (predicted.dim() - 1)))
        return ((predicted - wanted) ** 2).mean()

    critic = [p for name, p in policy.critic.named_parameters() if "features_extractor" not in name]
    value = _minimise(
        policy, critic, squared_error, len(demos), recipe.value_epochs, recipe.batch_size,
        recipe.learning_rate, generator,
    )  # fmt: skip
    policy.critic_target.load_state_dict(policy.critic.state_dict())
    _fill_replay_buffer(model.replay_buffer, demos, np.asarray(actions.cpu()))
    return bc, value


def _fill_replay_buffer(buffer, demos: Demos, actions: np.ndarray) -> None:
    """Write the demonstrated transitions into an empty replay buffer as SB3 stores its own:
    raw observations and rewards (``VecNormalize`` applies when sampling), ``done`` at every
    episode end and ``timeouts`` where it was a truncation (then bootstrapped). Transitions
    fill the buffer's rows ``n_envs`` at a time; a remainder short of a row is left out."""
    n_envs = buffer.n_envs
    count = min(len(demos) - len(demos) % n_envs, buffer.buffer_size * n_envs)
    if count == 0:
        return
    last = np.r_[demos.episode[1:] != demos.episode[:-1], True]
    following = np.r_[np.arange(1, len(demos)), 0]

    def next_of(step: np.ndarray, final: np.ndarray) -> np.ndarray:
        return np.where(
            last.reshape(-1, *([1] * (step.ndim - 1))), final[demos.episode], step[following]
        )

    def rows(array: np.ndarray) -> np.ndarray:
        return np.asarray(array[:count]).reshape(count // n_envs, n_envs, *array.shape[1:])

    if isinstance(demos.obs, dict):
        for key in buffer.observations:
            buffer.observations[key][: count // n_envs] = rows(demos.obs[key])
            buffer.next_observations[key][: count // n_envs] = rows(
                next_of(demos.obs[key], demos.final_obs[key])
            )
    else:
        buffer.observations[: count // n_envs] = rows(demos.obs)
        buffer.next_observations[: count // n_envs] = rows(next_of(demos.obs, demos.final_obs))
    buffer.actions[: count // n_envs] = rows(actions)
    buffer.rewards[: count // n_envs] = rows(demos.rews)
    buffer.dones[: count // n_envs] = rows(last.astype(np.float32))
    if getattr(buffer, "timeouts", None) is not None:
        buffer.timeouts[: count // n_envs] = rows(demos.truncated.astype(np.float32))
    buffer.pos = (count // n_envs) % buffer.buffer_size
    buffer.full = count // n_envs >= buffer.buffer_size


# ---------------------------------------------------------------------------- measures
def action_nll(model, demos: Demos, action_std: float) -> float:
    """The mean negative log-likelihood per demonstrated action, nats, of ``demos`` under a
    Gaussian of deviation ``action_std`` around ``model``'s mean action (the cloning loss,
    without fitting anything): the clone's fit, on demonstrations it was not fitted to when
    they are held out. A recurrent model runs through each episode from a zero state; the
    model's ``VecNormalize`` statistics (if any) scale the observations, unchanged.

    For ``A`` action components a perfect fit scores
    ``A * (log(action_std) + log(2 pi) / 2)``.
    """
    import torch

    kind = _model_kind(model)
    policy = model.policy
    vec_normalize = model.get_vec_normalize_env()
    obs = demos.obs if vec_normalize is None else vec_normalize.normalize_obs(demos.obs)
    policy.set_training_mode(False)
    with torch.no_grad():
        if kind == "recurrent":
            sequences = Sequences.of(policy, obs, demos.episode, actions=demos.acts)
            index = torch.arange(len(sequences))
            return float(_sequence_nll(policy, sequences, index, action_std))
        tensors, _ = policy.obs_to_tensor(obs)
        if kind == "off_policy":
            mean = torch.tanh(policy.actor.get_action_dist_params(tensors)[0])
            acts = policy.scale_action(demos.acts) if policy.squash_output else demos.acts
        else:
            mean, acts = policy.get_distribution(tensors).distribution.mean, demos.acts
        acts = torch.as_tensor(np.asarray(acts, dtype=np.float32), device=policy.device)
        normal = torch.distributions.Normal(mean, action_std)
        return float(-normal.log_prob(acts).sum(dim=-1).mean())


def load_recipe(
    config_file: str | Path, env_id: str, overrides: Mapping[str, Any] | None = None
) -> WarmStart:
    """The recipe of ``env_id`` in a training config's ``warm_start`` table (absent: no warm
    start), updated by ``overrides``.

    Raises:
        ValueError: a table that is not a mapping of env ids to mappings, or a bad recipe.
    """
    table = load_yaml(config_file).get("warm_start") or {}
    if not isinstance(table, dict) or not isinstance(table.get(env_id) or {}, dict):
        raise ValueError(f"warm_start in {config_file} must map env ids to recipes, got {table!r}")
    return WarmStart.from_mapping({**(table.get(env_id) or {}), **dict(overrides or {})})


def run_recipe(
    model, recipe: WarmStart, env_id: str, env_kwargs: dict, seed: int, run_dir: Path
) -> dict[str, Any]:
    """``agents.train``'s warm start of a new model: the demonstrations recorded (seeds
    ``DEMO_SEED ..``, with a progress line every 10 s) or loaded, then :func:`warm_start`;
    the recorded demonstrations and what the fits measured go to ``run_dir``
    (``demos.npz``, ``warm_start.yml``), and a summary to stdout."""
    import time

    import yaml

    from .demonstrations import load_demos, record_demos, save_demos
    from .seeds import DEMO_SEED

    start = time.monotonic()
    if isinstance(recipe.demos, int):
        last = DEMO_SEED + recipe.demos - 1
        print(
            f"warm start: recording {recipe.demos} episodes of the scripted policy on {env_id} "
            f"(seeds {DEMO_SEED}..{last})",
            flush=True,
        )
        lines = ProgressLines(recipe.demos, "demonstrations", interval=10.0)
        demos = record_demos(env_id, recipe.demos, DEMO_SEED, env_kwargs, lines.update)
        save_demos(demos, Path(run_dir) / "demos.npz")
    else:
        print(f"warm start: demonstrations from {recipe.demos}", flush=True)
        demos = load_demos(recipe.demos)
    recorded = time.monotonic() - start
    stats = warm_start(model, demos, recipe, seed)
    stats["seconds"] = {"demos": recorded, "fits": time.monotonic() - start - recorded}
    with open(Path(run_dir) / "warm_start.yml", "w") as f:
        yaml.safe_dump(stats, f, sort_keys=False)
    print(_summary(stats, recipe), flush=True)
    return stats


def _summary(stats: dict[str, Any], recipe: WarmStart) -> str:
    """What :func:`run_recipe` measured, in a few lines."""

    def losses(name: str, epochs: int, values: list[float]) -> str:
        if not values:
            return f"  {name}: none (0 epochs)"
        return f"  {name}: {epochs} epochs, loss {values[0]:.4g} -> {values[-1]:.4g}"

    first, last = stats["seeds"]
    seconds = stats["seconds"]
    return "\n".join(
        [
            f"warm start: {stats['episodes']} demonstrations (seeds {first}..{last}, "
            f"{stats['samples']} steps) in {clock(seconds['demos'])}, fits in "
            f"{clock(seconds['fits'])}",
            losses("policy cloned", recipe.bc_epochs, stats["bc_loss"]),
            losses("critic fitted", recipe.value_epochs, stats["value_loss"]),
        ]
    )
