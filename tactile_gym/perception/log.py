"""The log of a probing session, real or simulated, and its replay through the pipeline.

A log is one row per F/T sample with the fingertip's pose and the robot's events, and a header
that says what the pipeline needs to read it. It is stored as NPZ (arrays; no pickle) or CSV
(a ``# header:`` line of JSON, then a row of column names, then the rows):

| column             | meaning                                                  | unit      |
|--------------------|----------------------------------------------------------|-----------|
| time               | when the sample was read, increasing                     | s         |
| fx, fy, fz         | force on the fingertip, sensor frame                     | N         |
| mx, my, mz         | moment about the sensor origin, sensor frame             | N m       |
| x, y, z            | the sensor origin, world frame (z up)                    | m         |
| qx, qy, qz, qw     | the fingertip's orientation, sensor to world (unit)      | -         |
| tare               | 1: the robot tared on this row's reading (held still in  | -         |
|                    | free air; the reading is the tare's mean), else 0        |           |
| lift               | 1: the robot lifted off here, else 0                     | -         |

The wrench is raw (offset, drift and the fingertip's weight included) unless the header says
``tared``. The header (:class:`LogHeader`) holds the sample period, the skin's stiffness, the
fingertip's geometry, the sensor's noise (per row) and mass properties, and optionally the gate's
thresholds, the estimator (mode, loss, prior) and the probed edge's expected distance from the
axis. A simulated episode's truth goes in a separate sidecar (``<log>.truth.json``), which only
scoring reads.

:func:`load_log` refuses a log that cannot be read right, in one line naming the problem
(:class:`LogError`): missing columns, time that goes backwards, values that are not finite, a
period or units that do not match (a wrench in N mm, positions in mm, time in ms). A repeated
time, a dropped sample or a pose jump within a log are the pipeline's to flag: the press they
break is refused with its reason (``tactile_gym.perception.pipeline``). :func:`replay` runs a
log through the pipeline. NumPy only (CSV through the standard library).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tactile_gym.estimation import AxisPrior, JointAxisEstimator
from tactile_gym.perception.gate import GateConfig
from tactile_gym.perception.pipeline import MeasurementPipeline, Sample, StreamLimits
from tactile_gym.sensing import FingertipGeometry, SensorConfig
from tactile_gym.spatial import matrix_to_quaternion, quaternion_to_matrix
from tactile_gym.validation import build_config, check_choice, check_number

__all__ = [
    "COLUMNS",
    "LOG_FORMAT",
    "LogError",
    "LogHeader",
    "ProbeLog",
    "load_log",
    "replay",
    "truth_path",
]

#: The format's name and version, written into every header.
LOG_FORMAT = "tactile_gym.log/1"
#: The columns of a log, in order (module docstring).
COLUMNS = ("time", "fx", "fy", "fz", "mx", "my", "mz", "x", "y", "z")
COLUMNS += ("qx", "qy", "qz", "qw", "tare", "lift")
#: Positions beyond this distance from the world origin are taken for millimetres, m.
MAX_POSITION = 5.0
#: Moments this many times the fingertip's longest lever times the force are taken for N mm.
MAX_LEVER_RATIO = 10.0


class LogError(ValueError):
    """A log that cannot be read right; the message is one line naming the problem."""


@dataclass(frozen=True)
class LogHeader:
    """What the pipeline needs to know to read a log.

    Attributes:
        period: the time between samples, s.
        skin_stiffness: Winkler modulus of the skin, N/m^3 (the indentation correction).
        tared: the wrench is already tared and gravity-compensated.
        fingertip: ``FingertipGeometry`` fields (m); the package's defaults otherwise.
        sensor: ``SensorConfig`` fields: the noise of one row (N, N m), the drift, the
            fingertip's mass (kg) and centre of mass (sensor frame, m); the package's
            defaults otherwise.
        gate: ``GateConfig`` fields that differ from the defaults.
        estimator: ``mode`` (``"planar"``: a vertical axis; ``"3d"``), ``loss`` and
            ``covariance`` (``tactile_gym.estimation.COVARIANCES``).
        prior: the axis prior (``AxisPrior`` fields: ``pin``, ``pin_cov``, ``direction``,
            ``angle_std``; m, m^2, rad), or None.
        edge_distance: the probed edge's expected distance from the axis (mean, std), m, or
            None.
        source: where the log came from (free text).
    """

    period: float
    skin_stiffness: float
    tared: bool = False
    fingertip: dict = field(default_factory=dict)
    sensor: dict = field(default_factory=dict)
    gate: dict = field(default_factory=dict)
    estimator: dict = field(default_factory=lambda: {"mode": "3d", "loss": "soft_l1"})
    prior: dict | None = None
    edge_distance: tuple[float, float] | None = None
    source: str = ""

    def __post_init__(self) -> None:
        check_number("header.period", self.period, 0.0, 10.0, low_open=True)
        check_number("header.skin_stiffness", self.skin_stiffness, 0.0, 1e12, low_open=True)
        check_choice("header.estimator.mode", self.estimator.get("mode"), ("planar", "3d"))
        self.geometry()
        self.sensor_config()
        self.gate_config()
        self.axis_prior()

    def geometry(self) -> FingertipGeometry:
        return build_config(FingertipGeometry, self.fingertip, "header.fingertip")

    def sensor_config(self) -> SensorConfig:
        return build_config(SensorConfig, self.sensor, "header.sensor")

    def gate_config(self) -> GateConfig:
        return build_config(GateConfig, self.gate, "header.gate")

    def axis_prior(self) -> AxisPrior | None:
        if self.prior is None:
            return None
        return AxisPrior(**{k: np.asarray(v, dtype=float) for k, v in self.prior.items()})

    def pipeline(self) -> MeasurementPipeline:
        """A measurement pipeline for this log."""
        estimator = JointAxisEstimator(
            mode=self.estimator["mode"],
            loss=self.estimator.get("loss", "soft_l1"),
            prior=self.axis_prior(),
            covariance=self.estimator.get("covariance", "independent"),
        )
        distance = None if self.edge_distance is None else tuple(self.edge_distance)
        return MeasurementPipeline(
            self.geometry(),
            self.sensor_config(),
            self.skin_stiffness,
            self.gate_config(),
            estimator,
            distance,
            StreamLimits(period=self.period),
        )

    def as_json(self) -> dict[str, Any]:
        """The header as JSON values, with the format's name."""
        return {"format": LOG_FORMAT, **_jsonable(dataclasses.asdict(self))}

    @classmethod
    def from_json(cls, values: Any, where: str) -> LogHeader:
        if not isinstance(values, dict) or values.get("format") != LOG_FORMAT:
            raise LogError(f"{where}: the header is not a {LOG_FORMAT} header")
        fields = {k: v for k, v in values.items() if k != "format"}
        try:
            return build_config(cls, fields, "header")
        except (TypeError, ValueError) as error:
            raise LogError(f"{where}: {error}") from None


@dataclass(frozen=True, eq=False)
class ProbeLog:
    """A log (module docstring): the header and one row per sample.

    Attributes:
        header: the header.
        time: (N,) s.
        wrench: (N, 6) N and N m, sensor frame.
        position: (N, 3) m, world frame.
        quaternion: (N, 4) x y z w, sensor to world.
        tare, lift: (N,) the events.
    """

    header: LogHeader
    time: np.ndarray
    wrench: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    tare: np.ndarray
    lift: np.ndarray

    def __len__(self) -> int:
        return len(self.time)

    def samples(self) -> Iterator[Sample]:
        """The rows as pipeline samples."""
        tared = self.header.tared
        for k in range(len(self)):
            yield Sample(
                time=float(self.time[k]),
                wrench=self.wrench[k],
                position=self.position[k],
                rotation=quaternion_to_matrix(self.quaternion[k]),
                tared=tared,
                tare=bool(self.tare[k]),
                lift=bool(self.lift[k]),
            )

    def table(self) -> np.ndarray:
        """(N, 16) the rows in ``COLUMNS`` order."""
        events = np.stack([self.tare, self.lift], axis=1).astype(float)
        return np.hstack([self.time[:, None], self.wrench, self.position, self.quaternion, events])

    def save(self, path: str | Path) -> Path:
        """Write the log to ``path``: NPZ, or CSV when its suffix is ``.csv``."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        header = json.dumps(self.header.as_json())
        if path.suffix == ".csv":
            with path.open("w", newline="") as f:
                f.write(f"# header: {header}\n")
                writer = csv.writer(f)
                writer.writerow(COLUMNS)
                for row in self.table():
                    writer.writerow([repr(float(v)) for v in row])
            return path
        arrays = {name: getattr(self, name) for name in ("time", "wrench", "position")}
        arrays |= {"quaternion": self.quaternion, "tare": self.tare, "lift": self.lift}
        np.savez_compressed(path, header=np.array(header), **arrays)
        return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")

    @classmethod
    def from_samples(cls, header: LogHeader, samples: list[Sample]) -> ProbeLog:
        """The log of samples (a recorder's), each pose's rotation as a quaternion."""
        return cls(
            header=header,
            time=np.array([s.time for s in samples], dtype=float),
            wrench=np.array([s.wrench for s in samples], dtype=float).reshape(-1, 6),
            position=np.array([s.position for s in samples], dtype=float).reshape(-1, 3),
            quaternion=np.array(
                [matrix_to_quaternion(s.rotation) for s in samples], dtype=float
            ).reshape(-1, 4),
            tare=np.array([s.tare for s in samples], dtype=bool),
            lift=np.array([s.lift for s in samples], dtype=bool),
        )


def truth_path(path: str | Path) -> Path:
    """The truth sidecar of a simulated log (``<log>.truth.json``)."""
    path = Path(path)
    return path.with_name(path.name + ".truth.json")


def load_log(path: str | Path) -> ProbeLog:
    """Read and check a log (module docstring).

    Raises:
        LogError: one line naming what is wrong with the log.
    """
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise LogError(f"{where}: no such log file")
    if path.suffix == ".csv":
        header, table = _read_csv(path, where)
    else:
        header, table = _read_npz(path, where)
    log = ProbeLog(
        header=header,
        time=table[:, 0],
        wrench=table[:, 1:7],
        position=table[:, 7:10],
        quaternion=table[:, 10:14],
        tare=table[:, 14] != 0,
        lift=table[:, 15] != 0,
    )
    _check(log, where)
    return log


def replay(log: ProbeLog) -> MeasurementPipeline:
    """Run a log through a pipeline built from its header; return the pipeline after the last
    sample (its ``measurements``, ``estimate``, ``presses`` and ``tares``)."""
    pipeline = log.header.pipeline()
    samples = log.samples()
    pipeline.reset(next(samples))
    for sample in samples:
        pipeline.step(sample)
    return pipeline


# ---------------------------------------------------------------------- reading
def _read_npz(path: Path, where: str) -> tuple[LogHeader, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except Exception as error:  # not a zip, truncated, or object arrays (pickle)
        raise LogError(f"{where}: not a readable NPZ log ({type(error).__name__})") from None
    needed = ("header", "time", "wrench", "position", "quaternion", "tare", "lift")
    missing = [name for name in needed if name not in arrays]
    if missing:
        raise LogError(f"{where}: missing array(s) {missing}; a log has {list(needed)}")
    try:
        header = LogHeader.from_json(json.loads(str(arrays["header"])), where)
    except json.JSONDecodeError:
        raise LogError(f"{where}: the header is not JSON") from None
    n = len(arrays["time"])
    shapes = {"time": (n,), "wrench": (n, 6), "position": (n, 3), "quaternion": (n, 4)}
    shapes |= {"tare": (n,), "lift": (n,)}
    for name, shape in shapes.items():
        if arrays[name].shape != shape:
            raise LogError(f"{where}: {name} has shape {arrays[name].shape}, expected {shape}")
    columns = [arrays["time"][:, None], arrays["wrench"], arrays["position"]]
    columns += [arrays["quaternion"], arrays["tare"][:, None], arrays["lift"][:, None]]
    return header, np.hstack([np.asarray(c, dtype=float) for c in columns])


def _read_csv(path: Path, where: str) -> tuple[LogHeader, np.ndarray]:
    text = path.read_text()
    first, _, rest = text.partition("\n")
    if not first.startswith("# header:"):
        raise LogError(f"{where}: the first line must be '# header: {{...}}' (JSON)")
    try:
        header = LogHeader.from_json(json.loads(first[len("# header:") :]), where)
    except json.JSONDecodeError:
        raise LogError(f"{where}: the header is not JSON") from None
    reader = csv.reader(io.StringIO(rest))
    names = [name.strip() for name in next(reader, [])]
    missing = [name for name in COLUMNS if name not in names]
    if missing:
        raise LogError(f"{where}: missing column(s) {missing}; a log has {list(COLUMNS)}")
    index = [names.index(name) for name in COLUMNS]
    rows = []
    for line, row in enumerate(reader, start=3):
        if not row:
            continue
        try:
            rows.append([float(row[i]) for i in index])
        except (ValueError, IndexError):
            raise LogError(f"{where}: line {line} is not {len(names)} numbers") from None
    return header, np.array(rows, dtype=float).reshape(-1, len(COLUMNS))


def _check(log: ProbeLog, where: str) -> None:
    """Refuse what cannot be read right (module docstring)."""
    if len(log) < 2:
        raise LogError(f"{where}: {len(log)} row(s); a log needs at least 2")
    table = log.table()
    bad = np.argwhere(~np.isfinite(table))
    if len(bad):
        row, column = bad[0]
        raise LogError(
            f"{where}: row {row} column {COLUMNS[column]} is {table[row, column]}; a log's"
            " readings, poses and times must be finite"
        )
    steps = np.diff(log.time)
    if (steps < 0).any():
        row = int(np.argmax(steps < 0)) + 1
        raise LogError(
            f"{where}: time goes backwards at row {row} ({log.time[row - 1]!r} s, then"
            f" {log.time[row]!r} s); a log's time must increase"
        )
    period = log.header.period
    step = float(np.median(steps))
    if not 0.5 * period <= step <= 2.0 * period:
        raise LogError(
            f"{where}: the rows are {step:.4g} s apart, the header's period is {period:g} s"
            " (is time in milliseconds? it must be seconds)"
        )
    reach = float(np.abs(log.position).max())
    if reach > MAX_POSITION:
        raise LogError(
            f"{where}: positions reach {reach:.4g} from the origin, more than {MAX_POSITION:g} m"
            " (are they in millimetres? they must be metres)"
        )
    norms = np.linalg.norm(log.quaternion, axis=1)
    if np.abs(norms - 1.0).max() > 1e-3:
        row = int(np.argmax(np.abs(norms - 1.0)))
        raise LogError(f"{where}: the quaternion of row {row} has norm {norms[row]:.4g}, not 1")
    force = np.linalg.norm(log.wrench[:, :3], axis=1)
    moment = np.linalg.norm(log.wrench[:, 3:], axis=1)
    geometry = log.header.geometry()
    lever = geometry.cylinder_length + geometry.outer_radius
    loaded = force > 1.0
    if loaded.any() and np.median(moment[loaded] / force[loaded]) > MAX_LEVER_RATIO * lever:
        raise LogError(
            f"{where}: the moments are {np.median(moment[loaded] / force[loaded]):.3g} m times"
            f" the force, far beyond the fingertip's {lever * 1e3:.0f} mm (are they in N mm?"
            " they must be N m)"
        )


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value
