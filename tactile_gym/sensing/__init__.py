"""Intrinsic contact sensing for a soft fingertip on a 6-axis force/torque sensor.

NumPy only: this package must import without pybullet, so real robots can reuse it.
"""

from tactile_gym.sensing.geometry import FingertipGeometry, SurfaceSamples

__all__ = ["FingertipGeometry", "SurfaceSamples"]
