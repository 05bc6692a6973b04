"""What every ``python -m agents.<name>`` command shares: its parser, its errors, its quiet.

* :func:`make_parser`: the usage names the module as the README runs it
  (``python -m agents.train``, or ``python -m tactile_gym.agents.train`` from a wheel), every
  option's help shows its default, and ``--debug`` is added.
* :func:`run_main`: runs a command's ``main(argv)``. An expected error (a bad id, value,
  config file or key, a missing model or extra: :data:`EXPECTED_ERRORS`) becomes one line on
  stderr and exit status 2, like pip, ruff and argparse; ``--debug`` shows the traceback
  instead. A closed pipe (``--dry-run | head``) ends quietly, Ctrl-C with status 130.
* :class:`KeyValue`: the ``key:value`` arguments of ``--hyperparams`` and ``--env-kwargs``.
* :data:`DEFAULT_ENV_ID`, :func:`make_env`, :func:`check_env_id`: the ids the commands take.
* :func:`json_safe`: what the commands write as strict JSON.

A command adopts all of it in a few lines::

    from .cli import make_parser, run_main

    def main(argv=None):
        parser = make_parser(__spec__.name, __doc__)
        ...

    if __name__ == "__main__":
        sys.exit(run_main(main))
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import textwrap
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import yaml

import tactile_gym

#: Every id the commands take: the current ids, the joint ids (which joint is it), and the
#: legacy ones that committed models use (the joint ids' v0 among them: models train on it).
KNOWN_ENV_IDS: tuple[str, ...] = (
    tactile_gym.ENV_IDS
    + tactile_gym.JOINT_ENV_IDS
    + tactile_gym.LEGACY_ENV_IDS
    + tactile_gym.LEGACY_JOINT_ENV_IDS
)
#: The env trained and evaluated when none is named.
DEFAULT_ENV_ID = tactile_gym.ENV_IDS[0]


def check_env_id(field: str, env_id: str) -> None:
    """A ``ValueError`` naming ``field`` unless ``env_id`` is one of ``KNOWN_ENV_IDS``."""
    if env_id not in KNOWN_ENV_IDS:
        raise ValueError(f"{field} must be one of {', '.join(KNOWN_ENV_IDS)}, got {env_id!r}")


def make_env(env_id: str, **env_kwargs: Any) -> gym.Env:
    """``gym.make`` after importing tactile_gym, so that worker processes know the ids."""
    import tactile_gym  # noqa: F401 - registers the envs in this process

    return gym.make(env_id, **env_kwargs)


def json_safe(value):
    """``value`` with every non-finite float replaced by ``None`` (strict JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


#: Errors that mean "the input was wrong", not "the code is wrong": reported in one line.
#: ``ImportError`` is a missing extra (its message names the install command).
EXPECTED_ERRORS = (ValueError, FileNotFoundError, IsADirectoryError, ImportError, yaml.YAMLError)
#: Exit status of a command given bad input (argparse's, pip's and ruff's).
USAGE_ERROR = 2
KEY_VALUE_HELP = (
    "space-separated key:value pairs; each value is read as YAML, so 3e-4, true, flat, "
    "[64, 64] and {a: 1} are a float, a bool, a string, a list and a mapping"
)


def install_hint(extra: str) -> str:
    """How to install an extra, for a checkout and for the wheel."""
    return (
        f'pip install -e ".[{extra}]" in a checkout, or pip install "tactile-gym[{extra}]" '
        "with the wheel"
    )


def require(module: str, extra: str):
    """Import ``module``, or raise an ImportError that names the extra to install."""
    import importlib

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        if error.name != module.split(".")[0]:
            raise
        raise ImportError(f"{module} is not installed; {install_hint(extra)}") from error


def progress_bar(total: int, desc: str, unit: str):
    """A tqdm progress bar on stderr, with rate and ETA, shown where stderr is a terminal
    (tqdm comes with ``[train]``; without it, or off a terminal, a bar that shows nothing).
    """
    try:
        from tqdm.auto import tqdm
    except ImportError:
        from types import SimpleNamespace

        return SimpleNamespace(update=lambda n=1: None, close=lambda: None)
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Defaults shown after each option's help (where there is one to show: not for flags,
    nor where the help says what happens without the option); the description's examples
    kept as written."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if (
            action.default is None
            or action.default is False
            or action.default == {}
            or ("default:" in action.help)
        ):
            return action.help
        return super()._get_help_string(action)


def make_parser(module: str | None, doc: str | None, **kwargs: Any) -> argparse.ArgumentParser:
    """A parser whose usage reads ``python -m <module>`` and whose help shows defaults.

    Args:
        module: the command's module (``__spec__.name``): ``agents.train`` in a checkout,
            ``tactile_gym.agents.train`` in a wheel.
        doc: the module docstring; its first line is the description, its first indented
            block (the example commands) the epilog.
        **kwargs: further ``argparse.ArgumentParser`` arguments.
    """
    first, _, rest = (doc or "").strip().partition("\n")
    examples = textwrap.dedent(rest.lstrip("\n").split("\n\n")[0])
    parser = argparse.ArgumentParser(
        prog=f"python -m {module}" if module else None,
        description=first,
        epilog=f"examples:\n{textwrap.indent(examples, '  ')}" if examples.strip() else None,
        formatter_class=HelpFormatter,
        **kwargs,
    )
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    return parser


class KeyValue(argparse.Action):
    """``key:value`` pairs into a dict; each value is read as YAML (``3e-4``, ``[64, 64]``,
    ``flat``, ``{a: 1}``), like rl_zoo3's ``--env-kwargs``/``--hyperparams`` without eval."""

    def __call__(self, parser, namespace, values, option_string=None):
        pairs = {}
        for item in values:
            key, sep, value = item.partition(":")
            if not sep or not key:
                raise argparse.ArgumentError(self, f"expected key:value, got {item!r}")
            try:
                pairs[key] = yaml.safe_load(value)
            except yaml.YAMLError as error:
                raise argparse.ArgumentError(
                    self, f"the value of {key!r} is not valid YAML: {value!r}"
                ) from error
            joined = _colon_without_space(pairs[key])
            if joined is not None:
                meant = value.replace(joined, joined.replace(":", ": "))
                raise argparse.ArgumentError(
                    self,
                    f"the value of {key!r} reads {joined!r} as one key with no value: YAML "
                    f"needs a space after a colon, as in '{key}:{meant}' (quoted for the shell)",
                )
        setattr(namespace, self.dest, pairs)


def _colon_without_space(value: Any) -> str | None:
    """A mapping key in ``value``, at any depth, that holds a colon and has no value: what
    YAML reads from ``{friction:0.3}``, where ``{friction: 0.3}`` was meant."""
    if isinstance(value, dict):
        for key, item in value.items():
            if isinstance(key, str) and ":" in key and item is None:
                return key
            found = _colon_without_space(item)
            if found is not None:
                return found
    if isinstance(value, list):
        for item in value:
            found = _colon_without_space(item)
            if found is not None:
                return found
    return None


def _message(error: BaseException) -> str:
    """The error's text; a YAML syntax error's in one line with its file and line."""
    mark = getattr(error, "problem_mark", None)
    if isinstance(error, yaml.YAMLError) and mark is not None:
        return f"{mark.name}, line {mark.line + 1}: invalid YAML: {error.problem}"
    return str(error).strip() or type(error).__name__


def command_name(main: Callable) -> str:
    """``python -m <module>`` of the command whose ``main`` this is."""
    module = main.__module__
    if module == "__main__":
        spec = getattr(sys.modules["__main__"], "__spec__", None)
        module = spec.name if spec else os.path.basename(sys.argv[0])
    return f"python -m {module}"


def run_main(main: Callable[[list[str] | None], Any], argv: list[str] | None = None) -> int:
    """Run a command's ``main(argv)`` and return its exit status.

    Expected errors (:data:`EXPECTED_ERRORS`) print ``<command>: error: <message>`` on stderr
    and give :data:`USAGE_ERROR`; with ``--debug`` in ``argv`` they raise, traceback and all.
    ``main`` returning an int is the status; anything else is success.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    name = command_name(main)
    try:
        result = main(argv)
        sys.stdout.flush()  # a closed pipe shows here, not as a complaint at exit
    except EXPECTED_ERRORS as error:
        if "--debug" in argv:
            raise
        message = _message(error)
        print(f"{name}: error: {message}", file=sys.stderr)
        return USAGE_ERROR
    except BrokenPipeError:
        # The reader went away (`| head`): stop writing, and keep Python from complaining
        # again when it flushes stdout at exit.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return result if isinstance(result, int) and not isinstance(result, bool) else 0
