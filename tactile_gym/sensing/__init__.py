"""Intrinsic contact sensing for a soft fingertip on a 6-axis force/torque sensor.

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

__all__ = [
    "CONTACT_MODELS",
    "CONTACT_SHAPES",
    "EDGE_STD_UNOBSERVABLE",
    "ContactEstimate",
    "FingertipGeometry",
    "SurfaceSamples",
    "edge_from_trace",
    "estimate_contact",
    "indentation_depth",
]
