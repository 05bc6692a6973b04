"""How a run uses the machine: the cores it may use, the processes that step its envs and
torch's threads (``docs/design.md`` 7.9).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import tactile_gym

__all__ = ["DEFAULT_TORCH_THREADS", "available_cpus", "choose_env_workers", "torch_threads"]

#: Torch threads of the learner unless told otherwise. The networks are small (two layers of
#: 128-256 units, batches of 128-256): on 2 cores shared with other jobs PPO trained 2.9-3.8x
#: faster on one thread than on two, and 1.06x on 2 quiet cores (benchmarks/bench_train.py);
#: extra threads mostly wait on each other and on the envs.
DEFAULT_TORCH_THREADS = 1


def available_cpus() -> int:
    """Cores this process may run on (its CPU affinity, not the machine's core count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS and Windows have no affinity call
        return os.cpu_count() or 1


def choose_env_workers(env_id: str, n_envs: int, n_cpus: int) -> int:
    """How many processes step the vector env's sub-envs (``workers``, ``docs/design.md``
    7.9): 1 is this process, beside the learner.

    A primitive id's step is a whole primitive, many control steps of env work for one round
    trip to a worker: one worker per env up to the cores, the learner (a small share of a
    core) sharing them. A 6-D id's step is one control step, about what a round trip costs:
    workers only when each gets a core of its own beside the learner, else in-process. The
    README ("Speed", ``benchmarks/bench_train.py``) has the measurements.

    Args:
        env_id: the id trained.
        n_envs: parallel envs.
        n_cpus: cores the run may use.
    """
    if env_id in tactile_gym.PRIMITIVE_ENV_IDS:
        return max(1, min(n_envs, n_cpus))
    return n_envs if n_envs > 1 and n_cpus >= n_envs + 1 else 1


@contextlib.contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run torch with ``n`` intra-op threads, restoring the previous number afterwards."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(previous)
