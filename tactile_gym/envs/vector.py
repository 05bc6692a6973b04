"""A Gymnasium vector env of N scenes, in one process or spread over worker processes, for
every id (``docs/design.md`` 7.9).

``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` makes a
``HingeProbeVectorEnv``: N sub-envs, each the env ``gym.make(id)`` would make (the 6-D
``HingeProbeEnv``, or the primitive wrapper over it) with its own PyBullet DIRECT client.
With ``workers=1`` (the default) they are stepped in turn in this process; with ``workers=k``
they are split into k contiguous blocks, each held and stepped by a worker process (started
with ``forkserver``, or ``spawn`` where there is none), the actions of a block going to its
worker in one message per vector step and its batched results coming back in one. Either way
the per-sub-env work, batching included, is ``_Block``'s, and the blocks' batches are joined
as Gymnasium would have batched the sub-envs one by one, so the results are the same. A
script that makes workers must guard its top level with ``if __name__ == "__main__":``, as
for any ``forkserver`` or ``spawn`` process. Sub-env i reset with seed s and given the same
actions reproduces
``gym.make(id)`` reset with seed s exactly; a primitive sub-env runs its own primitive to
completion within one vector step, however long the others' primitives are.

Gymnasium 1.x conventions: ``metadata["autoreset_mode"]`` (``NEXT_STEP`` by default, as
``SyncVectorEnv``; ``SAME_STEP`` and ``DISABLED`` on request), batched observations (a dict of
``(N, k)`` arrays, or ``(N, k)`` with ``observation_mode="flat"``), infos batched with ``_key``
masks, ``single_observation_space`` and ``single_action_space``. An exception raised by a
sub-env names its index, in a worker too; a worker that dies is a ``RuntimeError``.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
import pickle
import signal
import traceback
from collections.abc import Callable, Sequence
from numbers import Integral
from operator import methodcaller
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from tactile_gym.envs.hinge_probe import HingeProbeEnv
from tactile_gym.envs.hinge_probe_primitive import make_primitive_env
from tactile_gym.validation import check_int

__all__ = [
    "MAX_NUM_ENVS",
    "WORKER_EXIT_TIMEOUT",
    "HingeProbeVectorEnv",
    "call_or_read",
    "make_primitive_vector_env",
    "make_vector_env",
]

#: The most sub-envs one vector env holds: each costs memory and build time
#: (``docs/design.md`` 7.9), so a typo such as ``num_envs=10_000`` fails at once.
MAX_NUM_ENVS = 256

#: How long ``close`` waits for a worker process to close its sub-envs and exit before it
#: terminates it, s.
WORKER_EXIT_TIMEOUT = 5.0  # s


def make_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the 6-D ids: ``num_envs`` ``HingeProbeEnv`` sub-envs."""
    return HingeProbeVectorEnv(HingeProbeEnv, num_envs, **kwargs)


def make_primitive_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the primitive ids: ``num_envs`` primitive sub-envs."""
    return HingeProbeVectorEnv(make_primitive_env, num_envs, **kwargs)


def _with_index(error: Exception, index: int, num_envs: int) -> Exception:
    """``error`` with the sub-env's index in its message, of the same type where the type
    takes a message; otherwise the original with the index as a note."""
    where = f"sub-env {index} of {num_envs}"
    try:
        indexed = type(error)(f"{where}: {error}")
    except Exception:  # a type whose constructor takes more than a message
        error.add_note(f"raised by {where}")
        return error
    indexed.index = index
    return indexed


def call_or_read(env: gym.Env, name: str, args: tuple = (), kwargs: dict | None = None) -> Any:
    """What ``VectorEnv.call`` gives for one sub-env: the method ``name`` (of the env or a
    wrapper) called with ``args`` and ``kwargs``, or the attribute read if it is not
    callable. A module-level function, so that ``functools.partial(call_or_read, ...)`` can
    go to ``HingeProbeVectorEnv.apply`` in worker processes."""
    attr = env.get_wrapper_attr(name)
    return attr(*args, **(kwargs or {})) if callable(attr) else attr


def _description(env: gym.Env) -> tuple:
    """What the vector env takes from its first sub-env: render mode, metadata and spaces."""
    return env.render_mode, env.metadata, env.observation_space, env.action_space


class _Block:
    """Sub-envs ``first`` to ``first + size - 1`` of a vector env of ``total``, and the
    per-sub-env logic: autoreset, errors naming the sub-env, batching. The vector env holds
    one block of all its sub-envs (``workers=1``) or each worker process holds one. Every
    method takes one row per sub-env of the block (seeds, actions, values); ``reset`` and
    ``step`` return the block's batch (observations, infos, ...), the others one result per
    sub-env.
    """

    #: Gymnasium's batching of one sub-env's info into a vector env's, over the block's rows
    #: (it reads only ``num_envs``, here the block's size): the same keys, masks and dtypes.
    _add_info = VectorEnv._add_info

    def __init__(
        self,
        env_fn: Callable[..., gym.Env],
        kwargs: dict[str, Any],
        first: int,
        size: int,
        total: int,
        autoreset_mode: AutoresetMode,
    ) -> None:
        self.first, self.num_envs, self.total = first, size, total
        self.autoreset_mode = autoreset_mode
        self.envs: list[gym.Env] = []
        try:
            for _ in range(size):
                self.envs.append(env_fn(**kwargs))
        except Exception:
            self.close()  # the clients already opened
            raise
        self.obs: list[Any] = [None] * size  # each sub-env's last observation
        self.ended = np.zeros(size, dtype=bool)  # NEXT_STEP: reset on the next step

    def reset(self, seeds: Sequence, mask: np.ndarray, options: dict | None) -> tuple:
        """Reset the sub-envs of ``mask``: the block's observations (the others' last ones)
        and the infos of those reset."""
        infos: dict[str, Any] = {}
        for j in np.flatnonzero(mask):
            reset = methodcaller("reset", seed=seeds[j], options=options)
            self.obs[j], info = self._call(j, reset)
            infos = self._add_info(infos, info, j)
        self.ended[mask] = False
        return self._batched_obs(), infos

    def step(self, actions: np.ndarray) -> tuple:
        """Step every sub-env with its row of ``actions``, the autoreset mode saying what an
        ended one does: the block's observations, rewards, terminations, truncations and
        infos."""
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminations = np.zeros(self.num_envs, dtype=bool)
        truncations = np.zeros(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        for j, action in enumerate(actions):
            if self.autoreset_mode == AutoresetMode.NEXT_STEP and self.ended[j]:
                self.obs[j], info = self._call(j, methodcaller("reset"))
            else:
                self.obs[j], rewards[j], terminations[j], truncations[j], info = self._call(
                    j, methodcaller("step", action)
                )
                if self.autoreset_mode == AutoresetMode.SAME_STEP and (
                    terminations[j] or truncations[j]
                ):
                    infos = self._add_info(infos, {"final_obs": self.obs[j], "final_info": info}, j)
                    self.obs[j], info = self._call(j, methodcaller("reset"))
            infos = self._add_info(infos, info, j)
        self.ended = terminations | truncations
        return self._batched_obs(), rewards, terminations, truncations, infos

    def apply(self, mask: np.ndarray, fn: Callable[[gym.Env], Any]) -> list:
        """``fn`` of each sub-env of ``mask`` (None for the others)."""
        return [self._call(j, fn) if selected else None for j, selected in enumerate(mask)]

    def set_attr(self, values: Sequence, name: str) -> list:
        return [
            self._call(j, methodcaller("set_wrapper_attr", name, value))
            for j, value in enumerate(values)
        ]

    def close(self) -> None:
        for env in self.envs:
            env.close()
        self.envs = []

    def _batched_obs(self):
        """The block's observations stacked into fresh arrays (the caller may keep them)."""
        space = self.envs[0].observation_space
        return concatenate(space, self.obs, create_empty_array(space, self.num_envs))

    def _call(self, j: int, fn: Callable[[gym.Env], Any]) -> Any:
        """``fn`` on sub-env j of the block; an error names the sub-env's global index."""
        try:
            return fn(self.envs[j])
        except Exception as error:
            indexed = _with_index(error, self.first + j, self.total)
            if indexed is error:
                raise
            raise indexed from error


#: The commands a worker's messages name: the methods of its block.
_COMMANDS = {
    method.__name__: method for method in (_Block.reset, _Block.step, _Block.apply, _Block.set_attr)
}


def _join(parts: Sequence) -> Any:
    """The blocks' batches (arrays, or dicts of arrays) joined in block order."""
    if len(parts) == 1:
        return parts[0]
    if isinstance(parts[0], dict):
        return {key: _join([part[key] for part in parts]) for key in parts[0]}
    return np.concatenate(parts)


def _join_infos(parts: Sequence[dict], rows: Sequence[int]) -> dict:
    """The blocks' batched infos (block k of ``rows[k]`` sub-envs) joined as
    ``VectorEnv._add_info`` would have batched them sub-env by sub-env: keys in order of first
    appearance, each array of the dtype its first block gave it, the rows of blocks without
    the key zero (``None`` in object arrays) and unmasked."""
    if len(parts) == 1:
        return parts[0]
    total, joined = sum(rows), {}
    for part, first, size in zip(parts, np.cumsum([0, *rows[:-1]]), rows):
        _put_info(joined, part, first, size, total)
    return joined


def _put_info(joined: dict, part: dict, first: int, size: int, total: int) -> dict:
    """``part``, a block's batched infos, written into rows ``first`` on of ``joined``."""
    for key, value in part.items():
        if isinstance(value, dict):
            joined[key] = _put_info(joined.get(key, {}), value, first, size, total)
            continue
        if key not in joined:
            joined[key] = (
                np.full(total, None, dtype=object)
                if value.dtype == object
                else np.zeros((total, *value.shape[1:]), dtype=value.dtype)
            )
        joined[key][first : first + size] = value
    return joined


# ---------------------------------------------------------------------- worker processes
def _error_reply(error: Exception) -> tuple:
    """A reply that carries ``error`` to the vector env's process, with the worker's
    traceback; an error that cannot cross (it does not pickle) becomes a ``RuntimeError``
    with its message."""
    where = "".join(traceback.format_exception(error))
    try:
        pickle.loads(pickle.dumps(error))
    except Exception:
        error = RuntimeError(f"{type(error).__name__}: {error}")
    return "error", error, where


def _send(conn, reply: tuple, what: str) -> None:
    """Send ``reply``; a result that does not pickle is sent as a ``TypeError`` instead."""
    try:
        data = pickle.dumps(reply, pickle.HIGHEST_PROTOCOL)
    except Exception as error:
        data = pickle.dumps(
            _error_reply(
                TypeError(
                    f"{what} gave a result that cannot be pickled to leave its worker: {error}"
                )
            )
        )
    conn.send_bytes(data)


def _serve(conn, env_fn, kwargs, first, size, num_envs, autoreset_mode, cpu) -> None:
    """A worker process: build a block, send its first sub-env's description, then run the
    block's methods the vector env asks for until it says ``"close"`` or goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the vector env's to handle
    if cpu is not None:
        # Pinned workers stepped faster on 2 cores (docs/design.md 7.9).
        os.sched_setaffinity(0, {cpu})
    try:
        block = _Block(env_fn, kwargs, first, size, num_envs, autoreset_mode)
    except Exception as error:
        conn.send(_error_reply(error))
        conn.close()
        return
    try:
        _send(conn, ("ok", _description(block.envs[0])), "the first sub-env's description")
        while (message := conn.recv())[0] != "close":
            method, args = message
            try:
                reply = ("ok", _COMMANDS[method](block, *args))
            except Exception as error:
                reply = _error_reply(error)
            _send(conn, reply, method)
    except (EOFError, OSError):  # the vector env's process went away
        pass
    finally:
        block.close()
        conn.close()


class _Worker:
    """The vector env's handle on one worker process: its block's place and its pipe."""

    def __init__(
        self,
        context: multiprocessing.context.BaseContext,
        index: int,
        first: int,
        size: int,
        env_fn: Callable[..., gym.Env],
        kwargs: dict[str, Any],
        num_envs: int,
        autoreset_mode: AutoresetMode,
        cpu: int | None,
    ) -> None:
        self.index, self.first, self.size = index, first, size
        self.conn, child = context.Pipe()
        self.process = context.Process(
            target=_serve,
            args=(child, env_fn, kwargs, first, size, num_envs, autoreset_mode, cpu),
            name=f"HingeProbeVectorEnv worker {index}",
            daemon=True,  # ended with the vector env's process, whatever happens to it
        )
        self.process.start()
        child.close()  # so that the worker's death closes the pipe

    def send(self, message: bytes) -> None:
        try:
            self.conn.send_bytes(message)
        except OSError:
            raise self._died() from None

    def receive(self) -> tuple:
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            raise self._died() from None

    def stop(self) -> None:
        """Ask the worker to close its sub-envs and exit; terminate it if it does not."""
        try:
            self.conn.send_bytes(pickle.dumps(("close", ())))
        except OSError:  # already gone
            pass
        self.process.join(WORKER_EXIT_TIMEOUT)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(WORKER_EXIT_TIMEOUT)
        self.conn.close()

    def _died(self) -> RuntimeError:
        self.process.join(WORKER_EXIT_TIMEOUT)
        return RuntimeError(
            f"worker process {self.index} (sub-envs {self.first}-{self.first + self.size - 1})"
            f" died, exit code {self.process.exitcode}"
        )


def _context() -> multiprocessing.context.BaseContext:
    """``forkserver`` where the platform has it, else ``spawn``: never ``fork``, which would
    copy this process's PyBullet clients and numba threads into the workers. The fork server
    imports this module once, so that the workers, forked from it, need not."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload([__name__])
        return context
    return multiprocessing.get_context("spawn")


# ---------------------------------------------------------------------- the vector env
class HingeProbeVectorEnv(VectorEnv):
    """N sub-envs of one id, stepped in this process or in worker processes (module
    docstring).

    Args:
        env_fn: makes one sub-env from the env keywords (the id's entry point); with
            ``workers`` > 1 it must pickle (a module-level function or class).
        num_envs: how many sub-envs, 1 to ``MAX_NUM_ENVS``.
        autoreset_mode: ``AutoresetMode`` or its value. ``NEXT_STEP``: the step after a
            sub-env's episode ends resets it (its action is ignored, reward 0). ``SAME_STEP``:
            the step that ends it resets it and puts the last observation and info in
            ``info["final_obs"]`` and ``info["final_info"]``. ``DISABLED``: reset ended
            sub-envs with ``reset(options={"reset_mask": mask})``.
        workers: how many processes step the sub-envs, 1 to ``num_envs``. 1: this process,
            the sub-envs in ``envs``. k > 1: k worker processes, each holding a contiguous
            block of sub-envs (sizes differ by at most 1); ``call``, ``get_attr``,
            ``set_attr``, ``render``, ``np_random`` and ``np_random_seed`` reach them
            through pipes, so arguments and results must pickle and come back as copies.
        **kwargs: the keywords of ``gym.make(id)`` (``render_mode`` included), the same for
            every sub-env.

    Raises:
        ValueError: ``num_envs`` not an integer in [1, ``MAX_NUM_ENVS``], ``workers`` not an
            integer in [1, ``num_envs``], an unknown ``autoreset_mode``,
            ``render_mode="human"`` with more than one sub-env; the sub-env's own errors for
            its keywords.
    """

    def __init__(
        self,
        env_fn: Callable[..., gym.Env],
        num_envs: int,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        workers: int = 1,
        **kwargs: Any,
    ) -> None:
        self._local: _Block | None = None
        self._workers: list[_Worker] = []
        self.num_envs = check_int("num_envs", num_envs, 1, MAX_NUM_ENVS)
        self.workers = check_int("workers", workers, 1, self.num_envs)
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            allowed = [mode.value for mode in AutoresetMode]
            raise ValueError(
                f"autoreset_mode must be one of {allowed}, got {autoreset_mode!r}"
            ) from None
        if kwargs.get("render_mode") == "human" and self.num_envs > 1:
            raise ValueError(
                "render_mode='human' opens PyBullet's GUI, which one process can open once;"
                f" got num_envs={self.num_envs} (workers={self.workers})."
                " Use num_envs=1 or render_mode='rgb_array'."
            )
        if self.workers == 1:
            self._local = _Block(
                env_fn, kwargs, 0, self.num_envs, self.num_envs, self.autoreset_mode
            )
            description = _description(self._local.envs[0])
        else:
            description = self._start_workers(env_fn, kwargs)
        self.render_mode, metadata, single_obs_space, single_action_space = description
        self.metadata = {**metadata, "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = single_obs_space
        self.single_action_space = single_action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._started = np.zeros(self.num_envs, dtype=bool)  # reset at least once
        self._sizes = [worker.size for worker in self._workers] or [self.num_envs]

    @property
    def envs(self) -> list[gym.Env]:
        """The sub-envs, with ``workers=1``; with workers they live in the worker processes."""
        if self._local is None:
            raise RuntimeError(
                f"with workers={self.workers} the sub-envs live in worker processes;"
                " reach them with apply, call, get_attr or set_attr"
            )
        return self._local.envs

    # ------------------------------------------------------------------ vector API
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ):
        """Reset the sub-envs (those of ``options["reset_mask"]`` if given).

        Args:
            seed: ``None`` (fresh entropy), an int s (sub-env i gets s + i, as Gymnasium's
                vector envs do) or one seed (or ``None``) per sub-env in a list, tuple or array.
            options: passed to every sub-env's ``reset``; ``reset_mask`` (a bool array of
                shape ``(num_envs,)``) picks which sub-envs to reset.

        Returns:
            The batched observations (the others' last ones for sub-envs not reset) and
            the batched infos of the sub-envs reset.
        """
        seeds = self._seeds(seed)
        options = dict(options or {})
        mask = self._reset_mask(options.pop("reset_mask", None))
        parts = self._run(_Block.reset, options or None, rows=(seeds, mask))
        self._started |= mask
        return _join([obs for obs, _ in parts]), _join_infos(
            [info for _, info in parts], self._sizes
        )

    def step(self, actions):
        """Step every sub-env with its row of ``actions`` (an array of shape
        ``(num_envs, *single_action_space.shape)``); the autoreset mode says what an ended
        sub-env does."""
        actions = np.asarray(actions)
        expected = (self.num_envs, *self.single_action_space.shape)
        if actions.shape != expected:
            raise ValueError(f"actions must have shape {expected}, got {actions.shape}")
        obs, rewards, terminations, truncations, infos = zip(
            *self._run(_Block.step, rows=(actions,))
        )
        return (
            _join(obs),
            _join(rewards),
            _join(terminations),
            _join(truncations),
            _join_infos(infos, self._sizes),
        )

    def render(self) -> tuple[Any, ...]:
        """Every sub-env's frame (``render_mode="rgb_array"``), in order."""
        return self.apply(methodcaller("render"))

    def close_extras(self, **kwargs: Any) -> None:
        """Close every sub-env (and its PyBullet client) and stop the workers; ``close()``
        twice is safe."""
        if self._local is not None:
            self._local.close()
        workers, self._workers = self._workers, []
        for worker in workers:
            worker.stop()

    def __del__(self) -> None:
        # Gymnasium's VectorEnv does not close on garbage collection; the workers would
        # otherwise idle until this process exits.
        if not getattr(self, "closed", True):
            self.close()

    # ------------------------------------------------------------------ sub-env access
    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call the method ``name`` of every sub-env (or read it, if not callable)."""
        return self.apply(functools.partial(call_or_read, name=name, args=args, kwargs=kwargs))

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """The attribute ``name`` of every sub-env."""
        return self.apply(methodcaller("get_wrapper_attr", name))

    def apply(
        self, fn: Callable[[gym.Env], Any], indices: Sequence[int] | None = None
    ) -> tuple[Any, ...]:
        """``fn(sub_env)`` for the sub-envs ``indices`` (default: all), in the order of
        ``indices``, run where the sub-envs live: with workers ``fn`` must pickle (a
        module-level function, a ``functools.partial`` of one, an ``operator.methodcaller``)
        and its results come back as copies. What ``call``, ``get_attr`` and ``render`` use,
        and what a wrapper such as Stable-Baselines3's ``VecEnv`` (``indices``) needs.

        Raises:
            ValueError: an index that is not an integer in [0, ``num_envs``).
        """
        if indices is None:
            indices = range(self.num_envs)
        indices = [check_int("indices", i, 0, self.num_envs - 1) for i in indices]
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[indices] = True
        results = self._each(_Block.apply, fn, rows=(mask,))
        return tuple(results[i] for i in indices)

    def set_attr(self, name: str, values: Any) -> None:
        """Set ``name`` on every sub-env: one value each from a list or tuple of
        ``num_envs``, otherwise the same value for all."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                f"set_attr needs one value per sub-env ({self.num_envs}), got {len(values)}"
            )
        self._each(_Block.set_attr, name, rows=(values,))

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:
        """Every sub-env's ``np_random_seed``."""
        return self.get_attr("np_random_seed")

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """Every sub-env's random generator (with workers, copies: drawing from them does
        not move the sub-envs')."""
        return self.get_attr("np_random")

    # ------------------------------------------------------------------ helpers
    def _start_workers(self, env_fn: Callable[..., gym.Env], kwargs: dict) -> tuple:
        """Start the workers, each building its block; the first sub-env's description."""
        context = _context()
        sizes = [len(b) for b in np.array_split(np.arange(self.num_envs), self.workers)]
        firsts = np.cumsum([0, *sizes[:-1]]).tolist()
        # Worker k on the k-th of the CPUs this process may use, where the OS can pin and the
        # workers take all of those CPUs. With fewer workers than CPUs nothing is pinned:
        # other processes making workers (the jobs of a sweep) would pin theirs to the same
        # first CPUs and leave the rest idle.
        cpus = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_setaffinity") else []
        if len(cpus) != self.workers:
            cpus = []
        try:
            for k, (first, size) in enumerate(zip(firsts, sizes)):
                cpu = cpus[k] if cpus else None
                self._workers.append(
                    _Worker(
                        context,
                        k,
                        first,
                        size,
                        env_fn,
                        kwargs,
                        self.num_envs,
                        self.autoreset_mode,
                        cpu,
                    )
                )
            return self._exchange([])[0]
        except BaseException:  # env_fn or kwargs that do not pickle, or fail in a worker
            self.close()
            raise

    def _run(self, method: Callable, *args: Any, rows: Sequence[Sequence] = ()) -> list:
        """``method``, one of ``_Block``'s, on every block, with each block's slice of
        ``rows`` (one row per sub-env each) and then ``args``; the blocks' results, in order.
        In this process the block's method is called; a worker is sent its name, the one
        command its messages carry."""
        if self.closed:
            raise RuntimeError("this vector env is closed")
        if self._local is not None:
            return [method(self._local, *rows, *args)]
        name = method.__name__
        messages = []
        for worker in self._workers:
            block_rows = [row[worker.first : worker.first + worker.size] for row in rows]
            try:
                messages.append(pickle.dumps((name, (*block_rows, *args))))
            except Exception as error:
                raise TypeError(
                    f"the arguments of {name} must pickle to reach the worker processes: {error}"
                ) from error
        return self._exchange(messages)

    def _each(self, method: Callable, *args: Any, rows: Sequence[Sequence] = ()) -> tuple:
        """``_run`` of a method that gives one result per sub-env: the results, in order."""
        return tuple(result for part in self._run(method, *args, rows=rows) for result in part)

    def _exchange(self, messages: list[bytes]) -> list:
        """Send each worker its message (none: wait for the replies to their start), then
        every worker's reply, in order. The first error among the replies is raised once all
        have come, so that no reply is left in a pipe; a dead worker, or an interrupt while
        replies are due, closes the vector env for the same reason."""
        try:
            for worker, message in zip(self._workers, messages):
                worker.send(message)
            replies = [worker.receive() for worker in self._workers]
        except BaseException:
            self.close()
            raise
        for worker, reply in zip(self._workers, replies):
            if reply[0] == "error":
                _, error, where = reply
                error.add_note(f"raised in worker process {worker.index}:\n{where}")
                raise error
        return [reply[1] for reply in replies]

    def _seeds(self, seed) -> list[int | None]:
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, Integral) and not isinstance(seed, (bool, np.bool_)):
            return [int(seed) + i for i in range(n)]
        if isinstance(seed, np.ndarray) and seed.ndim == 1:
            seed = seed.tolist()
        if not isinstance(seed, (list, tuple)):
            raise ValueError(
                f"seed must be None, an int or a list of {n} seeds (one per sub-env), got {seed!r}"
            )
        if len(seed) != n:
            raise ValueError(
                f"seed must list one seed per sub-env: num_envs={n}, got {len(seed)} seeds"
            )
        return list(seed)

    def _reset_mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.num_envs, dtype=bool)
        mask = np.asarray(mask)
        if mask.dtype != np.bool_ or mask.shape != (self.num_envs,) or not mask.any():
            raise ValueError(
                f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with"
                f" at least one True, got {mask!r}"
            )
        if not self._started[~mask].all():
            raise ValueError("reset every sub-env once (no reset_mask) before a masked reset")
        return mask
