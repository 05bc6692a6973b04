"""Intrinsic contact sensing for a soft fingertip and its 6-axis force/torque sensor.

NumPy only: this package must import without pybullet, so real robots can reuse it.
"""

from tactile_gym.sensing.contact import (
    CONTACT_MODELS,
    CONTACT_SHAPES,
    EDGE_STD_UNOBSERVABLE,
    ContactEstimate,
    edge_from_trace,
    estimate_contact,
    indentation_depth,
)
from tactile_gym.sensing.geometry import FingertipGeometry, SurfaceSamples
from tactile_gym.sensing.sensor import SensorConfig

__all__ = [
    "CONTACT_MODELS",
    "CONTACT_SHAPES",
    "EDGE_STD_UNOBSERVABLE",
    "ContactEstimate",
    "FingertipGeometry",
    "SensorConfig",
    "SurfaceSamples",
    "edge_from_trace",
    "estimate_contact",
    "indentation_depth",
]
