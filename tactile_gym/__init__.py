"""tactile_gym: active tactile perception of articulated objects.

Importing the package registers its environments with Gymnasium::

    import gymnasium as gym
    import tactile_gym  # noqa: F401

    env = gym.make("tactile_gym/HingeProbe-v2")
    envs = gym.make_vec("tactile_gym/HingeProbe-v2", num_envs=4)  # N scenes, one process

``tactile_gym.sensing``, ``tactile_gym.estimation``, ``tactile_gym.perception`` and
``tactile_gym.replay`` import without pybullet, and without Gymnasium (a robot's perception
needs neither: the ids are then not registered); the environment modules are only imported
when an env is made.

The v3 ids are the current ones: the realistic F/T sensor (offset, drift, the fingertip's
weight) with taring, as v2, on a leaner contact step, with an estimator whose predicted
uncertainty is calibrated, and a press that measures the skin's force gradient and holds
until its mean is good enough (``docs/design.md`` 5.2). The v2 and v1 ids
(``LEGACY_ENV_IDS``; v1: the ideal sensor, a 6-D action, no tare) stay registered
unchanged, so that models trained on them still run. The v0 ids are retired: their skin
model gave no edge direction from a pure press and their start pose revealed the edge
(``docs/design.md``, "Versions").
"""

from tactile_gym.registration import RegisteredKeywords

__version__ = "0.3.0"

_PLANAR = {"families": ("scissors",), "estimator": "planar"}
# The lid is left out of the 3D mix: lying on the table it can only be pushed shut, so a
# fingertip from above cannot turn it (docs/design.md, "Known limits"); families=("lid",)
# still builds it.
_3D = {"families": ("scissors", "door", "tilted"), "estimator": "3d"}

# The adaptive press (docs/design.md 5.2): every skill's press steps by the force gradient it
# measures, and the gate measures a still press, and a probe holds, until the predicted edge
# error of its mean is 2 deg (rad here), within 12 readings, its steadiness judged on the trend.
_ADAPTIVE_PRESS = {
    "measure_gradient": True,
    "gate": {"edge_std_target": 0.03490658503988659, "dwell_budget": 12, "steady_rule": "trend"},
}
# Each version's keywords over HingeProbeConfig's defaults (docs/design.md 10). v3: the lean
# contact step (3.6), the calibrated covariance (6.9) and the adaptive press (5.2). v2: the
# defaults. v1: the ideal sensor (white noise only), no tare and the gate without the preload
# rule (7.2).
_LEAN_CALIBRATED = {"physics": "v3", "estimator_covariance": "calibrated"}
_V3 = {**_LEAN_CALIBRATED, **_ADAPTIVE_PRESS}
_V1 = {"sensor_model": "ideal", "tare_action": False, "gate": {"preload_rule": False}}
#: Every registered version, newest first, with its keywords.
_VERSIONS = (("v3", _V3), ("v2", {}), ("v1", _V1))

_SIX_D = (
    "tactile_gym.envs.hinge_probe:HingeProbeEnv",
    "tactile_gym.envs.vector:make_vector_env",
)
_PRIMITIVE = (
    "tactile_gym.envs.hinge_probe_primitive:make_primitive_env",
    "tactile_gym.envs.vector:make_primitive_vector_env",
)
#: Each task: its name, its entry points (single env, vector env) and its keywords.
_TASKS = (
    ("HingeProbe", _SIX_D, _PLANAR),
    ("HingeProbe3D", _SIX_D, _3D),
    ("HingeProbePrimitive", _PRIMITIVE, _PLANAR),
    ("HingeProbe3DPrimitive", _PRIMITIVE, _3D),
)

# The joint ids (issue 28): the joint type unknown, each reset drawing a family of any joint;
# on the v3 ids' contact step and calibrated covariance, with the v2 press (the adaptive press,
# measured on v1, costs the blocks' typing: docs/design.md 7.12).
_JOINT_PLANAR = {"families": ("scissors", "slider", "block"), "estimator": "planar"}
_JOINT_3D = {"families": ("door", "tilted", "drawer", "tilted_drawer", "block"), "estimator": "3d"}
_JOINT_SIX_D = (
    "tactile_gym.envs.joint_probe:JointProbeEnv",
    "tactile_gym.envs.joint_probe:make_vector_env",
)
_JOINT_PRIMITIVE = (
    "tactile_gym.envs.joint_probe_primitive:make_primitive_env",
    "tactile_gym.envs.joint_probe_primitive:make_primitive_vector_env",
)
_JOINT_TASKS = (
    ("JointProbe", _JOINT_SIX_D, _JOINT_PLANAR),
    ("JointProbe3D", _JOINT_SIX_D, _JOINT_3D),
    ("JointProbePrimitive", _JOINT_PRIMITIVE, _JOINT_PLANAR),
    ("JointProbe3DPrimitive", _JOINT_PRIMITIVE, _JOINT_3D),
)
# The joint ids' v1 objects (docs/design.md 7.12): every face that looks up at least 17 mm
# wide, as the paper's grips are (20 mm, scaled by 0.85-1.15), so that a contact patch, 13 mm
# across at the gate's 7.5 N, never spans two of a face's edges: a door and its frame 20 mm
# thick (a cabinet door's 16-22 mm), a slider's rail and a drawer's cabinet panel 20 mm wide.
# What a family's own entry holds: ObjectConfig.family_default.
_JOINT_OBJECTS_V1 = {
    "door": {"free_link_size": (0.12, 0.02, 0.10), "fixed_link_size": (0.04, 0.02, 0.10)},
    "slider": {"fixed_link_size": (0.02, 0.002, 0.14)},
    "drawer": {"fixed_link_size": (0.02, 0.03, 0.20)},
    "tilted_drawer": {"fixed_link_size": (0.02, 0.03, 0.20)},
}
# The joint ids' v1 (docs/design.md 7.12): those objects; a press enters the estimate only once
# it is consistent with its line (e.g. a second press on it at least 6 mm away agrees with it);
# a model fit that a warm start held in a wrong minimum is refitted from scratch.
_JOINT_V1 = {
    "object": _JOINT_OBJECTS_V1,
    "labels": {"confirm_spacing": 0.006},
    "restart_misfits": True,
}
#: Each joint version's keywords over JointProbeConfig's defaults, newest first. v1: faces at
#: least 17 mm wide and the pipeline's corner rule (7.12). v0: the v3 ids' contact step and
#: covariance with the v2 press.
_JOINT_VERSIONS = (
    ("v1", {**_LEAN_CALIBRATED, **_JOINT_V1}),
    ("v0", _LEAN_CALIBRATED),
)

#: The current environment ids (v3): two tasks (the paper's planar scissors; scissors, doors
#: and tilted axes with a 3D estimator), each with two action modes on the same physics (6-D
#: fingertip motions and a tare, or probing primitives that run the former underneath).
ENV_IDS: tuple[str, ...] = tuple(f"tactile_gym/{name}-v3" for name, _, _ in _TASKS)
#: The earlier versions' ids, still registered and unchanged to the bit, so that the models
#: and figures made on them reproduce: v2 (the v2 contact step and the independent
#: covariance) and v1 (the ideal sensor, no tare, the v1 gate).
LEGACY_ENV_IDS: tuple[str, ...] = tuple(
    f"tactile_gym/{name}-{version}" for version, _ in _VERSIONS[1:] for name, _, _ in _TASKS
)
#: The joint ids: which joint is it (rigid, revolute or prismatic), and its parameters;
#: planar and 3D, each with both action modes, on the v3 ids' physics and estimator.
JOINT_ENV_IDS: tuple[str, ...] = tuple(
    f"tactile_gym/{name}-{_JOINT_VERSIONS[0][0]}" for name, _, _ in _JOINT_TASKS
)
#: The joint ids' earlier versions, still registered and unchanged (v0: faces 7-10 mm wide
#: among them, on which the gate lets corner presses in: docs/design.md 7.12).
LEGACY_JOINT_ENV_IDS: tuple[str, ...] = tuple(
    f"tactile_gym/{name}-{version}"
    for version, _ in _JOINT_VERSIONS[1:]
    for name, _, _ in _JOINT_TASKS
)
#: The ids (every version, and the joint ids) whose step is one probing primitive, many
#: control steps long.
PRIMITIVE_ENV_IDS: tuple[str, ...] = tuple(
    f"tactile_gym/{name}-{version}"
    for version, _ in _VERSIONS
    for name, entries, _ in _TASKS
    if entries is _PRIMITIVE
) + tuple(
    f"tactile_gym/{name}-{version}"
    for version, _ in _JOINT_VERSIONS
    for name, entries, _ in _JOINT_TASKS
    if entries is _JOINT_PRIMITIVE
)

try:
    from gymnasium.envs.registration import register
except ImportError:  # perception alone, on a robot without Gymnasium: nothing to register
    register = None
# Each id's keywords as RegisteredKeywords: gym.make's merge into a nested section
# (gate={"dwell_budget": 20} keeps the id's other gate fields) instead of replacing it.
for _versions, _tasks in ((_VERSIONS, _TASKS), (_JOINT_VERSIONS, _JOINT_TASKS)) if register else ():
    for _version, _extra in _versions:
        for _name, (_entry, _vector_entry), _kwargs in _tasks:
            register(
                id=f"tactile_gym/{_name}-{_version}",
                entry_point=_entry,
                vector_entry_point=_vector_entry,
                kwargs=RegisteredKeywords({**_kwargs, **_extra}),
            )

__all__ = [
    "ENV_IDS",
    "JOINT_ENV_IDS",
    "LEGACY_ENV_IDS",
    "LEGACY_JOINT_ENV_IDS",
    "PRIMITIVE_ENV_IDS",
    "__version__",
]
