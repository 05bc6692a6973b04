"""HingeProbe: estimate the joint axis of a hinged object with a soft tactile fingertip."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.measurement import GateConfig, Measurement, MeasurementGate
from tactile_gym.envs.scenarios import FAMILIES, ScenarioConfig, sample_scenario
from tactile_gym.envs.task import AxisEstimationTask, TaskConfig
from tactile_gym.estimation import JointAxisEstimator, axis_error
from tactile_gym.sensing import FingertipGeometry, estimate_contact
from tactile_gym.sim import ProbeScene, SensorConfig, SkinConfig

__all__ = ["HingeProbeConfig", "HingeProbeEnv", "OBSERVATION_LAYOUT"]

#: Physical bounds of the observation entries (observations are clipped to them).
FORCE_BOUND = 60.0  # N
MOMENT_BOUND = 3.0  # N m
POSITION_BOUND = 1.0  # m
STD_BOUND = 1.0  # m
MAX_MEASUREMENTS = 10_000.0

#: Entries of the flat observation, in order (Gymnasium sorts Dict keys), with their sizes.
OBSERVATION_LAYOUT: tuple[tuple[str, int], ...] = (
    ("contact", 11),
    ("estimate", 10),
    ("fingertip_pose", 7),
    ("wrench", 6),
)


@dataclass(frozen=True)
class HingeProbeConfig:
    """Every parameter of the env; each is a keyword of ``gym.make``.

    Attributes:
        families: object families drawn at reset, from ``scissors, door, lid, tilted``.
        estimator_mode: ``"planar"`` (axis along world z, paper eq. 16-21) or ``"3d"``.
        observation_mode: ``"dict"`` or ``"flat"`` (one Box, see ``OBSERVATION_LAYOUT``).
        time_step: physics time step, s.
        substeps: physics steps per control step (12 at 1/240 s gives 20 Hz control).
        max_translation: fingertip translation for an action of 1, m.
        max_rotation: fingertip rotation for an action of 1, rad.
        force_limit: guard that stops the fingertip advancing, and where the force penalty
            starts, N.
        hard_force_limit: force that ends the episode as a failure, N.
        workspace_radius: the episode fails when the fingertip's sensor origin is further
            than this from the hinge pin, m.
        randomize: draw object parameters, joint angle and fingertip start at reset; when
            False every reset uses the nominal scenario.
        force_noise_std: F/T sensor force noise, N.
        moment_noise_std: F/T sensor moment noise, N m.
        skin_stiffness: Winkler stiffness k_n of the skin, N/m^3 (sensing uses the same value
            for its indentation correction).
        friction: skin-object Coulomb friction coefficient.
        gate: measurement gate thresholds (``GateConfig`` fields as a dict).
        task: reward weights and success thresholds (``TaskConfig`` fields as a dict).
        scenario: reset randomisation ranges (``ScenarioConfig`` fields as a dict).
    """

    families: tuple[str, ...] = ("scissors",)
    estimator_mode: str = "planar"
    observation_mode: str = "dict"
    time_step: float = 1.0 / 240.0
    substeps: int = 12
    max_translation: float = 0.002
    max_rotation: float = float(np.deg2rad(3.0))
    force_limit: float = 8.0
    hard_force_limit: float = 30.0
    workspace_radius: float = 0.25
    randomize: bool = True
    force_noise_std: float = 0.02
    moment_noise_std: float = 5e-4
    skin_stiffness: float = 8.8e7
    friction: float = 0.5
    gate: dict = field(default_factory=dict)
    task: dict = field(default_factory=dict)
    scenario: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        families = (self.families,) if isinstance(self.families, str) else self.families
        object.__setattr__(self, "families", tuple(families))
        unknown = [f for f in self.families if f not in FAMILIES]
        if not self.families or unknown:
            raise ValueError(f"families must be a non-empty subset of {FAMILIES}, got {families}")
        choices = {"estimator_mode": ("planar", "3d"), "observation_mode": ("dict", "flat")}
        for name, allowed in choices.items():
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if self.estimator_mode == "planar" and any(f != "scissors" for f in self.families):
            raise ValueError(
                "estimator_mode='planar' assumes a vertical axis and only fits the 'scissors'"
                f" family; got families {self.families}. Use estimator_mode='3d'."
            )
        positive = (
            "time_step",
            "max_translation",
            "max_rotation",
            "force_limit",
            "workspace_radius",
            "skin_stiffness",
            "friction",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        for name in ("force_noise_std", "moment_noise_std"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if not (isinstance(self.substeps, int) and self.substeps >= 1):
            raise ValueError(f"substeps must be an integer >= 1, got {self.substeps!r}")
        if not self.hard_force_limit > self.force_limit:
            raise ValueError(
                f"hard_force_limit must exceed force_limit ({self.force_limit} N),"
                f" got {self.hard_force_limit!r}"
            )
        # Build the sub-configs once so that a bad field fails here, at construction.
        for name, cls in (("gate", GateConfig), ("task", TaskConfig), ("scenario", ScenarioConfig)):
            _build(cls, getattr(self, name), name)

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any]) -> HingeProbeConfig:
        """Build a config from keywords, rejecting unknown ones with the allowed list."""
        allowed = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(kwargs) - set(allowed))
        if unknown:
            raise ValueError(f"unknown HingeProbe keyword(s) {unknown}; allowed: {allowed}")
        return cls(**kwargs)


def _build(cls, values: dict, name: str):
    if not isinstance(values, dict):
        raise ValueError(f"{name} must be a dict of {cls.__name__} fields, got {values!r}")
    allowed = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(values) - set(allowed))
    if unknown:
        raise ValueError(f"unknown {name} field(s) {unknown}; allowed: {allowed}")
    converted = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
    return cls(**converted)


class HingeProbeEnv(gym.Env):
    """Probe a hinged object with a soft fingertip and estimate its joint axis.

    ## Description

    A kinematic fingertip (aluminium shell of radius 11 mm under a 5 mm silicone skin, on a
    6-axis force/torque sensor) probes the free link of a two-link object with one revolute
    joint, as in Matsuo et al. (IROS 2010). The skin is an elastic-foundation model; the F/T
    reading is the sum of its node forces plus sensor noise. Each control step the env runs
    Bicchi's intrinsic contact sensing on the reading, passes informative contacts through a
    measurement gate (``tactile_gym.envs.measurement``) to the built-in
    ``JointAxisEstimator``, and rewards the reduction of the estimate's error. Pushing the
    free link round its hinge while measuring the edge is what makes the axis observable.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``, scaled by ``DeltaPoseController``:

    | index | action                          | unit at 1                  | frame |
    |-------|---------------------------------|----------------------------|-------|
    | 0-2   | fingertip translation x, y, z   | ``max_translation`` (2 mm) | world |
    | 3-5   | rotation vector about the tip   | ``max_rotation`` (3 deg)   | world |

    The rotation turns the fingertip about the centre of its hemisphere. The move is spread
    smoothly over the control step; a guard stops the fingertip advancing while the force
    exceeds ``force_limit``.

    ## Observation Space

    A ``Dict`` of float32 Boxes (``observation_mode="flat"`` concatenates them in the order of
    ``OBSERVATION_LAYOUT``). Values are clipped to the bounds given.

    | key            | index | entry                                  | unit | frame  |
    |----------------|-------|----------------------------------------|------|--------|
    | wrench         | 0-2   | force on the fingertip (+-60)          | N    | sensor |
    |                | 3-5   | moment about the sensor origin (+-3)   | N m  | sensor |
    | fingertip_pose | 0-2   | sensor origin position (+-1)           | m    | world  |
    |                | 3-6   | orientation quaternion x, y, z, w      | -    | world  |
    | contact        | 0     | 1 if the contact estimate is valid     | -    | -      |
    |                | 1-3   | contact point, indentation-corrected   | m    | world  |
    |                | 4-6   | skin normal at the contact             | -    | world  |
    |                | 7-9   | edge direction (0 when unobservable)   | -    | world  |
    |                | 10    | predicted 1-sigma edge error (0..pi)   | rad  | -      |
    | estimate       | 0     | 1 if the estimator has an estimate     | -    | -      |
    |                | 1-3   | axis point closest to the world origin | m    | world  |
    |                | 4-6   | axis direction                         | -    | world  |
    |                | 7     | 1-sigma position uncertainty (0..1)    | m    | -      |
    |                | 8     | 1-sigma angle uncertainty (0..pi)      | rad  | -      |
    |                | 9     | accepted measurements (0..1e4)         | -    | -      |

    Positions are bounded by +-1 m and unit vectors by +-1.
    Invalid entries (no contact, no estimate) are zeros with their flag at 0.

    ## Rewards

    With ``E = min(position_error + L * angle_error, E_max)`` (``E = E_max`` while there is no
    estimate), the reward of a step is the sum of these terms, each reported in ``info``:

    | term                   | value                                        | default   |
    |------------------------|----------------------------------------------|-----------|
    | reward_error_reduction | (E_{t-1} - E_t) / E_scale                    | E_scale = 10 mm |
    | reward_force_penalty   | -c_f max(f_max - force_limit, 0) / force_limit | c_f = 0.1 |
    | reward_action_cost     | -c_a ‖a‖^2                                   | c_a = 0.001 |

    L = 0.05 m/rad and E_max = 0.1 m. Without penalties the return telescopes to the total
    error reduction ``(E_max - E_T) / E_scale``. Position error is the distance from the true
    hinge pin centre to the estimated axis line; angle error ignores the direction's sign.

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
    | fingertip start           | 45-75 % along the link, 2-5 mm off the edge, finger axis  |
    |                           | 10 +- 3 deg from the top face normal toward the edge side |
    | joint holding torque      | 0.1 N m                                                   |

    For ``HingeProbe-v0`` the free link points from its hinge toward world +x. The F/T noise
    is drawn from the same generator every step.

    ## Episode End

    * ``terminated`` (failure): the fingertip leaves the workspace (``workspace_radius`` from
      the hinge pin), the rigid shell bottoms out through the skin, or the force exceeds
      ``hard_force_limit``.
    * ``truncated``: the time limit of the registration (200 steps).
    * ``info["is_success"]``: position error < 2 mm and angle error < 2 deg.

    ``info`` also carries the reward terms, ``position_error`` (m), ``angle_error`` (rad),
    ``n_measurements``, ``true_axis_point``, ``true_axis_direction``, ``joint_angle`` (rad),
    ``max_force`` (N) and the failure flags.

    ## Arguments

    Every field of ``HingeProbeConfig`` is a keyword of ``gym.make``; unknown or out-of-range
    ones raise ``ValueError``. Presets live in ``configs/env/*.yml``::

        gym.make("tactile_gym/HingeProbe-v0", **yaml.safe_load(open("configs/env/hinge_probe.yml")))

    ## Version History

    * v0: initial release.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 20}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None,"
                f" got {render_mode!r}"
            )
        self.config = HingeProbeConfig.from_kwargs(kwargs)
        self.render_mode = render_mode
        cfg = self.config
        self.metadata = {**self.metadata, "render_fps": round(1.0 / (cfg.time_step * cfg.substeps))}
        self.gate_config = _build(GateConfig, cfg.gate, "gate")
        task_config = _build(TaskConfig, {"force_limit": cfg.force_limit, **cfg.task}, "task")
        self.scenario_config = _build(ScenarioConfig, cfg.scenario, "scenario")
        self.task = AxisEstimationTask(task_config)
        self.gate = MeasurementGate(self.gate_config)
        self.estimator = JointAxisEstimator(mode=cfg.estimator_mode)
        self.geometry = FingertipGeometry()
        self.controller = DeltaPoseController(
            cfg.max_translation, cfg.max_rotation, self.geometry.sphere_center
        )
        self._skin_config = SkinConfig(normal_stiffness=cfg.skin_stiffness, friction=cfg.friction)
        self._sensor_config = SensorConfig(
            force_noise_std=cfg.force_noise_std, moment_noise_std=cfg.moment_noise_std
        )
        self._scene: ProbeScene | None = None
        self.measurements: list[Measurement] = []

        self.action_space = spaces.Box(-1.0, 1.0, shape=(6,), dtype=np.float32)
        pos = np.full(3, POSITION_BOUND)
        unit = np.ones(3)
        wrench_high = np.r_[np.full(3, FORCE_BOUND), np.full(3, MOMENT_BOUND)]
        contact_high = np.r_[1.0, pos, unit, unit, np.pi]
        estimate_high = np.r_[1.0, pos, unit, STD_BOUND, np.pi, MAX_MEASUREMENTS]
        dict_space = spaces.Dict(
            {
                "wrench": _box(-wrench_high, wrench_high),
                "fingertip_pose": _box(-np.r_[pos, np.ones(4)], np.r_[pos, np.ones(4)]),
                "contact": _box(np.r_[0.0, -pos, -unit, -unit, 0.0], contact_high),
                "estimate": _box(np.r_[0.0, -pos, -unit, 0.0, 0.0, 0.0], estimate_high),
            }
        )
        self._dict_space = dict_space
        if cfg.observation_mode == "flat":
            self.observation_space = spaces.flatten_space(dict_space)
        else:
            self.observation_space = dict_space
        self._last_obs_contact = np.zeros(11)
        self._last_estimate_obs = np.zeros(10)

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        scenario = sample_scenario(
            self.np_random,
            self.config.families,
            self.scenario_config,
            self.geometry,
            self.config.randomize,
        )
        if self._scene is None:
            self._scene = ProbeScene(
                scenario.object_config,
                self._skin_config,
                self._sensor_config,
                self.geometry,
                time_step=self.config.time_step,
                substeps=self.config.substeps,
                force_limit=self.config.force_limit,
                gui=self.render_mode == "human",
            )
        self._scene.reset(
            scenario.joint_angle,
            scenario.fingertip_position,
            scenario.fingertip_orientation,
            object_config=scenario.object_config,
        )
        self.task.initialize_episode()
        self.gate.reset()
        self.estimator.reset()
        self.measurements = []
        self._estimate = None
        self._previous_edge_sensor = None
        obs, _ = self._observe(self._scene.read_wrench(self.np_random))
        position_error, angle_error = self._errors()
        info = self._base_info(position_error, angle_error)
        return obs, info

    def step(self, action):
        if self._scene is None:
            raise RuntimeError("call reset() before step()")
        action = np.asarray(action)
        if action.shape != (6,):
            raise ValueError(f"action must have shape (6,), got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action}")
        action = np.clip(action.astype(float), -1.0, 1.0)
        scene = self._scene
        target = self.controller.target(
            action, scene.fingertip_position, scene.fingertip_orientation
        )
        step_info = scene.control_step(*target)
        wrench = scene.read_wrench(self.np_random)
        obs, accepted = self._observe(wrench)
        position_error, angle_error = self._errors()
        reward, reward_info = self.task.get_reward(
            position_error, angle_error, step_info.max_force, action
        )
        pin, _ = scene.true_axis
        left_workspace = bool(
            np.linalg.norm(scene.fingertip_position - pin) > self.config.workspace_radius
        )
        overloaded = bool(step_info.max_force > self.config.hard_force_limit)
        terminated = left_workspace or overloaded or step_info.shell_contact
        info = self._base_info(position_error, angle_error)
        info.update(reward_info)
        info.update(
            max_force=float(step_info.max_force),
            force_limited=bool(step_info.force_limited),
            shell_contact=bool(step_info.shell_contact),
            left_workspace=left_workspace,
            overloaded=overloaded,
            new_measurements=len(accepted),
        )
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def render(self):
        if self._scene is None:
            return None
        if self.render_mode == "rgb_array":
            return self._scene.render()
        return None

    def close(self):
        if self._scene is not None:
            self._scene.close()
            self._scene = None

    # ------------------------------------------------------------------ helpers
    @property
    def scene(self) -> ProbeScene:
        """The simulation behind the env (ground truth lives here, not in observations)."""
        if self._scene is None:
            raise RuntimeError("call reset() first")
        return self._scene

    @property
    def axis_estimate(self):
        """The estimator's current ``AxisEstimate``, or None."""
        return self._estimate

    def _errors(self) -> tuple[float, float]:
        point, direction = self._scene.true_axis
        if self._estimate is None or self._estimate.degenerate:
            return float("inf"), float(np.pi / 2)
        position, angle = axis_error(self._estimate, point, direction, point)
        return float(position), float(angle)

    def _base_info(self, position_error: float, angle_error: float) -> dict[str, Any]:
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

    def _observe(self, wrench: np.ndarray) -> tuple[Any, list[Measurement]]:
        """Sense the contact, feed the gate and estimator (updating ``_estimate``), and build
        the observation."""
        scene = self._scene
        contact = estimate_contact(
            wrench[:3],
            wrench[3:],
            self.geometry,
            force_noise_std=self.config.force_noise_std,
            moment_noise_std=self.config.moment_noise_std,
            skin_stiffness=self.config.skin_stiffness,
            previous_edge=self._previous_edge_sensor,
        )
        contact_obs = np.zeros(11)
        accepted: list[Measurement] = []
        if contact.valid:
            point = scene.sensor_to_world_point(contact.corrected_point)
            normal = scene.sensor_to_world_vector(contact.normal)
            force = scene.sensor_to_world_vector(contact.force)
            observable = bool(np.all(np.isfinite(contact.edge_direction)))
            if observable:
                self._previous_edge_sensor = contact.edge_direction
                edge = scene.sensor_to_world_vector(contact.edge_direction)
            else:
                edge = np.full(3, np.nan)
            contact_obs[0] = 1.0
            contact_obs[1:4] = point
            contact_obs[4:7] = normal
            contact_obs[7:10] = edge if observable else 0.0
            contact_obs[10] = min(contact.edge_std, np.pi)
            accepted = self.gate.offer(True, force, point, edge, contact.edge_std)
            for m in accepted:
                self.estimator.add(m.point, m.edge, m.point_std, m.edge_std)
            self.measurements.extend(accepted)
        else:
            self.gate.offer(False, np.zeros(3), np.zeros(3), np.full(3, np.nan), np.inf)
            contact_obs[10] = np.pi

        if accepted:
            self._estimate = self.estimator.estimate()
        estimate_obs = np.zeros(10)
        estimate = self._estimate
        if estimate is not None and not estimate.degenerate:
            estimate_obs[0] = 1.0
            estimate_obs[1:4] = estimate.point
            estimate_obs[4:7] = estimate.direction
            estimate_obs[7] = estimate.position_std
            estimate_obs[8] = estimate.angle_std
        estimate_obs[9] = len(self.measurements)

        position, orientation = scene.fingertip_position, scene.fingertip_orientation
        obs = {
            "wrench": wrench,
            "fingertip_pose": np.r_[position, orientation],
            "contact": contact_obs,
            "estimate": estimate_obs,
        }
        for key, value in obs.items():
            space = self._dict_space[key]
            finite = np.nan_to_num(value, nan=0.0, posinf=space.high, neginf=space.low)
            obs[key] = np.clip(finite, space.low, space.high).astype(np.float32)
        if self.config.observation_mode == "flat":
            obs = spaces.flatten(self._dict_space, obs)
        return obs, accepted


def _box(low: np.ndarray, high: np.ndarray) -> spaces.Box:
    return spaces.Box(
        low=np.asarray(low, dtype=np.float32), high=np.asarray(high, dtype=np.float32)
    )
