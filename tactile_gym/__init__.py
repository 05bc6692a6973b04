"""tactile_gym: active tactile perception of articulated objects.

Importing the package registers its environments with Gymnasium::

    import gymnasium as gym
    import tactile_gym  # noqa: F401

    env = gym.make("tactile_gym/HingeProbe-v0")

``tactile_gym.sensing`` and ``tactile_gym.estimation`` import without pybullet; the
environment modules are only imported when an env is made.
"""

from gymnasium.envs.registration import register

__version__ = "0.1.0"

MAX_EPISODE_STEPS = 200

#: Every registered environment id.
ENV_IDS: tuple[str, ...] = ("tactile_gym/HingeProbe-v0", "tactile_gym/HingeProbe3D-v0")

register(
    id="tactile_gym/HingeProbe-v0",
    entry_point="tactile_gym.envs.hinge_probe_v0:HingeProbeEnv",
    max_episode_steps=MAX_EPISODE_STEPS,
    kwargs={"families": ("scissors",), "estimator_mode": "planar"},
)
register(
    id="tactile_gym/HingeProbe3D-v0",
    entry_point="tactile_gym.envs.hinge_probe_v0:HingeProbeEnv",
    max_episode_steps=MAX_EPISODE_STEPS,
    kwargs={"families": ("scissors", "door", "lid", "tilted"), "estimator_mode": "3d"},
)

__all__ = ["ENV_IDS", "MAX_EPISODE_STEPS", "__version__"]
