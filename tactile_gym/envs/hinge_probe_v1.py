"""HingeProbe v1: estimate the joint axis of a hinged object with a soft tactile fingertip."""

from __future__ import annotations

import dataclasses
import functools
import os
import sys
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.gate import GateConfig, Measurement, MeasurementGate, line_distance
from tactile_gym.envs.scenarios import FAMILIES, ScenarioConfig, probed_edge, sample_scenario
from tactile_gym.envs.task import (
    TERMINATION_REASONS,
    AxisEstimationTask,
    StepFacts,
    TaskConfig,
)
from tactile_gym.envs.touch import Touch, TouchSensor
from tactile_gym.estimation import LOSSES, AxisEstimate, AxisPrior, JointAxisEstimator, axis_error
from tactile_gym.sensing import FingertipGeometry, SensorConfig
from tactile_gym.sim import ObjectConfig, ProbeScene, SkinConfig
from tactile_gym.sim.scene import FORCE_LIMIT
from tactile_gym.sim.world import SUBSTEPS, TIME_STEP
from tactile_gym.validation import (
    build_config,
    check_bool,
    check_choice,
    check_int,
    check_number,
)

__all__ = ["HingeProbeConfig", "HingeProbeEnv", "OBSERVATION_LAYOUT"]

#: Physical bounds of the observation entries (observations are clipped to them).
FORCE_BOUND = 60.0  # N
MOMENT_BOUND = 3.0  # N m
POSITION_BOUND = 1.0  # m
STD_BOUND = 1.0  # m
MAX_MEASUREMENTS = 10_000.0

#: Entries of the flat observation, in order (Gymnasium sorts Dict keys), with their sizes.
OBSERVATION_LAYOUT: tuple[tuple[str, int], ...] = (
    ("contact", 12),
    ("estimate", 8),
    ("fingertip_pose", 7),
    ("last_measurement", 7),
    ("progress", 5),
    ("wrench", 6),
)

#: Edge directions closer than this count as one link angle in ``progress``, rad.
DISTINCT_ANGLE = float(np.deg2rad(3.0))
#: Scenario draws behind the prior (the reset distribution's), from a fixed seed.
PRIOR_SAMPLES = 512


@dataclass(frozen=True)
class HingeProbeConfig:
    """Every parameter of the env; each is a keyword of ``gym.make``.

    The physical parameters are nested: ``skin``, ``sensor`` and ``object`` take fields of
    :class:`~tactile_gym.sim.SkinConfig`, :class:`~tactile_gym.sensing.SensorConfig` and
    :class:`~tactile_gym.sim.ObjectConfig` (the last applied to every family before the reset
    draws); ``gate``, ``task`` and ``scenario`` take fields of ``GateConfig``, ``TaskConfig``
    and ``ScenarioConfig``. Each holds only what differs from those classes' defaults.

    Attributes:
        families: object families drawn at reset, from ``scissors, door, lid, tilted``.
        estimator: ``"planar"`` (axis along world z, paper eq. 16-21) or ``"3d"``.
        estimator_loss: robust loss of the estimator (``tactile_gym.estimation.LOSSES``).
        observation_mode: ``"dict"`` or ``"flat"`` (one Box, see ``OBSERVATION_LAYOUT``).
        max_steps: control steps before the episode is truncated.
        time_step: physics time step, s.
        substeps: physics steps per control step (12 at 1/240 s gives 20 Hz control).
        max_translation: fingertip translation for an action of 1, m (10 um to 10 mm).
        max_rotation: fingertip rotation for an action of 1, rad.
        force_limit: guard that stops the fingertip advancing, and where the force penalty
            starts, N.
        randomize: draw the object, joint angle and fingertip start at reset; when False
            every reset uses the nominal scenario.
        skin, sensor, object, gate, task, scenario: nested overrides (above).
    """

    families: tuple[str, ...] = ("scissors",)
    estimator: str = "planar"
    estimator_loss: str = "soft_l1"
    observation_mode: str = "dict"
    max_steps: int = 400
    time_step: float = TIME_STEP
    substeps: int = SUBSTEPS
    max_translation: float = 0.002
    max_rotation: float = float(np.deg2rad(3.0))
    force_limit: float = FORCE_LIMIT
    randomize: bool = True
    skin: dict = field(default_factory=dict)
    sensor: dict = field(default_factory=dict)
    object: dict = field(default_factory=dict)
    gate: dict = field(default_factory=dict)
    task: dict = field(default_factory=dict)
    scenario: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        families = (self.families,) if isinstance(self.families, str) else self.families
        if not isinstance(families, (tuple, list)) or not families:
            raise ValueError(f"families must be a non-empty list from {FAMILIES}, got {families!r}")
        for family in families:
            check_choice("families[...]", family, FAMILIES)
        object.__setattr__(self, "families", tuple(families))
        check_choice("estimator", self.estimator, ("planar", "3d"))
        check_choice("estimator_loss", self.estimator_loss, LOSSES)
        check_choice("observation_mode", self.observation_mode, ("dict", "flat"))
        if self.estimator == "planar" and set(self.families) - {"scissors"}:
            raise ValueError(
                "estimator='planar' assumes a vertical axis, which only the 'scissors' family"
                f" has; got families {self.families}. Use estimator='3d'."
            )
        check_int("max_steps", self.max_steps, 1, 100_000)
        check_number("time_step", self.time_step, 1e-4, 0.02)
        check_int("substeps", self.substeps, 1, 100)
        check_number("max_translation", self.max_translation, 1e-5, 0.01)
        check_number("max_rotation", self.max_rotation, 0.0, 0.2, low_open=True)
        check_number("force_limit", self.force_limit, 0.5, 50.0)
        check_bool("randomize", self.randomize)
        # Build every nested config once, so that a bad field fails here, at construction.
        self.skin_config()
        self.sensor_config()
        axis = np.asarray(self.object_config("scissors").axis)
        if self.estimator == "planar" and abs(axis[2]) < (1.0 - 1e-9) * np.linalg.norm(axis):
            raise ValueError(
                f"estimator='planar' assumes a vertical axis, got object.axis {axis.tolist()}."
                " Use estimator='3d'."
            )
        self.gate_config()
        self.scenario_config()
        task = self.task_config()
        if not task.hard_force_limit > self.force_limit:
            raise ValueError(
                f"task.hard_force_limit must exceed force_limit ({self.force_limit} N),"
                f" got {task.hard_force_limit!r}"
            )

    def skin_config(self) -> SkinConfig:
        return build_config(SkinConfig, self.skin, "skin")

    def sensor_config(self) -> SensorConfig:
        return build_config(SensorConfig, self.sensor, "sensor")

    def object_config(self, family: str) -> ObjectConfig:
        """The nominal object of a family with the ``object`` overrides."""
        if not isinstance(self.object, dict) or not all(isinstance(k, str) for k in self.object):
            raise ValueError(f"object must be a dict of ObjectConfig fields, got {self.object!r}")
        return ObjectConfig.family_default(family, **self.object)

    def gate_config(self) -> GateConfig:
        return build_config(GateConfig, self.gate, "gate")

    def task_config(self) -> TaskConfig:
        return build_config(TaskConfig, self.task, "task")

    def scenario_config(self) -> ScenarioConfig:
        return build_config(ScenarioConfig, self.scenario, "scenario")

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any]) -> HingeProbeConfig:
        """Build a config from keywords, rejecting unknown ones with the allowed list."""
        allowed = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(kwargs) - set(allowed))
        if unknown:
            raise ValueError(f"unknown HingeProbe keyword(s) {unknown}; allowed: {allowed}")
        return cls(
            **{
                k: tuple(v) if k == "families" and isinstance(v, list) else v
                for k, v in kwargs.items()
            }
        )


def _display_available() -> bool:
    """Whether PyBullet's GUI can open a window (X11 or Wayland on Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class HingeProbeEnv(gym.Env):
    """Probe a hinged object with a soft fingertip and estimate its joint axis.

    ## Description

    A kinematic fingertip (aluminium shell of radius 11 mm under a 5 mm silicone skin, on a
    6-axis force/torque sensor) probes the free link of a two-link object with one revolute
    joint, as in Matsuo et al. (IROS 2010). The skin is an elastic-foundation model; the F/T
    reading is the sum of its node forces plus sensor noise. Each control step the env runs
    Bicchi's intrinsic contact sensing on the reading, passes it through the measurement gate
    (``tactile_gym.envs.gate``: static pure presses on an edge, and slides along an edge) to
    the built-in ``JointAxisEstimator``, and rewards the reduction of the estimate's error.
    Measuring the edge at several link angles, and turning the link in between, is what makes
    the axis observable.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``, scaled by ``DeltaPoseController``:

    | index | action                          | unit at 1                  | frame |
    |-------|---------------------------------|----------------------------|-------|
    | 0-2   | fingertip translation x, y, z   | ``max_translation`` (2 mm) | world |
    | 3-5   | rotation vector about the tip   | ``max_rotation`` (3 deg)   | world |

    The rotation turns the fingertip about the centre of its hemisphere. The move is spread
    over the control step; a guard stops the fingertip advancing while the force exceeds
    ``force_limit``. (``HingeProbePrimitive-v1`` offers probing primitives instead.)

    ## Observation Space

    A ``Dict`` of float32 Boxes (``observation_mode="flat"`` concatenates them in the order of
    ``OBSERVATION_LAYOUT``). Values are clipped to the bounds given.

    | key            | index | entry                                         | unit | frame  |
    |----------------|-------|-----------------------------------------------|------|--------|
    | wrench         | 0-2   | force on the fingertip                        | N    | sensor |
    |                | 3-5   | moment about the sensor origin                | N m  | sensor |
    | fingertip_pose | 0-2   | sensor origin                                 | m    | world  |
    |                | 3-6   | orientation quaternion x, y, z, w             | -    | world  |
    | contact        | 0     | 1 if this reading gives a contact             | -    | -      |
    |                | 1-3   | contact point, indentation-corrected          | m    | world  |
    |                | 4-6   | skin normal at the contact                    | -    | world  |
    |                | 7-9   | edge direction, oriented physically (0: none) | -    | world  |
    |                | 10    | predicted RMS edge error (0..pi/2)            | rad  | -      |
    |                | 11    | tilt of the force from the skin normal        | rad  | -      |
    | estimate       | 0-2   | axis point closest to the world origin        | m    | world  |
    |                | 3-5   | axis direction                                | -    | world  |
    |                | 6     | 1-sigma position uncertainty (0..1)           | m    | -      |
    |                | 7     | 1-sigma angle uncertainty (0..pi)             | rad  | -      |
    | last_          | 0-2   | contact point of the last accepted measurement| m    | world  |
    | measurement    | 3-5   | its edge direction, oriented physically       | -    | world  |
    |                | 6     | its RMS edge error (pi/2: none yet)           | rad  | -      |
    | progress       | 0     | span of the measured edge directions          | rad  | -      |
    |                | 1     | distinct edge directions measured (0..1e4)    | -    | -      |
    |                | 2     | RMS edge error of the last measurement        | rad  | -      |
    |                | 3     | measurements accepted (0..1e4)                | -    | -      |
    |                | 4     | fraction of the episode left (1..0)           | -    | -      |

    Invalid entries (no contact, edge not observable) are zeros with their flag or std at
    their "none" value. The estimate is always defined: before any measurement it is the prior
    (the mean axis of the env's reset distribution, with its spread), so a policy without
    memory sees how well the axis is known, how widely the link has been turned (the span of
    the measured edges) and how much time is left. The uncertainties are the estimator's,
    floored at what the model error allows (``docs/design.md``).

    ## Rewards

    With ``E = min(position_error + L * angle_error, E_max)``, the reward of a step is the sum
    of these terms, each reported in ``info``:

    | term                   | value                                          | default         |
    |------------------------|------------------------------------------------|-----------------|
    | reward_error_reduction | (E_{t-1} - E_t) / E_scale                      | E_scale = 10 mm |
    | reward_force_penalty   | -c_f max(f_max - force_limit, 0) / force_limit | c_f = 0.1       |
    | reward_action_cost     | -c_a ‖a‖^2                                     | c_a = 0.001     |

    L = 0.05 m/rad and E_max = 0.1 m. ``E_0`` is the error of the prior, so without
    penalties the return is ``(E_0 - E_T) / E_scale``: the error removed from what was known
    before touching anything. A first estimate from poor measurements earns nothing unless
    it beats the prior (``tactile_gym.envs.task``). Position error is the distance from the
    true hinge pin centre to the estimated axis line; angle error ignores the sign.

    ## Starting State

    Drawn from ``self.np_random`` by ``tactile_gym.envs.scenarios.sample_scenario`` (uniform
    draws; ``scenario={...}`` changes the ranges, ``randomize=False`` gives the nominal start):

    | quantity                  | range (default)                                           |
    |---------------------------|-----------------------------------------------------------|
    | family                    | one of ``families``                                       |
    | free link length, width   | x 0.85-1.15 of the family's (scissors: 100 x 20 x 8 mm)   |
    | hinge position            | +-10 mm horizontally (scissors: pin at (17, 105, 4) mm)   |
    | layout yaw (not scissors) | -180..180 deg about world z; ``tilted`` axis 10-30 deg    |
    | initial joint angle       | -20..20 deg, clipped to the joint limits                  |
    | fingertip centre          | above the face that looks up, 45-75 % along the link,     |
    |                           | -4..+3 mm across the probed edge, 2-5 mm above the face   |
    | finger lean               | 0-15 deg from straight down, in a uniform random azimuth  |

    Only "a few mm above the link, near its edge" is revealed; the policy finds the edge by
    touch. For the scissors the free link points from its hinge toward world +x (+-20 deg).

    ## Episode End

    * ``terminated`` (failure), reasons in ``info["termination"]``: the fingertip's sensor
      origin leaves the workspace (``task.workspace_radius`` from the hinge pin), the rigid
      shell bottoms out through the skin, or the force exceeds ``task.hard_force_limit``.
    * ``truncated``: after ``max_steps`` control steps (the env counts them itself, so that
      the observation can say how much time is left; change it with ``max_steps=``).
    * Stepping after either raises ``RuntimeError``; call ``reset()``.
    * ``info["is_success"]``: position error < 2 mm and angle error < 2 deg.

    ``info`` also carries the reward terms, ``position_error`` (m), ``angle_error`` (rad),
    ``n_measurements``, ``new_measurements``, ``true_axis_point``, ``true_axis_direction``,
    ``joint_angle`` (rad) and ``max_force`` (N). The ground truth in ``info`` is for
    evaluation only; policies must not read it.

    ## Arguments

    Every field of ``HingeProbeConfig`` is a keyword of ``gym.make``; unknown, mistyped or
    out-of-range ones raise ``ValueError`` saying what is allowed. Shipped presets load by
    name::

        from tactile_gym.presets import load_preset

        gym.make("tactile_gym/HingeProbe-v1", **load_preset("env", "noise_x2"))

    ## Version History

    * v1: the skin presses each node along the face it entered (the paper's edge signal from a
      pure press); a measurement gate judged from observable quantities only; the fingertip
      starts leaning in a random direction; the reward starts from the prior's error; the
      observation reports progress; nested physical parameters; a probing-primitive variant.
    * v0: initial release (retired: its skin model gave no edge from a pure press, and its
      start pose revealed the edge direction).
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 20}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None,"
                f" got {render_mode!r}"
            )
        if render_mode == "human" and not _display_available():
            raise RuntimeError(
                "render_mode='human' opens PyBullet's GUI, which needs a display, and no DISPLAY"
                " or WAYLAND_DISPLAY is set. Use render_mode='rgb_array' for headless frames."
            )
        self.config = HingeProbeConfig.from_kwargs(kwargs)
        self.render_mode = render_mode
        cfg = self.config
        modes = [m for m in self.metadata["render_modes"] if m != "human" or _display_available()]
        self.metadata = {
            **self.metadata,
            "render_modes": modes,
            "render_fps": round(1.0 / (cfg.time_step * cfg.substeps)),
        }
        self.geometry = FingertipGeometry()
        self._skin_config = cfg.skin_config()
        self._sensor_config = cfg.sensor_config()
        self.scenario_config = cfg.scenario_config()
        self.task = AxisEstimationTask(cfg.task_config())
        self.touch_sensor = TouchSensor(
            self.geometry, self._sensor_config, self._skin_config.normal_stiffness
        )
        self.gate = MeasurementGate(cfg.gate_config(), self.touch_sensor)
        self.controller = DeltaPoseController(
            cfg.max_translation, cfg.max_rotation, self.geometry.sphere_center
        )
        self.prior, self.gate.edge_distance = self._reset_distribution_prior()
        # The estimator fuses the prior with the measurements (maximum a posteriori), so its
        # estimate is the prior before any measurement and leaves it as evidence accrues.
        self.estimator = JointAxisEstimator(
            mode=cfg.estimator, loss=cfg.estimator_loss, prior=self.prior
        )
        self._scene: ProbeScene | None = None
        self.measurements: list[Measurement] = []
        self._episode_over = True

        self.action_space = spaces.Box(-1.0, 1.0, shape=(6,), dtype=np.float32)
        pos = np.full(3, POSITION_BOUND)
        unit = np.ones(3)
        wrench_high = np.r_[np.full(3, FORCE_BOUND), np.full(3, MOMENT_BOUND)]
        self._dict_space = spaces.Dict(
            {
                "wrench": _box(-wrench_high, wrench_high),
                "fingertip_pose": _box(-np.r_[pos, np.ones(4)], np.r_[pos, np.ones(4)]),
                "contact": _box(
                    np.r_[0.0, -pos, -unit, -unit, 0.0, 0.0],
                    np.r_[1.0, pos, unit, unit, np.pi / 2, np.pi / 2],
                ),
                "estimate": _box(np.r_[-pos, -unit, 0.0, 0.0], np.r_[pos, unit, STD_BOUND, np.pi]),
                "last_measurement": _box(np.r_[-pos, -unit, 0.0], np.r_[pos, unit, np.pi / 2]),
                "progress": _box(
                    np.zeros(5), np.r_[np.pi, MAX_MEASUREMENTS, np.pi / 2, MAX_MEASUREMENTS, 1.0]
                ),
            }
        )
        flat_space = spaces.flatten_space(self._dict_space)
        self._low, self._high = flat_space.low.astype(float), flat_space.high.astype(float)
        sizes = dict(OBSERVATION_LAYOUT)
        ends = np.cumsum([sizes[key] for key, _ in OBSERVATION_LAYOUT])
        self._slices = {
            key: (int(e - sizes[key]), int(e)) for (key, _), e in zip(OBSERVATION_LAYOUT, ends)
        }
        self.observation_space = flat_space if cfg.observation_mode == "flat" else self._dict_space

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg = self.config
        scenario = sample_scenario(
            self.np_random,
            cfg.families,
            self.scenario_config,
            self.geometry,
            cfg.randomize,
            cfg.object,
        )
        if self._scene is None:
            self._scene = ProbeScene(
                scenario.object_config,
                self._skin_config,
                self._sensor_config,
                self.geometry,
                time_step=cfg.time_step,
                substeps=cfg.substeps,
                force_limit=cfg.force_limit,
                gui=self.render_mode == "human",
            )
        self._scene.reset(
            scenario.joint_angle,
            scenario.fingertip_position,
            scenario.fingertip_orientation,
            object_config=scenario.object_config,
        )
        self.gate.reset()
        self.estimator.reset()
        self.measurements = []
        self._directions: list[np.ndarray] = []  # one representative per distinct direction
        self._span = 0.0
        self._estimate = self.estimator.estimate()
        self._steps = 0
        self._episode_over = False
        self._quaternion = self._scene.fingertip_orientation
        self._wrench = self._scene.read_wrench(self.np_random)
        self._touch = self._sense(self._wrench)
        position_error, angle_error = self._true_errors()
        self.task.initialize_episode(position_error, angle_error)
        return self._observation(), self._true_info(position_error, angle_error)

    def step(self, action):
        if self._scene is None:
            raise RuntimeError("call reset() before step()")
        if self._episode_over:
            raise RuntimeError(
                "the episode has ended (terminated or truncated); call reset() before step()"
            )
        action = np.asarray(action)
        if action.shape != self.action_space.shape:
            raise ValueError(f"action must have shape (6,), got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action.tolist()}")
        action = np.clip(action.astype(float), -1.0, 1.0)
        scene = self._scene
        # controller -> scene -> sense -> gate and estimator -> task -> observation.
        target = self.controller.target(action, scene.fingertip_position, self._quaternion)
        step_info = scene.control_step(*target)
        self._quaternion = scene.fingertip_orientation
        self._wrench = scene.read_wrench(self.np_random)
        self._touch = self._sense(self._wrench)
        accepted = self._measure()
        position_error, angle_error = self._true_errors()
        facts = StepFacts(
            position_error=position_error,
            angle_error=angle_error,
            max_force=float(step_info.max_force),
            force_limit=float(scene.force_limit),
            shell_contact=bool(step_info.shell_contact),
            hinge_distance=self._true_hinge_distance(),
            action=action,
        )
        reward, reward_info = self.task.get_reward(facts)
        reasons = self.task.get_termination(facts)
        terminated = any(reasons.values())
        self._steps += 1
        truncated = self._steps >= self.config.max_steps and not terminated
        self._episode_over = terminated or truncated
        info = self._true_info(position_error, angle_error)
        info.update(reward_info)
        info.update(
            max_force=float(step_info.max_force),
            force_limited=bool(step_info.force_limited),
            termination=reasons,
            new_measurements=len(accepted),
        )
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, terminated, truncated, info

    def render(self):
        if self._scene is None or self.render_mode != "rgb_array":
            return None
        return self._scene.render()

    def close(self):
        if self._scene is not None:
            self._scene.close()
            self._scene = None

    # ------------------------------------------------------------------ accessors
    @property
    def scene(self) -> ProbeScene:
        """The simulation behind the env (ground truth lives here, not in observations)."""
        if self._scene is None:
            raise RuntimeError("call reset() first")
        return self._scene

    @property
    def dict_observation_space(self) -> spaces.Dict:
        """The observation as a ``Dict`` (what ``observation_mode="flat"`` flattens)."""
        return self._dict_space

    @property
    def axis_estimate(self) -> AxisEstimate:
        """The current estimate (the prior fused with the measurements so far)."""
        return self._estimate

    @property
    def steps_left(self) -> int:
        """Control steps before the episode is truncated."""
        return self.config.max_steps - self._steps

    # ------------------------------------------------------------------ the measurement path
    def _sense(self, wrench: np.ndarray) -> Touch:
        scene = self._scene
        return self.touch_sensor.sense(wrench, scene.fingertip_rotation, scene.fingertip_position)

    def _measure(self) -> list[Measurement]:
        """Offer this step's reading to the gate and feed what it accepts to the estimator."""
        scene = self._scene
        accepted = self.gate.offer(
            self._wrench, scene.fingertip_rotation, scene.fingertip_position, self._touch
        )
        accepted = [m for m in accepted if self.gate.same_edge(m, self._estimate)]
        for m in accepted:
            self.estimator.add(m.point, m.edge, m.point_std, m.edge_std, edge_cov=m.edge_cov)
            self._count_direction(m.edge)
        self.measurements.extend(accepted)
        if accepted:
            self._estimate = self.estimator.estimate()
        return accepted

    def _observation(self):
        """The observation of the current state (reads state only, changes nothing)."""
        scene = self._scene
        touch = self._touch
        contact = np.zeros(12)
        contact[10] = np.pi / 2
        if touch.valid:
            contact[0] = 1.0
            contact[1:4] = touch.point
            contact[4:7] = touch.normal
            contact[11] = touch.tilt
            if touch.observable:
                contact[7:10] = touch.edge
                contact[10] = touch.edge_std
        est = self._estimate
        stds = (est.position_std, est.angle_std)
        last = (np.zeros(3), np.zeros(3), (np.pi / 2,))
        if self.measurements:
            m = self.measurements[-1]
            last = (m.point, m.edge, (m.edge_std,))
        parts = {
            "contact": contact,
            "estimate": np.concatenate((est.point, est.direction, stds)),
            "fingertip_pose": np.concatenate((scene.fingertip_position, self._quaternion)),
            "last_measurement": np.concatenate(last),
            "progress": self._progress(),
            "wrench": self._wrench,
        }
        # One pass over the flat vector (in OBSERVATION_LAYOUT order): clip to the bounds,
        # NaN to 0 (an undefined entry whose flag says so).
        flat = np.concatenate([parts[key] for key, _ in OBSERVATION_LAYOUT])
        flat = np.clip(np.nan_to_num(flat, nan=0.0), self._low, self._high).astype(np.float32)
        if self.config.observation_mode == "flat":
            return flat
        return {key: flat[a:b] for key, (a, b) in self._slices.items()}

    def _count_direction(self, edge: np.ndarray) -> None:
        """Update the span and the distinct directions of the measured edges with one more."""
        if self._directions:
            cos = np.array(self._directions) @ edge
            self._span = max(self._span, float(np.arccos(np.clip(cos.min(), -1.0, 1.0))))
            if cos.max() >= np.cos(DISTINCT_ANGLE):
                return
        self._directions.append(edge)

    def _progress(self) -> np.ndarray:
        """Span and count of measured edge directions, last quality, count, time left."""
        last = self.measurements[-1].edge_std if self.measurements else np.pi / 2
        left = 1.0 - self._steps / self.config.max_steps
        return np.array([self._span, len(self._directions), last, len(self.measurements), left])

    # ------------------------------------------------------------------ ground truth
    # Only these methods read the simulator's truth; it feeds the reward, termination and
    # info, never the measurement path above (tests/test_ground_truth.py audits this).
    def _true_errors(self) -> tuple[float, float]:
        point, direction = self._scene.true_axis
        position, angle = axis_error(self._estimate, point, direction, point)
        return float(position), float(angle)

    def _true_hinge_distance(self) -> float:
        pin, _ = self._scene.true_axis
        return float(np.linalg.norm(self._scene.fingertip_position - pin))

    def _true_info(self, position_error: float, angle_error: float) -> dict[str, Any]:
        point, direction = self._scene.true_axis
        return {
            "is_success": self.task.is_success(position_error, angle_error),
            "position_error": position_error,
            "angle_error": angle_error,
            "n_measurements": len(self.measurements),
            "true_axis_point": point.copy(),
            "true_axis_direction": direction.copy(),
            "joint_angle": float(self._scene.joint_angle),
        }

    def _reset_distribution_prior(self) -> tuple[AxisPrior, tuple[float, float]]:
        """The prior from the reset distribution (fixed seed; never this episode's truth)."""
        cfg = self.config
        return _reset_distribution_prior(
            cfg.families,
            _frozen(dataclasses.asdict(self.scenario_config)),
            self.geometry,
            cfg.randomize,
            _frozen(cfg.object),
        )


@functools.lru_cache(maxsize=64)
def _reset_distribution_prior(
    families: tuple[str, ...],
    scenario: tuple,
    geometry: FingertipGeometry,
    randomize: bool,
    object_overrides: tuple,
) -> tuple[AxisPrior, tuple[float, float]]:
    """The prior of one reset distribution, drawn once per process: the axis, and the
    distance of the probed edge from it (mean, std; ``MeasurementGate.same_edge``).

    Its ``PRIOR_SAMPLES`` draws take about 0.4 s, most of a ``gym.make``, and every env made
    with the same families, ranges and overrides draws the same scenarios from the same seed.
    ``scenario`` and ``object_overrides`` are the ``_frozen`` ``ScenarioConfig`` fields and
    ``object`` overrides. Envs share the result, so its arrays are read-only.
    """
    scenario_config = ScenarioConfig(**dict(scenario))
    rng = np.random.default_rng(0)
    pins, directions, distances = [], [], []
    for _ in range(PRIOR_SAMPLES if randomize else 1):
        drawn = sample_scenario(
            rng, families, scenario_config, geometry, randomize, dict(object_overrides)
        )
        config = drawn.object_config
        pins.append(config.joint_position)
        directions.append(config.axis)
        origin, edge, _, _ = probed_edge(config, 0.0)
        distances.append(
            line_distance(origin, edge, np.asarray(config.joint_position), config.axis)
        )
    prior = AxisPrior.from_samples(np.array(pins), np.array(directions))
    for array in (prior.pin, prior.pin_cov, prior.direction):
        array.flags.writeable = False
    return prior, (float(np.mean(distances)), float(np.std(distances)))


def _frozen(value: Any) -> Any:
    """A hashable copy of a config value: dicts as sorted item pairs, sequences as tuples."""
    if isinstance(value, dict):
        return tuple(sorted((key, _frozen(item)) for key, item in value.items()))
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_frozen(item) for item in value)
    return value


def _box(low: np.ndarray, high: np.ndarray) -> spaces.Box:
    return spaces.Box(
        low=np.asarray(low, dtype=np.float32), high=np.asarray(high, dtype=np.float32)
    )


# The termination reasons are documented with the task.
__all__ += ["TERMINATION_REASONS"]
