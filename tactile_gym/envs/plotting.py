"""Deprecated alias of ``tactile_gym.plotting``, which moved out of the envs in 0.4 so that
the log replay draws without the simulator. The old name goes in 0.5."""

import warnings

from tactile_gym.plotting import *  # noqa: F403
from tactile_gym.plotting import __all__  # noqa: F401

warnings.warn(
    "tactile_gym.envs.plotting moved to tactile_gym.plotting; the old name goes in 0.5",
    DeprecationWarning,
    stacklevel=2,
)
