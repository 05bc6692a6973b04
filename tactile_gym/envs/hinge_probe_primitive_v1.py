"""Deprecated alias of ``tactile_gym.envs.hinge_probe_primitive``, renamed in 0.4 for what it
holds (the env serves every version; the ids name theirs). The old name goes in 0.5."""

import warnings

from tactile_gym.envs.hinge_probe_primitive import *  # noqa: F403
from tactile_gym.envs.hinge_probe_primitive import __all__  # noqa: F401

warnings.warn(
    "tactile_gym.envs.hinge_probe_primitive_v1 is renamed tactile_gym.envs.hinge_probe_primitive;"
    " the old name goes in 0.5",
    DeprecationWarning,
    stacklevel=2,
)
