"""Everything that imports pybullet: world, hinged objects, soft skin, F/T sensor, scene.

Frames: world (z up, table top at z = 0) and sensor (origin at the F/T sensor, z along the
finger axis). SI units throughout.
"""

# First: pybullet without its start-up line, before the modules below import it.
from tactile_gym.sim import _pybullet  # noqa: F401, I001
from tactile_gym.sensing import SensorConfig  # re-exported: the sensor is a sensing concept
from tactile_gym.sim.config import ObjectConfig, SkinConfig
from tactile_gym.sim.objects import HingedObject
from tactile_gym.sim.scene import ProbeScene, StepInfo
from tactile_gym.sim.skin import SoftSkin
from tactile_gym.sim.world import World

__all__ = [
    "HingedObject",
    "ObjectConfig",
    "ProbeScene",
    "SensorConfig",
    "SkinConfig",
    "SoftSkin",
    "StepInfo",
    "World",
]
