"""tactile_gym: active tactile perception of articulated objects.

Importing the package registers its environments with Gymnasium::

    import gymnasium as gym
    import tactile_gym  # noqa: F401

    env = gym.make("tactile_gym/HingeProbe-v2")

``tactile_gym.sensing`` and ``tactile_gym.estimation`` import without pybullet; the
environment modules are only imported when an env is made.

The v2 ids are the current ones: a realistic F/T sensor (offset, drift, the fingertip's weight)
and taring. The v1 ids (``LEGACY_ENV_IDS``: the ideal sensor, a 6-D action, no tare) stay
registered unchanged, so that models trained on them still run. The v0 ids are retired: their
skin model gave no edge direction from a pure press and their start pose revealed the edge
(``docs/design.md``, "Versions").
"""

from gymnasium.envs.registration import register

__version__ = "0.2.0"

_PLANAR = {"families": ("scissors",), "estimator": "planar"}
# The lid is left out of the 3D mix: lying on the table it can only be pushed shut, so a
# fingertip from above cannot turn it (docs/design.md, "Known limits"); families=("lid",)
# still builds it.
_3D = {"families": ("scissors", "door", "tilted"), "estimator": "3d"}

# v1: the ideal sensor (white noise only) and no tare (docs/design.md 10).
_V1 = {"sensor_model": "ideal", "tare_action": False}

#: The current environment ids: two tasks (the paper's planar scissors; scissors, doors and
#: tilted axes with a 3D estimator), each with two action modes on the same physics (6-D
#: fingertip motions and a tare, or probing primitives that run the former underneath).
ENV_IDS: tuple[str, ...] = (
    "tactile_gym/HingeProbe-v2",
    "tactile_gym/HingeProbe3D-v2",
    "tactile_gym/HingeProbePrimitive-v2",
    "tactile_gym/HingeProbe3DPrimitive-v2",
)
#: The v1 ids, the same tasks with the ideal sensor and no tare.
LEGACY_ENV_IDS: tuple[str, ...] = tuple(i.replace("-v2", "-v1") for i in ENV_IDS)

register(
    id="tactile_gym/HingeProbe-v2",
    entry_point="tactile_gym.envs.hinge_probe_v1:HingeProbeEnv",
    kwargs=_PLANAR,
)
register(
    id="tactile_gym/HingeProbe3D-v2",
    entry_point="tactile_gym.envs.hinge_probe_v1:HingeProbeEnv",
    kwargs=_3D,
)
register(
    id="tactile_gym/HingeProbePrimitive-v2",
    entry_point="tactile_gym.envs.hinge_probe_primitive_v1:make_primitive_env",
    kwargs=_PLANAR,
)
register(
    id="tactile_gym/HingeProbe3DPrimitive-v2",
    entry_point="tactile_gym.envs.hinge_probe_primitive_v1:make_primitive_env",
    kwargs=_3D,
)
register(
    id="tactile_gym/HingeProbe-v1",
    entry_point="tactile_gym.envs.hinge_probe_v1:HingeProbeEnv",
    kwargs={**_PLANAR, **_V1},
)
register(
    id="tactile_gym/HingeProbe3D-v1",
    entry_point="tactile_gym.envs.hinge_probe_v1:HingeProbeEnv",
    kwargs={**_3D, **_V1},
)
register(
    id="tactile_gym/HingeProbePrimitive-v1",
    entry_point="tactile_gym.envs.hinge_probe_primitive_v1:make_primitive_env",
    kwargs={**_PLANAR, **_V1},
)
register(
    id="tactile_gym/HingeProbe3DPrimitive-v1",
    entry_point="tactile_gym.envs.hinge_probe_primitive_v1:make_primitive_env",
    kwargs={**_3D, **_V1},
)

__all__ = ["ENV_IDS", "LEGACY_ENV_IDS", "__version__"]
