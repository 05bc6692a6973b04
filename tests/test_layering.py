"""The agents layer's imports (issue 25, item 5): no circle among its modules, counting the
imports inside functions; a command (a module with a ``main``) uses another command only
through its public names (``__all__``); the benchmarks import the library, not the commands.
The imports are read from the source, every form: ``from .x import y``, ``from . import x``,
``import agents.x``, ``from tactile_gym.agents import x``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
AGENTS = ROOT / "agents"
MODULES = {path.stem: path for path in AGENTS.glob("*.py")}
PREFIXES = (("agents",), ("tactile_gym", "agents"))


def imported(path: Path, inside_agents: bool) -> dict[str, set[str]]:
    """The agents modules a file imports, each with the names it takes from it: the names
    of a ``from`` import, or the attributes read off the module where it imports the module
    itself (``from . import evaluate`` then ``evaluate.evaluate``)."""
    tree = ast.parse(path.read_text())
    found: dict[str, set[str]] = {}
    as_module: dict[str, str] = {}  # local name -> agents module

    def split(dotted: str) -> list[str] | None:
        parts = dotted.split(".")
        for prefix in PREFIXES:
            if tuple(parts[: len(prefix)]) == prefix:
                return parts[len(prefix) :]
        return None

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                rest = split(alias.name)
                if rest:
                    found.setdefault(rest[0], set())
                    if alias.asname:
                        as_module[alias.asname] = rest[0]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                assert inside_agents, f"{path}: a relative import outside agents/"
                rest = node.module.split(".") if node.module else []
            else:
                rest = split(node.module or "")
                if rest is None:
                    continue
            names = [alias.name for alias in node.names]
            if rest:
                found.setdefault(rest[0], set()).update(names)
            else:  # ``from . import x``: modules
                for alias in node.names:
                    found.setdefault(alias.name, set())
                    as_module[alias.asname or alias.name] = alias.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            module = as_module.get(node.value.id)
            if module is not None:
                found[module].add(node.attr)
    return {module: names for module, names in found.items() if module in MODULES}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every circle a depth-first search meets, each as the modules around it."""
    state: dict[str, int] = {}
    found = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for dep in sorted(graph.get(node, ())):
            if state.get(dep) == 1:
                found.append([*stack[stack.index(dep) :], dep])
            elif dep not in state:
                visit(dep, [*stack, dep])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    return found


def is_command(path: Path) -> bool:
    tree = ast.parse(path.read_text())
    return any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body)


def public(path: Path) -> set[str]:
    """A module's ``__all__``."""
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            return set(ast.literal_eval(node.value))
    return set()


GRAPH = {name: set(imported(path, True)) - {name} for name, path in MODULES.items()}
COMMANDS = {name for name, path in MODULES.items() if is_command(path)}


def test_the_checks_see_what_they_look_for(tmp_path):
    """The checks can fail: a circle hidden in a function and a module import are found."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
    code = tmp_path / "x.py"
    code.write_text(
        "def f():\n    from .train import train\n    from . import evaluate as ev\n"
        "    ev.evaluate()\n    import agents.runs\n"
    )
    assert imported(code, True) == {"train": {"train"}, "evaluate": {"evaluate"}, "runs": set()}


def test_the_agents_layer_has_no_import_circle():
    assert cycles(GRAPH) == []


def test_the_run_folder_and_the_policies_have_their_own_modules():
    """Nothing but ``agents.runs`` knows the run folder's files, and the policies are
    ``agents.policies``', whoever plays them."""
    assert {"evaluate", "train", "selection", "sweep"} <= COMMANDS
    assert "runs" not in COMMANDS and "policies" not in COMMANDS
    for name in ("evaluate", "train"):
        assert "runs" in GRAPH[name]
    assert not GRAPH["runs"] & COMMANDS and not GRAPH["policies"] & COMMANDS


@pytest.mark.parametrize("name", sorted(MODULES))
def test_a_command_is_used_through_its_public_names_only(name):
    for module, names in imported(MODULES[name], True).items():
        if module in COMMANDS and module != name:
            internal = sorted(names - public(MODULES[module]))
            assert not internal, f"agents.{name} uses agents.{module}'s internals {internal}"


@pytest.mark.parametrize("path", sorted((ROOT / "benchmarks").glob("*.py")), ids=lambda p: p.stem)
def test_the_benchmarks_import_the_library_not_the_commands(path):
    commands = sorted(set(imported(path, False)) & COMMANDS)
    assert not commands, f"{path.name} imports the commands {commands}"
