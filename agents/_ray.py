"""Ray, imported only here and only when a sweep or a parallel evaluation asks for it.

Ray is the optional ``[sweep]`` extra: the env, ``agents.train`` and a serial
``agents.evaluate`` never import it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

from .cli import require


def import_ray():
    """The ``ray`` module, or an ImportError that says how to install it."""
    return require("ray", "train,sweep")


@contextlib.contextmanager
def ray_session(address: str | None = None, num_cpus: int | None = None) -> Iterator:
    """Ray, initialised for the block.

    Args:
        address: a running cluster to join (``"auto"``, ``"host:port"``, ``"ray://..."``);
            ``None`` starts Ray embedded in this process (or uses one already initialised).
            Run from a repository checkout, the ``agents`` package is shipped to the
            cluster's workers (Ray ``py_modules``); ``tactile_gym`` and the extras must be
            installed on every node.
        num_cpus: CPUs of an embedded Ray; ``None`` gives it all of this machine's.

    Yields:
        The ``ray`` module. Ray is shut down after the block if this call started it.
    """
    ray = import_ray()
    started = False
    if not ray.is_initialized():
        if address:
            runtime_env = {}
            if __package__ == "agents":  # a checkout: remote workers cannot import it otherwise
                runtime_env["py_modules"] = [str(Path(__file__).parent)]
            ray.init(address=address, runtime_env=runtime_env, log_to_driver=False)
        else:
            ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
        started = True
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()
