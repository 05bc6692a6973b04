"""Intrinsic contact sensing for a soft fingertip and its 6-axis force/torque sensor.

NumPy only: this package must import without pybullet, so real robots can reuse it
(``docs/design.md`` 5).
"""

from tactile_gym.sensing.contact import ContactEstimate, estimate_contact
from tactile_gym.sensing.contact_point import CONTACT_MODELS
from tactile_gym.sensing.edge import EDGE_STD_UNOBSERVABLE, edge_from_trace
from tactile_gym.sensing.geometry import FingertipGeometry, SurfaceSamples
from tactile_gym.sensing.indentation import CONTACT_SHAPES, indentation_depth
from tactile_gym.sensing.probing import (
    GradientEstimate,
    HoldRule,
    PressConfig,
    PressController,
    Touch,
    TouchSensor,
    effective_readings,
    predicted_edge_std,
    run_press,
)
from tactile_gym.sensing.sensor import (
    RELEASE_FORCE,
    SENSOR_MODELS,
    TARE_SAMPLES,
    TOUCH_FORCE,
    SensorConfig,
    SensorErrors,
    Tare,
    fingertip_mass_properties,
    gravity_wrench,
)

__all__ = [
    "CONTACT_MODELS",
    "CONTACT_SHAPES",
    "EDGE_STD_UNOBSERVABLE",
    "RELEASE_FORCE",
    "SENSOR_MODELS",
    "TARE_SAMPLES",
    "TOUCH_FORCE",
    "ContactEstimate",
    "FingertipGeometry",
    "GradientEstimate",
    "HoldRule",
    "PressConfig",
    "PressController",
    "SensorConfig",
    "SensorErrors",
    "SurfaceSamples",
    "Tare",
    "Touch",
    "TouchSensor",
    "edge_from_trace",
    "effective_readings",
    "estimate_contact",
    "fingertip_mass_properties",
    "gravity_wrench",
    "indentation_depth",
    "predicted_edge_std",
    "run_press",
]
