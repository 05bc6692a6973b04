"""The README and the documentation pages say what is true, and CI runs the README's commands.

Each ```python block of README.md and of the hand-written pages in docs/ runs on its own, in a
fresh interpreter started in an empty temporary folder, as a reader would paste it after the
README's set-up: a block must be self-contained, and what it writes stays out of the
repository. A block that is not meant to run starts with a ``# not run: <why>`` line, and only
a few may. The README's two commands (the first shell block of its Set-up section: ``make
run`` and ``make test``) and the ``make docs`` that its Set-up section names are the ``make``
lines of ``.ci/run``, and the steps it gives by hand install the torch that the Makefile
installs. The README stays a short front door: at most 250 lines, its links lead to files
that exist (and to headings that exist in the pages), and its summary of results says what
the results page says.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
CI = ROOT / ".ci" / "run"
RESULTS = ROOT / "docs" / "results.md"
#: The hand-written pages; docs/envs/ and docs/api/ are written from the docstrings at build
#: time, where Sphinx checks their links.
PAGES = sorted((ROOT / "docs").glob("*.md"))
GENERATED = ("docs/envs/", "docs/api/")
OPT_OUT = "# not run:"
MAX_OPT_OUTS = 2
MAX_README_LINES = 250
TIMEOUT = 120  # s, per block
FENCE = re.compile(r"^([ \t]*)```python[ \t]*\n(.*?)^\1```[ \t]*$", re.MULTILINE | re.DOTALL)
SHELL = re.compile(r"^```(?:bash|sh|shell)[ \t]*\n(.*?)^```", re.MULTILINE | re.DOTALL)
LINK = re.compile(r"\[[^\]]*\]\((?P<target>[^)\s]+)\)")


def python_blocks(text: str) -> list[tuple[int, str]]:
    """The (first line number, dedented code) of each ```python block of a Markdown text."""
    return [
        (text.count("\n", 0, m.start()) + 1, textwrap.dedent(m.group(2)))
        for m in FENCE.finditer(text)
    ]


def section(text: str, title: str) -> str:
    """The text of a "## <title>" section, up to the next "## " heading."""
    start = re.search(rf"^## {re.escape(title)}\s*$", text, re.MULTILINE)
    assert start, f"no '## {title}' section"
    end = re.compile(r"^## ", re.MULTILINE).search(text, start.end())
    return text[start.end() : end.start() if end else len(text)]


def setup_blocks(text: str) -> list[list[str]]:
    """The command lines of each shell block in the README's "## Set-up" section, without
    their comments."""
    return [
        [command for command in map(_without_comment, block.splitlines()) if command]
        for block in SHELL.findall(section(text, "Set-up"))
    ]


def _without_comment(line: str) -> str:
    return re.sub(r"(^|\s)#.*$", "", line).strip()


def opted_out(code: str) -> bool:
    return code.lstrip().startswith(OPT_OUT)


def run_block(code: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run one block in a fresh interpreter in ``cwd``."""
    env = {**os.environ, "MPLBACKEND": "Agg"}  # a block's plt.show() must not wait
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )


def github_slug(title: str) -> str:
    """The anchor GitHub (and MyST, with ``myst_heading_anchors``) gives a heading: lower
    case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.MULTILINE | re.DOTALL)
    return {github_slug(t) for t in re.findall(r"^#{1,6} (.+)$", text, re.MULTILINE)}


def broken_links(page: Path) -> list[str]:
    """The relative links of a Markdown page whose file (or heading, in a Markdown page) does
    not exist; links into the generated pages are the site build's to check."""
    broken = []
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+:", target):  # https:, mailto:, project:
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        relative = file.relative_to(ROOT).as_posix() if file.is_relative_to(ROOT) else None
        if relative and relative.startswith(GENERATED):
            continue
        if not file.exists():
            broken.append(target)
        elif anchor and file.suffix == ".md" and anchor not in anchors(file):
            broken.append(target)
    return broken


BLOCKS = [
    (page, line, code)
    for page in (README, *PAGES)
    for line, code in python_blocks(page.read_text())
]


def test_the_pages_have_python_blocks_and_few_opt_outs():
    assert python_blocks(README.read_text()), "README.md has no ```python blocks"
    skipped = [f"{page.name}:{line}" for page, line, code in BLOCKS if opted_out(code)]
    assert len(skipped) <= MAX_OPT_OUTS, f"blocks at {skipped} do not run"
    for page, line, code in BLOCKS:
        if opted_out(code):
            reason = code.lstrip().splitlines()[0][len(OPT_OUT) :].strip()
            assert reason, f"the block at {page.name}:{line} opts out without saying why"


@pytest.mark.parametrize(
    "page, line, code", BLOCKS, ids=[f"{page.stem}:{line}" for page, line, _ in BLOCKS]
)
def test_python_block_runs(page, line, code, tmp_path):
    if opted_out(code):
        pytest.skip(code.lstrip().splitlines()[0])
    result = run_block(code, tmp_path)
    assert result.returncode == 0, (
        f"{page.name} block at line {line} failed:\n{code}\n{result.stderr[-3000:]}"
    )


def test_ci_runs_the_readmes_commands():
    text = README.read_text()
    commands, *_ = setup_blocks(text)
    assert commands == ["make run", "make test"], commands
    ci_lines = map(_without_comment, CI.read_text().splitlines())
    ci_make = [line for line in ci_lines if line.startswith("make")]
    assert sorted(ci_make) == sorted([*commands, "make docs"]), ci_make
    named = set(re.findall(r"`(make \w+)`", section(text, "Set-up")))
    assert "make docs" in named, "the README's Set-up does not say that CI builds the docs"


def test_the_manual_steps_do_what_the_makefile_does():
    """The steps by hand install the torch the Makefile does and run what its targets run."""
    _, manual, *_ = setup_blocks(README.read_text())
    makefile = (ROOT / "Makefile").read_text()
    torch = re.search(r"^TORCH := (\S+)", makefile, re.MULTILINE).group(1)
    index = re.search(r"^TORCH_CPU_INDEX := (\S+)", makefile, re.MULTILINE).group(1)
    assert f"pip install {torch} --index-url {index}" in manual
    assert re.search(r"^EXTRAS \?= (\S+)", makefile, re.MULTILINE).group(1) == "train,test,clients"
    assert 'pip install -e ".[train,test,clients]"' in manual
    for command in ("python -m agents.reproduce_paper", "ruff check . && ruff format --check ."):
        assert any(command in line for line in manual), command
        assert command in makefile, command


def test_the_readme_is_a_short_front_door():
    lines = README.read_text().count("\n")
    assert lines <= MAX_README_LINES, f"README.md has {lines} lines"


@pytest.mark.parametrize("page", [README, *PAGES], ids=lambda p: p.name)
def test_links_lead_somewhere(page):
    assert broken_links(page) == []


def sections_by_anchor(page: Path) -> dict[str, str]:
    """Each heading's anchor mapped to its section's text, up to the next heading of the same
    or a higher level."""
    text = page.read_text()
    headings = list(re.finditer(r"^(#{1,6}) (.+)$", text, re.MULTILINE))
    sections = {}
    for i, heading in enumerate(headings):
        level = len(heading.group(1))
        end = next((h.start() for h in headings[i + 1 :] if len(h.group(1)) <= level), len(text))
        sections[github_slug(heading.group(2))] = text[heading.end() : end]
    return sections


def statements(text: str) -> list[str]:
    """A section's table rows and paragraphs, each one statement."""
    rows = [line for line in text.splitlines() if line.startswith("|")]
    prose = re.sub(r"^\|.*$", "", text, flags=re.MULTILINE)
    return rows + [" ".join(p.split()) for p in re.split(r"\n\s*\n", prose) if p.strip()]


def test_the_readmes_results_are_the_results_pages():
    """The figures of each row of the README's summary table are stated together, in one table
    row or paragraph, in the results page's section that the row links to, which says how
    they were measured."""
    rows = [r for r in section(README.read_text(), "Results").splitlines() if r.startswith("|")]
    sections = sections_by_anchor(RESULTS)
    assert len(rows) >= 7, rows
    for row in rows[2:]:
        _, what, result, where, _ = row.split("|")
        (anchor,) = re.findall(r"docs/results\.md#([\w-]+)", where)
        assert anchor in sections, row
        numbers = re.findall(r"\d[\d,]*(?:\.\d+)?", result)
        patterns = [rf"(?<![\d.]){re.escape(n)}(?!\d)" for n in numbers]
        assert numbers and any(
            all(re.search(p, statement) for p in patterns)
            for statement in statements(sections[anchor])
        ), f"{result.strip()!r} ({what.strip()}) is not in docs/results.md#{anchor}"


def test_blocks_are_found_and_failures_seen(tmp_path):
    text = (
        "Intro\n\n```python\nprint('a')\n```\n\n```bash\nls\n```\n\n"
        "1. A list item:\n\n   ```python\n   import sys\n   sys.exit(3)\n   ```\n\n"
        "```python\n# not run: needs a robot\nrobot.go()\n```\n"
    )
    blocks = python_blocks(text)
    assert [line for line, _ in blocks] == [3, 13, 18]
    assert [opted_out(code) for _, code in blocks] == [False, False, True]
    assert run_block(blocks[0][1], tmp_path).stdout == "a\n"
    assert run_block(blocks[1][1], tmp_path).returncode == 3
    setup = "## Set-up\n\n```bash\npip install x   # why\n# a comment\n```\n\n"
    setup += "```bash\nmake\n```\n\n## Usage\n```bash\nls\n```\n"
    assert setup_blocks(setup) == [["pip install x"], ["make"]]


def test_broken_links_are_seen(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    (tmp_path / "other.md").write_text("# Other page\n\n## The paper's Table I\n")
    page = tmp_path / "page.md"
    page.write_text(
        "# Page\n\n[a](other.md) [b](other.md#the-papers-table-i) [c](#page)"
        " [d](missing.md) [e](other.md#no-such-heading) [f](https://example.org/x)"
        " [g](docs/envs/generated.md)\n"
    )
    assert broken_links(page) == ["missing.md", "other.md#no-such-heading"]
