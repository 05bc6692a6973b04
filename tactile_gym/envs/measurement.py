"""Deprecated alias of ``tactile_gym.perception.pipeline``: the measurement gate and pipeline
moved to ``tactile_gym.perception`` in 0.4, so that a robot runs them without the simulator.
The old name goes in 0.5."""

import warnings

from tactile_gym.perception.pipeline import *  # noqa: F403
from tactile_gym.perception.pipeline import __all__  # noqa: F401

warnings.warn(
    "tactile_gym.envs.measurement moved to tactile_gym.perception.pipeline;"
    " the old name goes in 0.5",
    DeprecationWarning,
    stacklevel=2,
)
