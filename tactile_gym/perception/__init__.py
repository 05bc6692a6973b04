"""Perception for a real or a simulated robot: F/T readings and fingertip poses in, the
joint axis out. NumPy and SciPy only: no simulator, no Gymnasium.

* :class:`MeasurementPipeline` joins the tare, the reading of a wrench
  (``tactile_gym.sensing.TouchSensor``), the measurement gate, its same-edge test and the
  online estimator, fed one :class:`Sample` at a time (``pipeline``);
* :class:`MeasurementGate` and :class:`GateConfig`: which touches become measurements, each
  refusal named by its rule (``gate``, ``docs/design.md`` 7.2);
* :class:`JointPipeline`: the same pipeline for an unknown joint, its presses labelled by edge
  line and link configuration (:class:`LabelConfig`) for the joint-type estimator
  (``joints``, ``docs/design.md`` 7.12).

The env (``tactile_gym.envs``) and the log replay (``tactile_gym.replay``) feed the same
pipeline; what is known before touching (the estimator's prior, the probed edge's distance
from the axis) is handed to it.
"""

from tactile_gym.perception.gate import GATE_RULES, GateConfig, Measurement, MeasurementGate
from tactile_gym.perception.joints import JointPipeline, LabelConfig
from tactile_gym.perception.pipeline import (
    DISTINCT_ANGLE,
    STREAM_FAULTS,
    MeasurementPipeline,
    Perceived,
    PressRecord,
    Sample,
    StreamLimits,
    TareRecord,
)

__all__ = [
    "DISTINCT_ANGLE",
    "GATE_RULES",
    "STREAM_FAULTS",
    "GateConfig",
    "JointPipeline",
    "LabelConfig",
    "Measurement",
    "MeasurementGate",
    "MeasurementPipeline",
    "Perceived",
    "PressRecord",
    "Sample",
    "StreamLimits",
    "TareRecord",
]
