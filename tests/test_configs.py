"""Configuration from the user's side: bad input is refused by name; one default per field.

Every field reachable through ``gym.make`` (the env's keywords, each field of the nested
``skin``, ``sensor``, ``object``, ``gate``, ``task`` and ``scenario`` dicts, and the primitive
env's own keywords) is drawn with values of the right and the wrong types, in and out of
range. Making the env must either raise a ``ValueError`` that names the field, or succeed with
a value of the field's type, after which a reset and a step give finite observations inside
the observation space.

One default per field: a shipped preset holds only overrides, a function that takes a config
field's parameter as a keyword refers to the field's one definition instead of restating a
literal, and the env's own keywords do not duplicate the nested configs' fields. Each check
is a function that ``test_the_default_checks_can_fail`` feeds a known violation.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import math
import pkgutil
import textwrap
from numbers import Real
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tactile_gym
from tactile_gym import ENV_IDS
from tactile_gym.envs.hinge_probe import HingeProbeConfig
from tactile_gym.envs.hinge_probe_primitive import HingeProbePrimitiveEnv
from tactile_gym.envs.scenarios import ScenarioConfig
from tactile_gym.envs.skills import PrimitiveScales
from tactile_gym.envs.task import TaskConfig
from tactile_gym.estimation import LOSSES
from tactile_gym.perception.gate import GateConfig
from tactile_gym.presets import load_preset, preset_names
from tactile_gym.registration import merge_keywords
from tactile_gym.sensing import FingertipGeometry, SensorConfig
from tactile_gym.sim import ObjectConfig, SkinConfig
from tactile_gym.sim.config import FAMILIES

#: The nested keywords of ``gym.make`` and the config each one's fields belong to.
NESTED = {
    "skin": SkinConfig,
    "sensor": SensorConfig,
    "object": ObjectConfig,
    "gate": GateConfig,
    "task": TaskConfig,
    "scenario": ScenarioConfig,
}
PRIMITIVE_IDS = tuple(i for i in ENV_IDS if "Primitive" in i)
#: Strings a user might pass for a choice field: every allowed one, and near misses.
STRINGS = (*FAMILIES, *LOSSES, "planar", "3d", "dict", "flat", "", "3D", "Planar", "sphere")


# ---------------------------------------------------------------------------- the fields
@dataclasses.dataclass(frozen=True)
class Field:
    """One keyword reachable through ``gym.make``: ``section`` is a nested dict or None."""

    section: str | None
    name: str
    default: Any

    @property
    def label(self) -> str:
        return f"{self.section}.{self.name}" if self.section else self.name


def _default(field: dataclasses.Field) -> Any:
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return field.default


def env_fields(env_id: str) -> list[Field]:
    """Every field of ``gym.make(env_id, ...)``, with the default that id gives it."""
    registered = gym.spec(env_id).kwargs
    fields = [
        Field(None, f.name, registered.get(f.name, _default(f)))
        for f in dataclasses.fields(HingeProbeConfig)
        if f.name not in NESTED
    ]
    for section, cls in NESTED.items():
        given = registered.get(section, {})  # gym.make merges a section into the registered one
        fields += [
            Field(section, f.name, given.get(f.name, _default(f))) for f in dataclasses.fields(cls)
        ]
    if env_id in PRIMITIVE_IDS:
        fields += [Field(None, name, value) for name, value in primitive_keywords().items()]
    return fields


def primitive_keywords() -> dict[str, Any]:
    """The primitive env's own keywords and their defaults."""
    parameters = inspect.signature(HingeProbePrimitiveEnv.__init__).parameters.values()
    return {
        p.name: p.default
        for p in parameters
        if p.default is not inspect.Parameter.empty and p.name != "render_mode"
    }


def make_kwargs(changes: list[tuple[Field, Any]]) -> dict[str, Any]:
    kwargs: dict[str, Any] = {}
    for field, value in changes:
        if field.section is None:
            kwargs[field.name] = value
        else:
            kwargs.setdefault(field.section, {})[field.name] = value
    return kwargs


# ---------------------------------------------------------------------------- the values
WRONG_TYPES = st.one_of(
    st.none(),
    st.booleans(),
    st.sampled_from([np.bool_(True), "False", "True", "0.01", "nan", "1e6", object()]),
    st.text(max_size=3),
    st.lists(st.floats(-1.0, 1.0), max_size=4),
    st.dictionaries(st.sampled_from(["a", "low"]), st.integers(), max_size=1),
)
#: Any magnitude from 1e-12 to 1e12, either sign, and the special floats.
ANY_REAL = st.one_of(
    st.floats(-12.0, 12.0).map(lambda e: 10.0**e),
    st.floats(-12.0, 12.0).map(lambda e: -(10.0**e)),
    st.sampled_from([0.0, math.nan, math.inf, -math.inf, 1e300, -1e300]),
)
FACTORS = (-1.0, 0.0, 1e-6, 0.1, 0.5, 0.9, 1.0, 1.1, 2.0, 10.0, 1e3, 1e6)


def near(x: float) -> st.SearchStrategy:
    """Values around ``x``: scaled by common factors, or within twice its size."""
    span = 2.0 * abs(x) + 1e-3
    return st.one_of(
        st.sampled_from(FACTORS).map(lambda f: x * f),
        st.floats(-span, span),
    )


def number_values(default: float | None) -> st.SearchStrategy:
    scale = 1.0 if default is None else float(default)
    return st.one_of(
        near(scale),
        ANY_REAL,
        near(scale).map(np.float32),
        st.integers(-3, 3),
        st.sampled_from([scale, 10**6, 10**12]),
        st.just(None),
        WRONG_TYPES,
    )


def int_values(default: int) -> st.SearchStrategy:
    return st.one_of(
        st.integers(-2, 2 * default + 2),
        st.sampled_from([0, -1, 10**6, 10**12, -(10**12)]),
        st.sampled_from([float(default), 1e6, default + 0.5]),
        st.integers(-2, 2 * default + 2).map(np.int64),
        WRONG_TYPES,
    )


def tuple_values(default: tuple) -> st.SearchStrategy:
    if all(isinstance(v, str) for v in default):  # families
        names = st.sampled_from(STRINGS)
        return st.one_of(
            st.lists(names, max_size=4),
            st.lists(names, max_size=4).map(tuple),
            names,
            WRONG_TYPES,
        )
    numbers = st.tuples(*[st.one_of(near(float(v)), ANY_REAL) for v in default])
    mixed = st.tuples(*[st.one_of(near(float(v)), ANY_REAL, WRONG_TYPES) for v in default])
    return st.one_of(
        numbers,
        numbers.map(list),
        numbers.map(np.array),
        mixed,
        st.just(tuple(reversed(default))),
        st.lists(st.one_of(near(float(default[0])), ANY_REAL), max_size=len(default) + 2),
        WRONG_TYPES,
    )


def values_for(field: Field) -> st.SearchStrategy:
    """Values of the right and the wrong types, in and out of range, for one field."""
    default = field.default
    if isinstance(default, bool):
        return st.one_of(st.booleans(), st.just(np.bool_(False)), WRONG_TYPES, st.integers(0, 1))
    if isinstance(default, int):
        return int_values(default)
    if isinstance(default, float) or default is None:
        return number_values(default)
    if isinstance(default, str):
        return st.one_of(st.sampled_from(STRINGS), WRONG_TYPES)
    if isinstance(default, tuple):
        return tuple_values(default)
    raise AssertionError(f"no values for {field.label} = {default!r}")


def scaled(x: float) -> st.SearchStrategy:
    """Values of the sign of ``x`` from a tenth to ten times it (small ones around 0)."""
    if x == 0.0:
        return st.floats(-1e-3, 1e-3)
    return st.one_of(
        st.sampled_from((0.1, 0.5, 0.9, 1.1, 2.0, 10.0)).map(lambda f: x * f),
        st.floats(min(0.0, 2.0 * x), max(0.0, 2.0 * x)),
    )


def plausible_values_for(field: Field) -> st.SearchStrategy:
    """Values of the field's type around its default: mostly accepted, often at the edge of
    the allowed range, so that the physics runs with them."""
    default = field.default
    if isinstance(default, bool):
        return st.booleans()
    if isinstance(default, int):
        return st.sampled_from((0.1, 0.5, 2.0, 10.0)).map(lambda f: int(default * f) or default)
    if default is None:  # tangential_stiffness: k_n / 3 unless given
        return st.one_of(st.none(), st.floats(5.0, 10.0).map(lambda e: 10.0**e))
    if isinstance(default, float):
        return scaled(default)
    if isinstance(default, str):
        return st.sampled_from(STRINGS)
    if isinstance(default[0], str):  # families
        return st.lists(st.sampled_from(FAMILIES), min_size=1, max_size=3, unique=True)
    return st.one_of(st.tuples(*[scaled(v) for v in default]), st.just(tuple(reversed(default))))


@st.composite
def changes(draw, env_id: str, max_fields: int, plausible: bool = False) -> list:
    """One to ``max_fields`` fields of ``env_id``, each with a drawn value."""
    fields = env_fields(env_id)
    chosen = draw(st.lists(st.sampled_from(fields), min_size=1, max_size=max_fields, unique=True))
    values = plausible_values_for if plausible else values_for
    return [(field, draw(values(field))) for field in chosen]


# ---------------------------------------------------------------------------- the checks
def _is_real(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, (bool, np.bool_))


def accepted_value_is_sane(field: Field, value: Any) -> bool:
    """Whether an accepted value has the field's type (no bool for a number, no string for a
    bool, no NaN, the default's length), so that nothing absurd passes silently."""
    default = field.default
    if isinstance(default, bool):
        return isinstance(value, (bool, np.bool_))
    if isinstance(default, (int, float)) or default is None:
        if value is None:
            return default is None
        if isinstance(default, int) and not isinstance(value, (int, np.integer)):
            return False
        return _is_real(value) and math.isfinite(value)
    if isinstance(default, str):
        return isinstance(value, str)
    if field.name in ("families", "fixed_layouts"):
        if not isinstance(value, (str, list, tuple)):
            return False
        names = (value,) if isinstance(value, str) else tuple(value)
        # No fixed layout is sane (every family yawed at random); no family is not.
        return (len(names) > 0 or field.name == "fixed_layouts") and set(names) <= set(FAMILIES)
    if not isinstance(value, (list, tuple, np.ndarray)):
        return False
    values = list(value)
    return len(values) == len(default) and all(_is_real(v) and math.isfinite(v) for v in values)


def make_or_refuse(env_id: str, change: list[tuple[Field, Any]], **extra) -> gym.Env | None:
    """``gym.make`` with the changes: None when it refused them as it must, with a
    ``ValueError`` naming one of the fields; the env when each value is sane."""
    try:
        env = gym.make(env_id, **extra, **make_kwargs(change))
    except ValueError as error:
        names = [field.name for field, _ in change]
        assert any(name in str(error) for name in names), f"{error!r} names none of {names}"
        return None
    for field, value in change:
        assert accepted_value_is_sane(field, value), f"{field.label}={value!r} was accepted"
    return env


def check_one_step(env: gym.Env) -> None:
    """A reset and one step give finite observations inside the space."""
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    obs2, reward, *_ = env.step(env.action_space.sample())
    for o in (obs, obs2):
        assert env.observation_space.contains(o)
        flat = gym.spaces.flatten(env.observation_space, o)
        assert np.all(np.isfinite(flat))
    assert math.isfinite(reward)


FUZZ = settings(
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@settings(FUZZ, max_examples=250)
@given(data=st.data())
def test_any_field_any_value_is_refused_by_name_or_sane(data):
    """Validation alone, on every id: make the env and never step it (a fixed start keeps the
    prior's draws out of it, unless ``randomize`` is the field drawn)."""
    env_id = data.draw(st.sampled_from(ENV_IDS), label="env_id")
    change = data.draw(changes(env_id, max_fields=1), label="change")
    fixed = {} if change[0][0].name == "randomize" else {"randomize": False}
    env = make_or_refuse(env_id, change, **fixed)
    if env is not None:
        env.close()


@settings(FUZZ, max_examples=25)
@given(data=st.data())
def test_accepted_values_give_finite_observations(data):
    """Up to three fields at once, drawn near their defaults, then a reset and a step."""
    env_id = data.draw(st.sampled_from(ENV_IDS), label="env_id")
    change = data.draw(changes(env_id, max_fields=3, plausible=True), label="change")
    env = make_or_refuse(env_id, change)
    if env is not None:
        check_one_step(env)
        env.close()


#: The planar ids (the 6-D one and the primitive one).
PLANAR_IDS = [ENV_IDS[0], PRIMITIVE_IDS[0]]


@pytest.mark.parametrize("env_id", PLANAR_IDS)
@pytest.mark.parametrize(
    "kwargs, field",
    [
        # The list.
        ({"task": {"error_scale": 0}}, "task.error_scale"),
        ({"task": {"error_cap": -0.1}}, "task.error_cap"),
        ({"scenario": {"position_jitter": 1000}}, "scenario.position_jitter"),
        ({"randomize": "False"}, "randomize"),
        ({"substeps": True}, "substeps"),
        ({"skin": {"normal_stiffness": True}}, "skin.normal_stiffness"),
        ({"substeps": 1e6}, "substeps"),
        ({"substeps": 10**6}, "substeps"),
        ({"object": {"axis": (0.0, 0.0, 0.0)}}, "object.axis"),
        ({"gate": {"force_band": (5.0, 4.0, 3.0)}}, "gate.force_band"),
        ({"sensor": {"force_noise_std": math.nan}}, "sensor.force_noise_std"),
        ({"max_translation": math.inf}, "max_translation"),
        # Found by the fuzzing above: each was another exception, or a misleading message.
        ({"object": {"family": "door"}}, "object.family"),  # TypeError
        ({"object": {"edge_radius": "0.0003"}}, "object.edge_radius"),  # TypeError
        ({"object": {1: 2, "a": 3}}, "object"),  # TypeError
        ({"skin": {1: 2, "a": 3}}, "skin"),  # TypeError
        ({"object": {"axis": (1e300, 1e300, 0.0)}}, "object.axis"),  # blamed link_direction
        ({"gate": {"force_band": (0.0, 1e-5)}}, "force_band"),  # below TOUCH_FORCE
        ({"max_translation": 5e-324}, "max_translation"),  # OverflowError in a primitive
        # A tilted axis contradicts the planar estimator, as other families do.
        ({"object": {"axis": (1.0, 0.0, 1.0)}}, "object.axis"),
    ],
)
def test_known_bad_values_are_refused_by_name(env_id, kwargs, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        gym.make(env_id, **kwargs)


@pytest.mark.parametrize("env_id", PLANAR_IDS)
@pytest.mark.parametrize(
    "kwargs",
    [
        {"object": {"lower_limit": 1.0}},  # reset failed: the object was built at angle 0
        {"observation_mode": "flat"},  # the primitives indexed the flat vector by name
    ],
)
def test_fuzzing_finds_that_now_work(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    for _ in range(2):
        check_one_step(env)
    env.close()


@pytest.mark.parametrize("env_id", [ENV_IDS[0], PRIMITIVE_IDS[0]])
def test_every_field_refuses_wrong_types_and_absurd_sizes(env_id):
    """Each field on its own: a bool for a number, a string for a bool, NaN, a wrong length
    and a value of 1e12 (no field is unbounded) are refused with the field named."""
    for field in env_fields(env_id):
        default = field.default
        if isinstance(default, bool):
            bad = ["False", 1, None]
        elif isinstance(default, (int, float)) or default is None:
            bad = [True, str(default), math.nan, 1e12, -1e12]
            if isinstance(default, int):
                bad += [10**12, -(10**12), float(default)]
        elif isinstance(default, str):
            bad = [1, None, default.upper() + "?"]
        elif field.name == "families":
            bad = [(), ("sphere",), [1]]
        elif field.name == "fixed_layouts":  # a list of families, empty allowed
            bad = [("sphere",), [1], "sphere"]
        else:
            huge = (1e12,) * len(default)
            bad = [default[:-1], (*default, default[0]), (math.nan,) * len(default), huge]
        fixed = {} if field.name == "randomize" else {"randomize": False}
        for value in bad:
            with pytest.raises(ValueError, match=field.name):
                gym.make(env_id, **fixed, **make_kwargs([(field, value)]))


@pytest.mark.parametrize("section", NESTED)
@pytest.mark.parametrize("value", [5, "abc", [1], None, {1: 2}, {1: 2, "a": 3}, {"bogus": 1}])
def test_nested_keywords_take_only_dicts_of_their_fields(section, value):
    with pytest.raises(ValueError, match=section):
        gym.make(ENV_IDS[0], **{section: value})


@pytest.mark.parametrize("mode", ["make", "sync", "vector_entry_point"])
def test_a_nested_keyword_merges_into_the_ids_registered_section(mode):
    """``gate={"dwell_budget": 20}`` on a v3 id changes that field and keeps the adaptive
    press's other gate fields (Gymnasium alone would drop them), through ``gym.make`` and
    both ways of ``gym.make_vec``; the registered keywords stay as they were."""
    env_id = ENV_IDS[0]
    registered = dict(gym.spec(env_id).kwargs["gate"])
    assert {"edge_std_target", "steady_rule"} <= set(registered)
    if mode == "make":
        env = gym.make(env_id, gate={"dwell_budget": 20})
        config = env.unwrapped.config
    elif mode == "sync":
        env = gym.make_vec(env_id, num_envs=1, vectorization_mode=mode, gate={"dwell_budget": 20})
        config = env.envs[0].unwrapped.config
    else:
        env = gym.make_vec(env_id, num_envs=1, vectorization_mode=mode, gate={"dwell_budget": 20})
        (config,) = env.call("config")
    merged = {**registered, "dwell_budget": 20}
    assert config.gate == merged
    assert config.gate_config == GateConfig(**merged) != GateConfig(dwell_budget=20)
    assert env.spec.kwargs["gate"] == merged  # the spec says what the env was made with
    env.close()
    assert gym.spec(env_id).kwargs["gate"] == registered


def test_a_merged_nested_keyword_is_still_checked_by_name():
    with pytest.raises(ValueError, match=r"unknown gate field\(s\) \['dwel_budget'\]"):
        gym.make(ENV_IDS[0], gate={"dwel_budget": 20})
    # A registered field set back to its class default: the merge cannot drop a key.
    env = gym.make(ENV_IDS[0], gate={"steady_rule": GateConfig().steady_rule})
    assert env.unwrapped.config.gate_config.steady_rule == GateConfig().steady_rule
    env.close()


def test_merge_keywords_merges_mappings_at_any_depth_and_replaces_the_rest():
    base = {"gate": {"dwell": 8, "force_band": (4.5, 5.5)}, "a": {"b": {"c": 1, "d": 2}}, "n": 1}
    changes = {"gate": {"dwell": 9}, "a": {"b": {"c": 3}}, "n": {"x": 1}, "skin": {"friction": 1}}
    assert merge_keywords(base, changes) == {
        "gate": {"dwell": 9, "force_band": (4.5, 5.5)},
        "a": {"b": {"c": 3, "d": 2}},
        "n": {"x": 1},
        "skin": {"friction": 1},
    }
    assert base["gate"] == {"dwell": 8, "force_band": (4.5, 5.5)}  # neither argument changed
    assert merge_keywords(base, {"gate": None})["gate"] is None


def test_shipped_env_presets_make_the_3d_env():
    """The 3D id draws every family but the lid, so each preset is checked on them all."""
    for name in preset_names("env"):
        gym.make(ENV_IDS[1], **load_preset("env", name)).close()


# ---------------------------------------------------------------------------- one default
def config_classes() -> list[type]:
    """The dataclasses that hold defaults of parameters: every ``*Config`` in the package and
    its agents, and the primitive scales and fingertip geometry."""
    classes = {PrimitiveScales, FingertipGeometry}
    for module in package_modules():
        for obj in vars(module).values():
            if (
                inspect.isclass(obj)
                and dataclasses.is_dataclass(obj)
                and obj.__name__.endswith("Config")
                and obj.__module__ == module.__name__
            ):
                classes.add(obj)
    return sorted(classes, key=lambda c: c.__name__)


def package_modules() -> list:
    """tactile_gym's modules and those of its agents (shipped as ``tactile_gym.agents``);
    the Ray helpers need the ``sweep`` extra and hold no defaults."""
    import agents

    modules = []
    for package in (tactile_gym, agents):
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if not info.name.endswith("._ray"):
                modules.append(importlib.import_module(info.name))
    return modules


def restated_defaults(values: dict[str, Any], defaults: dict[str, Any]) -> list[str]:
    """The keys of a preset whose value equals the default it would override."""

    def same(a: Any, b: Any) -> bool:
        if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
            return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
        if _is_real(a) and _is_real(b):
            return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-15)
        return a == b

    return sorted(
        key for key, value in values.items() if key in defaults and same(value, defaults[key])
    )


def _defaults(cls: type) -> dict[str, Any]:
    return {f.name: _default(f) for f in dataclasses.fields(cls)}


def test_object_presets_hold_only_overrides():
    base = _defaults(ObjectConfig)
    for family in preset_names("objects"):
        assert restated_defaults(load_preset("objects", family), base) == [], family


def test_env_presets_hold_only_overrides():
    top = _defaults(HingeProbeConfig)
    families = {f: _defaults(ObjectConfig) | load_preset("objects", f) for f in FAMILIES}
    for name in preset_names("env"):
        preset = load_preset("env", name)
        flat = {k: v for k, v in preset.items() if k not in NESTED}
        assert restated_defaults(flat, top) == [], name
        for section, values in preset.items():
            if section == "object":
                # Applied to every family: a restatement if it changes none of them.
                used = preset.get("families", FAMILIES)
                restated = [restated_defaults(values, families[f]) for f in used]
                assert set.intersection(*map(set, restated)) == set(), (name, section)
            elif section in NESTED:
                assert restated_defaults(values, _defaults(NESTED[section])) == [], (name, section)


def _numeric(value: Any) -> bool:
    """A physical value: a number or a tuple of numbers (not a switch, a name or None)."""
    if isinstance(value, tuple):
        return len(value) > 0 and all(_is_real(v) for v in value)
    return _is_real(value)


def physical_fields(classes: list[type]) -> dict[str, list[tuple[str, Any]]]:
    """Field name -> [(class name, default)] over the numeric fields of ``classes``."""
    fields: dict[str, list[tuple[str, Any]]] = {}
    for cls in classes:
        for f in dataclasses.fields(cls):
            if _numeric(_default(f)):
                fields.setdefault(f.name, []).append((cls.__name__, _default(f)))
    return fields


def _functions(module) -> list[tuple[str, Any]]:
    """Module-level functions and the methods of classes defined in ``module``."""
    found = []
    for name, obj in vars(module).items():
        if getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            found.append((name, obj))
        elif inspect.isclass(obj):
            for attr, member in vars(obj).items():
                member = getattr(member, "__func__", member)
                if inspect.isfunction(member) and member.__module__ == module.__name__:
                    found.append((f"{name}.{attr}", member))
    return found


def _default_expressions(function) -> dict[str, ast.expr]:
    """The source expression of each keyword default of ``function`` (empty without source:
    a dataclass's generated ``__init__``)."""
    try:
        source = textwrap.dedent(inspect.getsource(function))
    except (OSError, TypeError):
        return {}
    node = ast.parse(source).body[0]
    if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
        return {}
    args = node.args
    positional = args.posonlyargs + args.args
    out = {
        a.arg: d for a, d in zip(positional[len(positional) - len(args.defaults) :], args.defaults)
    }
    out.update({a.arg: d for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None})
    return out


def second_defaults(functions: list[tuple[str, Any]], fields: dict, exempt: set) -> list[str]:
    """Keyword defaults of ``functions`` for a physical config field that restate a value
    (any expression but a plain name or attribute, i.e. a reference to one definition) or
    differ from the field's default. ``exempt`` holds (function, parameter) pairs whose
    parameter only shares a field's name."""
    problems = []
    for qualname, function in functions:
        for parameter, expression in _default_expressions(function).items():
            if parameter not in fields or (qualname, parameter) in exempt:
                continue
            value = inspect.signature(function).parameters[parameter].default
            if value is None:
                continue  # "not given", not a second value
            owners = fields[parameter]
            if not isinstance(expression, (ast.Name, ast.Attribute)):
                problems.append(
                    f"{qualname}({parameter}={ast.unparse(expression)}) restates {owners}"
                )
            elif not any(_same_value(value, default) for _, default in owners):
                problems.append(f"{qualname}({parameter}={value!r}) differs from {owners}")
    return problems


def _same_value(a: Any, b: Any) -> bool:
    return restated_defaults({"v": a}, {"v": b}) == ["v"]


#: Parameters that share a config field's name but not its meaning.
NOT_THE_FIELD = {
    # The contact-point noise of one reading along a trace, not the gate's error of a
    # measured point handed to the estimator.
    ("edge_from_trace", "point_std"),
    # How often a failed training run is retried, not the prober's failed probes.
    ("run_sweep", "retries"),
    # The joint ids' primitives reach further (JOINT_SCALES): to the face's other edges.
    ("JointProbePrimitiveEnv.__init__", "probe_across"),
    ("JointProbePrimitiveEnv.__init__", "probe_along"),
}


def test_keyword_defaults_name_the_one_definition():
    fields = physical_fields(config_classes())
    functions = []
    for module in package_modules():
        functions += [(q, f) for q, f in _functions(module)]
    problems = second_defaults(functions, fields, NOT_THE_FIELD)
    assert problems == []
    # Each exemption still names a real parameter (no stale entries).
    names = {q for q, _ in functions}
    assert {q for q, _ in NOT_THE_FIELD} <= names


def test_env_keywords_do_not_duplicate_nested_fields():
    nested = {f.name: cls.__name__ for cls in NESTED.values() for f in dataclasses.fields(cls)}
    top = [f.name for f in dataclasses.fields(HingeProbeConfig) if f.name not in NESTED]
    top += list(primitive_keywords())
    assert {name: nested[name] for name in top if name in nested} == {}


def test_the_default_checks_can_fail():
    # A preset that restates a default, and one that does not.
    assert restated_defaults({"holding_torque": 0.1, "damping": 0.5}, _defaults(ObjectConfig)) == [
        "holding_torque"
    ]
    assert restated_defaults({"free_link_size": [0.1, 0.02, 0.008]}, _defaults(ObjectConfig)) == [
        "free_link_size"
    ]
    fields = physical_fields([SensorConfig, FingertipGeometry])

    def literal(force_noise_std: float = 0.02):
        return force_noise_std

    def different(shell_radius: float = FingertipGeometry.skin_thickness):
        return shell_radius

    def referenced(*, force_noise_std: float = SensorConfig.force_noise_std):
        return force_noise_std

    found = second_defaults(
        [("literal", literal), ("different", different), ("referenced", referenced)], fields, set()
    )
    assert [p.split("(")[0] for p in found] == ["literal", "different"]
