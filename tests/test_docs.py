"""The documentation's own machinery and the repository files that describe the package.

The site itself is built, with warnings as errors, by ``make docs`` (in ``.ci/run``); these
tests need no Sphinx. They check the build hooks' conversions on inputs whose output is known
(``docs/_ext/tactile_docs.py``), that the env pages cover every registered id and that the
env docstrings they render have the reference's sections and cite design sections that
exist, and that LICENSE, CITATION.cff and CHANGELOG.md agree with the package.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import tactile_gym

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
import tactile_docs  # noqa: E402

ENV_SECTIONS = ("Description", "Action Space", "Episode End", "Arguments", "Version History")


def test_literal_blocks_roles_and_design_references_become_myst():
    doc = (
        "Load one::\n\n    env = gym.make(x)\n    env.reset()\n\nThen :class:`~a.B` and "
        ":py:func:`c`, the skin (``docs/design.md`` 3, 4.2) and ``Linked`` not ``other``."
    )
    anchors = {"3": "3-the-skin", "4.2": "42-shear"}
    links = {"Linked": "pkg.mod.Linked"}
    text = tactile_docs.docstring_to_myst(doc, links.get, anchors)
    assert text.startswith("Load one:\n\n```python\nenv = gym.make(x)\nenv.reset()\n```\n")
    assert "{py:class}`~a.B`" in text and "{py:func}`c`" in text
    assert "design notes [3](../design.md#3-the-skin), [4.2](../design.md#42-shear)" in text
    assert "{py:obj}`Linked <pkg.mod.Linked>`" in text and "``other``" in text


def test_an_unknown_design_section_fails_the_page():
    with pytest.raises(ValueError, match=r"no section \['9.9'\]"):
        tactile_docs.docstring_to_myst("(``docs/design.md`` 9.9)", {}.get, {"3": "3-x"})


def test_norms_are_escaped_outside_literals():
    lines = ["|f| >= ``a|b``, |m|.", "Code::", "", "    x = |y|", "", "After |z|."]
    assert tactile_docs.escape_bars(lines) == [
        r"\|f\| >= ``a|b``, \|m\|.",
        "Code::",
        "",
        "    x = |y|",
        "",
        r"After \|z\|.",
    ]


def test_an_indented_block_of_commands_is_literal():
    lines = ["Run:", "", "    python -m a", "    python -m b", "", "    python -m c", "", "Text."]
    assert tactile_docs.literal_commands(lines) == ["Run:", "", "::", "", *lines[2:]]
    marked = ["Run::", "", "    python -m a"]
    assert tactile_docs.literal_commands(marked) == marked


def test_the_env_pages_cover_every_id_once():
    joint = [*tactile_gym.JOINT_ENV_IDS, *tactile_gym.LEGACY_JOINT_ENV_IDS]
    ids = [*tactile_gym.ENV_IDS, *tactile_gym.LEGACY_ENV_IDS, *joint]
    covered = [
        env_id
        for family in tactile_docs.ENV_FAMILIES
        for env_id in ids
        if (env_id in tactile_gym.PRIMITIVE_ENV_IDS) == family.primitive
        and (env_id in joint) == family.joint
    ]
    assert sorted(covered) == sorted(ids)
    classes = {tactile_docs._load(family.cls) for family in tactile_docs.ENV_FAMILIES}
    for env_id in ids:
        entry = gym.spec(env_id).entry_point
        module = entry.split(":")[0] if isinstance(entry, str) else entry.__module__
        assert any(cls.__module__ == module for cls in classes), (env_id, entry)


@pytest.mark.parametrize("family", tactile_docs.ENV_FAMILIES, ids=lambda f: f.page)
def test_env_docstrings_are_references(family):
    """Each env page's source has the reference's sections and cites existing design
    sections."""
    doc = tactile_docs._load(family.cls).__doc__
    headings = re.findall(r"^\s*## (.+)$", doc, re.MULTILINE)
    assert [s for s in ENV_SECTIONS if s not in headings] == [], headings
    design = (ROOT / "docs" / "design.md").read_text()
    sections = set(re.findall(r"^#{2,4} (\d+(?:\.\d+)*)\.? ", design, re.MULTILINE))
    for match in tactile_docs._DESIGN_REF.finditer(doc):
        for number in re.findall(r"\d+(?:\.\d+)?", match.group("refs")):
            assert number in sections, match.group(0)


def test_the_licence_is_the_declared_one():
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'^license = "MIT"$', pyproject, re.MULTILINE)
    licence = (ROOT / "LICENSE").read_text()
    assert licence.startswith("MIT License\n")
    assert "Copyright (c) 2026 the tactile_gym authors" in licence


def test_the_citation_names_the_package_and_the_paper_the_readme_names():
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0" and citation["type"] == "software"
    assert citation["license"] == "MIT"
    (paper,) = citation["references"]
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert f"*{paper['title']}*, IROS {paper['year']}" in readme
    assert paper["authors"][0]["family-names"] == "Matsuo" and "Matsuo et al." in readme
    assert paper["start"] < paper["end"]


def test_the_changelog_has_this_version_and_every_registered_env_version():
    changelog = (ROOT / "CHANGELOG.md").read_text()
    releases = re.findall(r"^## (\S+)", changelog, re.MULTILINE)
    assert releases[0] == "Unreleased" and tactile_gym.__version__ in releases
    versions = {i.rsplit("-", 1)[1] for i in (*tactile_gym.ENV_IDS, *tactile_gym.LEGACY_ENV_IDS)}
    for version in versions:
        assert f"**{version}**" in changelog, version
    for env_id in (*tactile_gym.JOINT_ENV_IDS, *tactile_gym.LEGACY_JOINT_ENV_IDS):
        assert env_id.split("/")[1] in changelog, env_id


def test_the_package_declares_its_types():
    assert (ROOT / "tactile_gym" / "py.typed").exists()
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'^"tactile_gym" = \["py.typed"\]$', pyproject, re.MULTILINE)
