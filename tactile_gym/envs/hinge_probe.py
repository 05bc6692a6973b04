"""HingeProbe v2 and v1: estimate the joint axis of a hinged object with a soft tactile fingertip.

One class serves both versions: v2 (the realistic F/T sensor, taring) and v1 (the ideal
sensor, no tare) differ only in ``HingeProbeConfig.sensor_model`` and ``tare_action``, which
``tactile_gym/__init__.py`` sets per id.

``HingeProbeEnv`` joins parts that know nothing of each other (``docs/design.md`` 7.1): the
controller (``controller.py``), the simulation (``tactile_gym.sim.ProbeScene``), the
measurement pipeline (``measurement.py``: touch sensing, gate and estimator), the task
(``task.py``: reward and termination from the ground truth) and the observation codec
(``observation.py``). Its class docstring documents the id.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.measurement import (
    GateConfig,
    Measurement,
    MeasurementPipeline,
    reset_distribution_prior,
)
from tactile_gym.envs.observation import (
    NO_EDGE,
    OBSERVATION,
    ContactObs,
    EstimateObs,
    FingertipPoseObs,
    LastMeasurementObs,
    ProgressObs,
    WrenchObs,
)
from tactile_gym.envs.render import Overlay, RenderOptions, draw_overlay
from tactile_gym.envs.scenarios import FAMILIES, ScenarioConfig, sample_scenario
from tactile_gym.envs.step_guard import StepGuard
from tactile_gym.envs.task import (
    TERMINATION_REASONS,
    AxisEstimationTask,
    StepFacts,
    TaskConfig,
)
from tactile_gym.estimation import LOSSES, AxisEstimate, axis_error
from tactile_gym.sensing import (
    SENSOR_MODELS,
    TARE_SAMPLES,
    TOUCH_FORCE,
    FingertipGeometry,
    SensorConfig,
    Tare,
)
from tactile_gym.sim import ObjectConfig, ProbeScene, SkinConfig
from tactile_gym.sim.scene import FORCE_LIMIT, PHYSICS
from tactile_gym.sim.world import SUBSTEPS, TIME_STEP
from tactile_gym.validation import (
    build_config,
    check_bool,
    check_choice,
    check_int,
    check_number,
)
from tactile_gym.vec3 import norm

# The termination reasons are documented with the task.
__all__ = ["HingeProbeConfig", "HingeProbeEnv", "TERMINATION_REASONS"]


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
        observation_mode: ``"dict"`` or ``"flat"`` (one Box in the order of
            ``tactile_gym.envs.observation.OBSERVATION_LAYOUT``).
        max_steps: control steps before the episode is truncated.
        time_step: physics time step, s.
        substeps: physics steps per control step (12 at 1/240 s gives 20 Hz control).
        max_translation: fingertip translation for an action of 1, m (10 um to 10 mm).
        max_rotation: fingertip rotation for an action of 1, rad.
        force_limit: guard that stops the fingertip advancing, and where the force penalty
            starts, N.
        randomize: draw the object, joint angle and fingertip start at reset; when False
            every reset uses the nominal scenario.
        sensor_model: the F/T sensor the ``sensor`` overrides apply to, from
            ``SENSOR_MODELS``: ``"realistic"`` (offset, drift, the fingertip's weight) or
            ``"ideal"`` (white noise only; the v1 ids').
        tare_action: the v2 behaviour: tare at reset and on the action's seventh component
            (the class docstring); False gives the v1 ids' 6-D action and raw reading.
        physics: the contact step, from ``tactile_gym.sim.scene.PHYSICS``: ``"v2"`` (the v1
            and v2 ids') or ``"v3"`` (the lean step, ``docs/design.md`` 3.6).
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
    sensor_model: str = "realistic"
    tare_action: bool = True
    physics: str = "v2"
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
        check_choice("sensor_model", self.sensor_model, SENSOR_MODELS)
        check_bool("tare_action", self.tare_action)
        check_choice("physics", self.physics, PHYSICS)
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
        """``sensor_model``'s sensor with the ``sensor`` overrides (or ``sensor`` itself, a
        ``SensorConfig``)."""
        if isinstance(self.sensor, SensorConfig):
            return self.sensor
        build_config(SensorConfig, self.sensor, "sensor")  # unknown or bad fields fail here
        changes = {k: tuple(v) if isinstance(v, list) else v for k, v in self.sensor.items()}
        return SensorConfig.preset(self.sensor_model, **changes)

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
    joint, as in Matsuo et al. (IROS 2010). The skin is an elastic-foundation model
    (``docs/design.md`` 3); the F/T reading is the sum of its node forces plus sensor noise.
    Each control step the env moves the fingertip, reads the sensor and hands the reading to
    its measurement pipeline (``tactile_gym.envs.measurement``): Bicchi's intrinsic contact
    sensing, the measurement gate, which accepts only static pure presses on an edge (slides
    are not measured: ``docs/design.md`` 4.3, 7.2), and the built-in ``JointAxisEstimator``.
    It rewards the reduction of the estimate's error. Measuring the edge at several link
    angles, and turning the link in between, is what makes the axis observable.

    ## Action Space

    ``Box(-1, 1, (7,), float32)`` (v1: ``(6,)``, no tare), scaled by ``DeltaPoseController``:

    | index | action                          | unit at 1                  | frame |
    |-------|---------------------------------|----------------------------|-------|
    | 0-2   | fingertip translation x, y, z   | ``max_translation`` (2 mm) | world |
    | 3-5   | rotation vector about the tip   | ``max_rotation`` (3 deg)   | world |
    | 6     | tare the F/T sensor if > 0.5    | -                          | -     |

    The rotation turns the fingertip about the centre of its hemisphere. The move is spread over
    the control step; a guard stops the fingertip advancing while the force exceeds
    ``force_limit``. (``HingeProbePrimitive-v2`` offers probing primitives instead.)

    **Taring** (v2, ``docs/design.md`` 5.1). The env tares at reset (every episode starts in
    free air) and when ``a[6] > 0.5``: after the move, the step's reading, the mean of
    ``TARE_SAMPLES`` sensor samples, becomes the new zero, taken at the commanded pose. A tare
    requested while the reading says touching (|f| >= ``TOUCH_FORCE`` on the current tare) is
    refused (``info["tare_refused"]``); otherwise it is taken (``info["tared"]``). A tare during
    a contact too light to read (|f| below the threshold) is taken, as a real robot would: its
    force then stays in every reading as an offset, and the policy carries that error until it
    tares again in free air. ``info["tare_age"]`` is the time since the last tare, s.

    ## Observation Space

    A ``Dict`` of float32 Boxes (``observation_mode="flat"`` concatenates them in the order of
    ``OBSERVATION_LAYOUT``). Values are clipped to the bounds given. Each key is a group of
    named entries in ``tactile_gym.envs.observation`` (``ContactObs.read(obs).tilt``):

    | key            | entry (index)     | meaning                                 | unit | frame  |
    |----------------|-------------------|-----------------------------------------|------|--------|
    | wrench         | force (0-2)       | force on the fingertip, tared           | N    | sensor |
    |                | moment (3-5)      | moment about the sensor origin, tared   | N m  | sensor |
    | fingertip_pose | position (0-2)    | sensor origin                           | m    | world  |
    |                | quaternion (3-6)  | orientation x, y, z, w                  | -    | world  |
    | contact        | touching (0)      | 1 if this reading gives a contact       | -    | -      |
    |                | point (1-3)       | contact point, indentation-corrected    | m    | world  |
    |                | normal (4-6)      | skin normal at the contact              | -    | world  |
    |                | edge (7-9)        | edge direction, oriented physically     | -    | world  |
    |                | edge_std (10)     | predicted RMS edge error (0..pi/2)      | rad  | -      |
    |                | tilt (11)         | tilt of the force from the skin normal  | rad  | -      |
    | estimate       | point (0-2)       | axis point closest to the world origin  | m    | world  |
    |                | direction (3-5)   | axis direction                          | -    | world  |
    |                | position_std (6)  | 1-sigma position uncertainty (0..1)     | m    | -      |
    |                | angle_std (7)     | 1-sigma angle uncertainty (0..pi)       | rad  | -      |
    | last_          | point (0-2)       | contact point of the last measurement   | m    | world  |
    | measurement    | edge (3-5)        | its edge direction, oriented physically | -    | world  |
    |                | edge_std (6)      | its RMS edge error (pi/2: none yet)     | rad  | -      |
    | progress       | span (0)          | span of the measured edge directions    | rad  | -      |
    |                | directions (1)    | distinct edge directions (0..1e4)       | -    | -      |
    |                | last_edge_std (2) | RMS edge error of the last measurement  | rad  | -      |
    |                | measurements (3)  | measurements accepted (0..1e4)          | -    | -      |
    |                | time_left (4)     | fraction of the episode left (1..0)     | -    | -      |

    The wrench is the tared, gravity-compensated reading (``tactile_gym.sensing.Tare``: the
    reading minus the last tare minus the change of the fingertip's weight since it); the raw
    reading, with its offset, drift and weight, is not observed. (v1: the raw reading of the
    ideal sensor, which has none of these.) Invalid entries (no contact, edge not observable)
    are zeros with their flag or std at their "none" value. The estimate is always defined:
    before any measurement it is the prior (the mean axis of the env's reset distribution, with
    its spread), so a policy without memory sees how well the axis is known, how widely the link
    has been turned (the span of the measured edges) and how much time is left. The
    uncertainties are the estimator's, floored at what the model error allows
    (``docs/design.md`` 6.5, 7.5).

    ## Rewards

    With ``E = min(position_error + L * angle_error, E_max)``, the reward of a step is the sum
    of these terms, each reported in ``info``:

    | term                   | value                                          | default         |
    |------------------------|------------------------------------------------|-----------------|
    | reward_error_reduction | (E_{t-1} - E_t) / E_scale                      | E_scale = 10 mm |
    | reward_force_penalty   | -c_f max(f_max - force_limit, 0) / force_limit | c_f = 0.1       |
    | reward_action_cost     | -c_a ‖a‖^2                                     | c_a = 0.001     |
    | reward_termination     | -c_t on the step that ends the episode in a    | c_t = 0         |
    |                        | failure (``task.termination_penalty``)         |                 |

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
    ``joint_angle`` (rad), ``max_force`` (N) and, in v2, ``tared``, ``tare_refused`` and
    ``tare_age`` (s) (Action Space). The ground truth in ``info`` is for
    evaluation only; policies must not read it.

    ## Arguments

    Every field of ``HingeProbeConfig`` is a keyword of ``gym.make``; unknown, mistyped or
    out-of-range ones raise ``ValueError`` saying what is allowed. Shipped presets load by
    name::

        from tactile_gym.presets import load_preset

        gym.make("tactile_gym/HingeProbe-v2", **load_preset("env", "noise_x2"))

    ``render_mode="rgb_array"`` frames are ``render_width`` x ``render_height`` pixels (640 x
    480) and show the observed force, the measurements and the estimated axis;
    ``render_truth=True`` adds the true axis, for videos only (``tactile_gym.envs.render``).

    ## Version History

    * v2: a realistic F/T sensor by default (an offset drawn at reset, a slow drift, the
      fingertip's weight; ``sensor_model="realistic"``), taring at reset and on a seventh
      action component, the observed wrench tared and gravity-compensated
      (``docs/design.md`` 5.1), and a gate that counts the skin's path since first touch
      (``gate={"preload_rule": True}``, 7.2). The v1 ids stay registered unchanged.
    * v1: the skin presses each node along the face it entered (the paper's edge signal from a
      pure press); a measurement gate judged from observable quantities only; the fingertip
      starts leaning in a random direction; the reward starts from the prior's error; the
      observation reports progress; nested physical parameters; a probing-primitive variant.
    * v0: initial release (retired: its skin model gave no edge from a pure press, and its
      start pose revealed the edge direction).
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 20}

    def __init__(
        self,
        render_mode: str | None = None,
        render_width: int = RenderOptions.render_width,
        render_height: int = RenderOptions.render_height,
        render_truth: bool = RenderOptions.render_truth,
        **kwargs: Any,
    ) -> None:
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
        self.config = cfg = HingeProbeConfig.from_kwargs(kwargs)
        self.render_mode = render_mode
        self.render_options = RenderOptions(render_width, render_height, render_truth)
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
        self.controller = DeltaPoseController(
            cfg.max_translation, cfg.max_rotation, self.geometry.sphere_center
        )
        prior, edge_distance = reset_distribution_prior(
            cfg.families, self.scenario_config, self.geometry, cfg.randomize, cfg.object
        )
        self.pipeline = MeasurementPipeline(
            self.geometry,
            self._sensor_config,
            self._skin_config.normal_stiffness,
            cfg.gate_config(),
            cfg.estimator,
            cfg.estimator_loss,
            prior,
            edge_distance,
        )
        self.task = AxisEstimationTask(cfg.task_config())
        self.codec = OBSERVATION
        self.dict_observation_space = self.codec.dict_space
        self.observation_space = self.codec.space(cfg.observation_mode)
        self.action_space = spaces.Box(
            -1.0, 1.0, shape=(7 if cfg.tare_action else 6,), dtype=np.float32
        )
        self._guard = StepGuard(self.action_space)
        self._scene: ProbeScene | None = None
        # The estimate ``_errors`` belong to (``_true_errors``).
        self._errors_of: AxisEstimate | None = None
        self._errors = (math.inf, math.pi / 2)

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
                physics=cfg.physics,
            )
        scene = self._scene
        scene.reset(
            scenario.joint_angle,
            scenario.fingertip_position,
            scenario.fingertip_orientation,
            object_config=scenario.object_config,
            rng=self.np_random,
        )
        self._steps = 0
        self._tare = Tare.of(self._sensor_config)
        self._tare_step = 0
        # Every episode starts in free air (2-5 mm above the face, "Starting State"): the
        # operator's tare there needs no knowledge of contact.
        reading = scene.read_wrench(self.np_random, TARE_SAMPLES if cfg.tare_action else 1)
        if cfg.tare_action:
            self._tare.take(reading, scene.fingertip_rotation)
        self._wrench = self._tare.compensate(reading, scene.fingertip_rotation)
        self.pipeline.reset(self._wrench, scene.fingertip_rotation, scene.fingertip_position)
        self._guard.begin()
        self._errors_of = None  # a new episode's truth: no errors computed for it yet
        position_error, angle_error = self._true_errors()
        self.task.initialize_episode(position_error, angle_error)
        return self._observation(), self._true_info(position_error, angle_error)

    def step(self, action):
        action = self._guard.check(action)
        scene = self._scene
        position, rotation = self.controller.target(
            action, scene.fingertip_position, scene.fingertip_rotation
        )
        step_info = scene.control_step(position, rotation)
        tare_info = self._read(rotation, self.config.tare_action and action[6] > 0.5)
        added = self.pipeline.step(self._wrench, scene.fingertip_rotation, scene.fingertip_position)
        self._steps += 1
        facts = self._true_facts(step_info, action[:6])
        reward, reward_info = self.task.get_reward(facts)
        reasons = self.task.get_termination(facts)
        terminated = any(reasons.values())
        truncated = self._steps >= self.config.max_steps and not terminated
        self._guard.end(terminated or truncated)
        info = {
            **self._true_info(facts.position_error, facts.angle_error),
            **reward_info,
            "max_force": facts.max_force,
            "force_limited": bool(step_info.force_limited),
            "termination": reasons,
            "new_measurements": added,
            **tare_info,
        }
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, terminated, truncated, info

    def render(self):
        """The frame (``render_mode="rgb_array"``): the probed region with the force, the
        measurements, the estimated axis and, with ``render_truth=True``, the true axis
        (``tactile_gym.envs.render``)."""
        if self._scene is None or self.render_mode != "rgb_array":
            return None
        scene, pipeline, options = self._scene, self.pipeline, self.render_options
        image, camera = scene.render(options.render_width, options.render_height)
        touch = pipeline.touch
        tip = scene.sensor_to_world_point(self.geometry.sphere_center)
        origin = touch.point if touch.valid else tip
        estimate = pipeline.estimate
        overlay = Overlay(
            step=self._steps,
            force=scene.sensor_to_world_vector(self._wrench[:3]),
            force_origin=origin,
            points=np.array([m.point for m in pipeline.measurements]).reshape(-1, 3),
            edges=np.array([m.edge for m in pipeline.measurements]).reshape(-1, 3),
            axis=(estimate.point, estimate.direction),
            true_axis=self._true_axis_for_render() if options.render_truth else None,
        )
        return draw_overlay(image, camera, overlay)

    def close(self):
        self._guard.stop()
        if self._scene is not None:
            self._scene.close()
            self._scene = None

    def _read(self, rotation: np.ndarray, tare: bool) -> dict[str, Any]:
        """Read the sensor into ``self._wrench`` (tared, gravity-compensated at the commanded
        ``rotation``), taring first if asked and the reading does not say touching.

        Returns:
            The tare's ``info`` entries (none without ``tare_action``).
        """
        # A tare's reading averages TARE_SAMPLES sensor samples over the step.
        reading = self._scene.read_wrench(self.np_random, TARE_SAMPLES if tare else 1)
        self._wrench = self._tare.compensate(reading, rotation)
        if not self.config.tare_action:
            return {}
        refused = tare and norm(self._wrench[:3]) >= TOUCH_FORCE
        if tare and not refused:
            self._tare.take(reading, rotation)
            self._tare_step = self._steps + 1
            self._wrench = self._tare.compensate(reading, rotation)
        period = self.config.time_step * self.config.substeps
        return {
            "tared": bool(tare and not refused),
            "tare_refused": bool(refused),
            "tare_age": (self._steps + 1 - self._tare_step) * period,
        }

    # ------------------------------------------------------------------ accessors
    @property
    def scene(self) -> ProbeScene:
        """The simulation behind the env (ground truth lives here, not in observations)."""
        if self._scene is None:
            raise RuntimeError("call reset() first")
        return self._scene

    @property
    def measurements(self) -> list[Measurement]:
        """The measurements accepted this episode (``.point``, ``.edge``, ...; world frame)."""
        return self.pipeline.measurements

    @property
    def axis_estimate(self) -> AxisEstimate:
        """The current estimate (the prior fused with the measurements so far)."""
        return self.pipeline.estimate

    @property
    def gate(self):
        """The pipeline's measurement gate (its ``config`` and ``last_rejection``)."""
        return self.pipeline.gate

    def _observation(self):
        """The observation of the current state (reads state only, changes nothing)."""
        scene, pipeline = self._scene, self.pipeline
        last = pipeline.last
        groups = (
            ContactObs.from_touch(pipeline.touch),
            EstimateObs.from_estimate(pipeline.estimate),
            FingertipPoseObs(scene.fingertip_position, scene.fingertip_orientation),
            LastMeasurementObs.from_measurement(last),
            ProgressObs(
                span=pipeline.span,
                directions=pipeline.directions,
                last_edge_std=NO_EDGE if last is None else last.edge_std,
                measurements=len(pipeline.measurements),
                time_left=1.0 - self._steps / self.config.max_steps,
            ),
            WrenchObs(self._wrench[:3], self._wrench[3:]),
        )
        parts = {group.key: group.to_array() for group in groups}
        return self.codec.encode(parts, self.config.observation_mode)

    # ------------------------------------------------------------------ ground truth
    # Only these methods read the simulator's truth; it feeds the reward, termination and
    # info, never the measurement pipeline (tests/test_ground_truth.py audits this).
    def _true_errors(self) -> tuple[float, float]:
        """The current estimate's errors. The true axis is fixed over an episode and the
        estimate changes only with a measurement, so they are computed once per estimate."""
        estimate = self.pipeline.estimate
        if estimate is not self._errors_of:
            point, direction = self._scene.true_axis
            position, angle = axis_error(estimate, point, direction, point)
            self._errors = (float(position), float(angle))
            self._errors_of = estimate
        return self._errors

    def _true_facts(self, step_info, action: np.ndarray) -> StepFacts:
        """What the task judges a step by (``StepFacts``), from the truth and the step."""
        position_error, angle_error = self._true_errors()
        pin, _ = self._scene.true_axis
        return StepFacts(
            position_error=position_error,
            angle_error=angle_error,
            max_force=float(step_info.max_force),
            force_limit=float(self._scene.force_limit),
            shell_contact=bool(step_info.shell_contact),
            hinge_distance=norm(self._scene.fingertip_position - pin),
            action=action,
            measurements=len(self.pipeline.measurements),
        )

    def _true_axis_for_render(self) -> tuple[np.ndarray, np.ndarray]:
        """The true axis, drawn only with ``render_truth=True`` (videos, never an input)."""
        point, direction = self._scene.true_axis
        return point.copy(), direction.copy()

    def _true_info(self, position_error: float, angle_error: float) -> dict[str, Any]:
        point, direction = self._scene.true_axis
        return {
            "is_success": self.task.is_success(position_error, angle_error),
            "position_error": position_error,
            "angle_error": angle_error,
            "n_measurements": len(self.pipeline.measurements),
            "true_axis_point": point,  # the scene's copies
            "true_axis_direction": direction,
            "joint_angle": float(self._scene.joint_angle),
        }
