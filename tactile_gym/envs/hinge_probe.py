"""HingeProbe: estimate the joint axis of a hinged object with a soft tactile fingertip.

One class serves every version: v2 (the realistic F/T sensor, taring) and v1 (the ideal
sensor, no tare) differ only in ``HingeProbeConfig.sensor_model`` and ``tare_action``, which
``tactile_gym/__init__.py`` sets per id.

``HingeProbeEnv`` joins parts that know nothing of each other (``docs/design.md`` 7.1): the
controller (``controller.py``), the simulation (``tactile_gym.sim.ProbeScene``), the
measurement pipeline (``tactile_gym.perception``: tare, touch sensing, gate and estimator), the
task (``task.py``: reward and termination from the ground truth) and the observation codec
(``observation.py``). Its class docstring documents the ids.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tactile_gym.envs.config import HingeProbeConfig
from tactile_gym.envs.controller import DeltaPoseController
from tactile_gym.envs.observation import OBSERVATION, ObservationCodec, PipelineParts
from tactile_gym.envs.render import RenderOptions, draw_frame
from tactile_gym.envs.step_guard import (
    EnvSpecOwnHorizon,
    StepGuard,
    check_render_mode,
    display_available,
)
from tactile_gym.envs.task import TERMINATION_REASONS, AxisEstimationTask, StepFacts
from tactile_gym.estimation import AxisEstimate, axis_error
from tactile_gym.perception import Measurement, Perceived, Sample
from tactile_gym.sensing import TARE_SAMPLES, FingertipGeometry
from tactile_gym.sim import ProbeScene
from tactile_gym.vec3 import norm

# The termination reasons are documented with the task.
__all__ = ["HingeProbeConfig", "HingeProbeEnv", "TERMINATION_REASONS"]


class HingeProbeEnv(EnvSpecOwnHorizon, gym.Env):
    """Probe a hinged object with a soft fingertip and estimate its joint axis.

    ## Description

    A kinematic fingertip (aluminium shell of radius 11 mm under a 5 mm silicone skin, on a
    6-axis force/torque sensor) probes the free link of a two-link object with one revolute
    joint, as in Matsuo et al. (IROS 2010). The skin is an elastic-foundation model
    (``docs/design.md`` 3); the F/T reading is the sum of its node forces plus sensor noise.
    Each control step the env moves the fingertip, reads the sensor and hands the reading and
    the fingertip's pose to its measurement pipeline (``tactile_gym.perception``, which runs on
    a real robot's logs alike): the tare, Bicchi's intrinsic contact sensing, the measurement
    gate, which accepts only static pure presses on an edge (slides are not measured:
    ``docs/design.md`` 4.3, 7.2), and the built-in ``JointAxisEstimator``.
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
    | last_measurement | point (0-2)     | contact point of the last measurement   | m    | world  |
    |                | edge (3-5)        | its edge direction, oriented physically | -    | world  |
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

    * ``terminated`` (failure), each reason a boolean ``info["termination_<reason>"]``
      (``TERMINATION_REASONS``): the fingertip's sensor origin leaves the workspace
      (``left_workspace``: ``task.workspace_radius`` from the hinge pin, or from where it
      started with ``task={"workspace_center": "start"}``), the rigid shell
      bottoms out through the skin (``shell_contact``), or the force exceeds
      ``task.hard_force_limit`` (``overloaded``).
    * ``truncated``: after ``max_steps`` control steps (the env counts them itself, so that
      the observation can say how much time is left; change it with ``max_steps=``).
      ``env.spec.max_episode_steps`` is ``max_steps``, for tools that read the horizon there.
    * Stepping after either raises ``RuntimeError``; call ``reset()``.
    * ``info["is_success"]``: position error < 2 mm and angle error < 2 deg.

    ``info`` has the same keys at every reset and step, each a NumPy scalar or array, none a
    dict, a string or an observation key (the conventions of TorchRL's and Gymnasium's vector
    info readers): the reward terms, ``is_success``, ``position_error`` (m), ``angle_error``
    (rad), ``n_measurements``, ``new_measurements``, ``true_axis_point``,
    ``true_axis_direction``, ``joint_angle`` (rad), ``max_force`` (N), ``force_limited``, the
    ``termination_<reason>`` flags and, in v2, ``tared``, ``tare_refused`` and ``tare_age``
    (s) (Action Space); at reset the step's entries are 0 or False. The ground truth in
    ``info`` is for evaluation only; policies must not read it.

    ## Arguments

    Every field of ``HingeProbeConfig`` is a keyword of ``gym.make``; mistyped or
    out-of-range ones raise ``ValueError`` saying what is allowed, and unknown ones an error
    that is both a ``ValueError`` and a ``TypeError`` in Python's wording ("got an unexpected
    keyword argument"), which tools such as TorchRL's ``GymEnv`` expect. Shipped presets load by
    name::

        from tactile_gym.presets import load_preset

        gym.make("tactile_gym/HingeProbe-v2", **load_preset("env", "noise_x2"))

    ``render_mode="rgb_array"`` frames are ``render_width`` x ``render_height`` pixels (640 x
    480) and show the observed force, the measurements and the estimated axis;
    ``render_truth=True`` adds the true axis, for videos only (``tactile_gym.envs.render``).

    ## Version History

    * v3: the v3 contact step (``physics="v3"``, ``docs/design.md`` 3.6: one compiled call
      per control step, the joint integrated in it; trajectories held to bounds of v2's, not to
      its bits), the calibrated covariance (``estimator_covariance="calibrated"``, 6.9: the
      ``estimate`` entry's stds are honest) and the adaptive press (5.2:
      ``measure_gradient=True``, every skill steps by the force gradient it measures; the gate
      measures a still press once the predicted edge error of its mean is 2 deg, within 12
      readings, its steadiness judged on the force's trend). The v2 and v1 ids stay
      registered unchanged.
    * 0.4 (no new version: observations, rewards and dynamics are unchanged): ``info`` is flat
      and numeric (``termination_<reason>`` flags replace the ``termination`` dict; NumPy
      scalars), the same keys at reset and step; ``env.spec.max_episode_steps`` is
      ``max_steps``; an unknown keyword raises a ``TypeError`` too.
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
    #: The config, task, observation codec and the observation's arrays from the pipeline
    #: of the ids (an env of other ids that reuses this one's machinery, ``JointProbeEnv``,
    #: sets its own).
    config_class: ClassVar[type[HingeProbeConfig]] = HingeProbeConfig
    task_class: ClassVar[type[AxisEstimationTask]] = AxisEstimationTask
    observation_codec: ClassVar[ObservationCodec] = OBSERVATION
    observation_parts: ClassVar[type[PipelineParts]] = PipelineParts

    def __init__(
        self,
        render_mode: str | None = None,
        render_width: int = RenderOptions.render_width,
        render_height: int = RenderOptions.render_height,
        render_truth: bool = RenderOptions.render_truth,
        **kwargs: Any,
    ) -> None:
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.config = cfg = self.config_class.from_kwargs(kwargs)
        self._horizon = cfg.max_steps
        self.render_mode = render_mode
        self.render_options = RenderOptions(render_width, render_height, render_truth)
        self.period = cfg.time_step * cfg.substeps
        modes = [m for m in self.metadata["render_modes"] if m != "human" or display_available()]
        self.metadata = {"render_modes": modes, "render_fps": round(1 / self.period)}
        self.geometry = FingertipGeometry()
        self.controller = DeltaPoseController(
            cfg.max_translation, cfg.max_rotation, self.geometry.sphere_center
        )
        self.pipeline = cfg.pipeline(self.geometry)
        self.task = self.task_class(cfg.task_config)
        self.codec = self.observation_codec
        self._parts = self.observation_parts()
        self.dict_observation_space = self.codec.dict_space
        self.observation_space = self.codec.space(cfg.observation_mode)
        self.action_space = spaces.Box(
            -1.0, 1.0, shape=(7 if cfg.tare_action else 6,), dtype=np.float32
        )
        self._guard = StepGuard(self.action_space)
        self._scene: ProbeScene | None = None
        # The estimate ``_errors`` belong to (``_true_errors``).
        self._errors_of: AxisEstimate | None = None

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg = self.config
        scenario = cfg.draw_scenario(self.np_random, self.geometry)
        if self._scene is None:
            self._scene = ProbeScene(
                scenario.object_config,
                cfg.skin_config,
                cfg.sensor_config,
                self.geometry,
                time_step=cfg.time_step,
                substeps=cfg.substeps,
                force_limit=cfg.force_limit,
                gui=self.render_mode == "human",
                physics=cfg.physics,
            )
        self._scene.reset(
            scenario.joint_angle,
            scenario.fingertip_position,
            scenario.fingertip_orientation,
            object_config=scenario.object_config,
            rng=self.np_random,
        )
        self._steps = 0
        self._start_position = self._scene.fingertip_position
        # Every episode starts in free air (2-5 mm above the face, "Starting State"): the
        # operator's tare there needs no knowledge of contact.
        perceived = self.pipeline.reset(self._sample(None, cfg.tare_action))
        self._guard.begin()
        self._errors_of = None  # a new episode's truth: no errors computed for it yet
        facts = self._true_facts(None, np.zeros(6))
        self.task.initialize_episode(facts)
        return self._observation(), self._true_info(perceived, facts)

    def step(self, action):
        action = self._guard.check(action)
        position, rotation = self.controller.target(action, *self._scene.fingertip_pose)
        step_info = self._scene.control_step(position, rotation)
        self._steps += 1
        perceived = self.pipeline.step(self._sample(rotation, self._tare_asked(action)))
        facts = self._true_facts(step_info, action[:6])
        reasons = self.task.get_termination(facts)
        terminated = any(reasons.values())
        reward, terms = self.task.get_reward(facts, terminated)
        truncated = self._steps >= self.config.max_steps and not terminated
        self._guard.end(terminated or truncated)
        if self.render_mode == "human":
            self.render()
        info = self._true_info(perceived, facts, step_info.force_limited, terms, reasons)
        return self._observation(), reward, terminated, truncated, info

    def render(self):
        """The frame (``render_mode="rgb_array"``): the probed region with the force, the
        measurements, the estimated axis and, with ``render_truth=True``, the true axis
        (``tactile_gym.envs.render``)."""
        if self._scene is None or self.render_mode != "rgb_array":
            return None
        return self.frame()

    def frame(self, caption: str = "") -> np.ndarray:
        """The current frame, with ``caption`` in its key (the primitive env's)."""
        options = self.render_options
        truth = self._true_axis_for_render() if options.render_truth else None
        return draw_frame(self._scene, self.pipeline, self._steps, options, truth, caption)

    def close(self):
        self._guard.stop()
        if self._scene is not None:
            self._scene.close()
            self._scene = None

    def _tare_asked(self, action: np.ndarray) -> bool:
        return bool(self.config.tare_action and action[6] > 0.5)

    def _sample(self, commanded_rotation: np.ndarray | None, tare: bool) -> Sample:
        """This step's reading and the fingertip's pose, as a robot logs them; a tare's
        reading averages ``TARE_SAMPLES`` sensor samples (``docs/design.md`` 5.1)."""
        scene = self._scene
        return Sample(
            time=self._steps * self.period,
            wrench=scene.read_wrench(self.np_random, TARE_SAMPLES if tare else 1),
            position=scene.fingertip_position,
            rotation=scene.fingertip_rotation,
            tare=tare,
            commanded_rotation=commanded_rotation,
        )

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
        scene = self._scene
        parts = self._parts(
            self.pipeline,
            scene.fingertip_position,
            scene.fingertip_orientation,
            time_left=1.0 - self._steps / self.config.max_steps,
        )
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
        """What the task judges a step by (``StepFacts``), from the truth and the step (None:
        the reset, no step)."""
        position_error, angle_error = self._true_errors()
        pin, _ = self._scene.true_axis
        position = self._scene.fingertip_position
        estimate = self.pipeline.estimate
        return StepFacts(
            position_error=position_error,
            angle_error=angle_error,
            max_force=0.0 if step_info is None else float(step_info.max_force),
            force_limit=float(self._scene.force_limit),
            shell_contact=step_info is not None and bool(step_info.shell_contact),
            hinge_distance=norm(position - pin),
            start_distance=norm(position - self._start_position),
            action=action,
            measurements=len(self.pipeline.measurements),
            position_std=estimate.position_std,
            angle_std=estimate.angle_std,
        )

    def _true_axis_for_render(self) -> tuple[np.ndarray, np.ndarray]:
        """The true axis, drawn only with ``render_truth=True`` (videos, never an input)."""
        point, direction = self._scene.true_axis
        return point.copy(), direction.copy()

    def _true_info(
        self,
        perceived: Perceived,
        facts: StepFacts,
        force_limited: bool = False,
        terms: dict[str, float] | None = None,
        reasons: dict[str, bool] | None = None,
    ) -> dict[str, Any]:
        """The ``info`` of a reset (no terms nor reasons: the step's entries 0 or False) or a
        step, flat and numeric (class docstring, Episode End)."""
        point, direction = self._scene.true_axis
        info = {
            **self.task.info(facts, terms, reasons),
            "n_measurements": np.int64(len(self.pipeline.measurements)),
            "new_measurements": np.int64(len(perceived.accepted)),
            "true_axis_point": point,  # the scene's copies
            "true_axis_direction": direction,
            "joint_angle": np.float64(self._scene.joint_angle),
            "max_force": np.float64(facts.max_force),
            "force_limited": np.bool_(force_limited),
        }
        if self.config.tare_action:
            info["tared"] = np.bool_(perceived.tared)
            info["tare_refused"] = np.bool_(perceived.tare_refused)
            info["tare_age"] = np.float64(self.pipeline.tare_age(self._steps * self.period))
        return info
