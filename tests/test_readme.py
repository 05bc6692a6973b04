"""The README's Python blocks run as written, and CI runs the README's commands.

Each ```python block of README.md runs on its own, in a fresh interpreter started in the
repository root, as a reader would paste it after the README's set-up: a block must be
self-contained. A block that is not meant to run starts with a ``# not run: <why>`` line,
and only a few may. Files or folders a block creates in the root (a figure, say) are removed
afterwards. The README's two commands (the first shell block of its Set-up section: ``make
run`` and ``make test``) are lines of ``.ci/run``, and the steps it gives by hand install the
torch that the Makefile installs.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
CI = ROOT / ".ci" / "run"
OPT_OUT = "# not run:"
MAX_OPT_OUTS = 2
TIMEOUT = 120  # s, per block
FENCE = re.compile(r"^([ \t]*)```python[ \t]*\n(.*?)^\1```[ \t]*$", re.MULTILINE | re.DOTALL)
SHELL = re.compile(r"^```(?:bash|sh|shell)[ \t]*\n(.*?)^```", re.MULTILINE | re.DOTALL)


def python_blocks(text: str) -> list[tuple[int, str]]:
    """The (first line number, dedented code) of each ```python block of a Markdown text."""
    return [
        (text.count("\n", 0, m.start()) + 1, textwrap.dedent(m.group(2)))
        for m in FENCE.finditer(text)
    ]


def setup_blocks(text: str) -> list[list[str]]:
    """The command lines of each shell block in the README's "## Set-up" section, without
    their comments."""
    start = re.search(r"^## Set-up", text, re.MULTILINE)
    assert start, "README.md has no '## Set-up' section"
    end = re.compile(r"^## ", re.MULTILINE).search(text, start.end())
    section = text[start.end() : end.start() if end else len(text)]
    return [
        [command for command in map(_without_comment, block.splitlines()) if command]
        for block in SHELL.findall(section)
    ]


def _without_comment(line: str) -> str:
    return re.sub(r"(^|\s)#.*$", "", line).strip()


def opted_out(code: str) -> bool:
    return code.lstrip().startswith(OPT_OUT)


def run_block(code: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """Run one block in a fresh interpreter in ``cwd``; remove what it created there."""
    before = set(cwd.iterdir())
    env = {**os.environ, "MPLBACKEND": "Agg"}  # a block's plt.show() must not wait
    try:
        return subprocess.run(
            [sys.executable, "-c", code],
            cwd=cwd,
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
    finally:
        for path in set(cwd.iterdir()) - before:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()


BLOCKS = python_blocks(README.read_text())


def test_the_readme_has_python_blocks_and_few_opt_outs():
    assert BLOCKS, "README.md has no ```python blocks"
    skipped = [line for line, code in BLOCKS if opted_out(code)]
    assert len(skipped) <= MAX_OPT_OUTS, f"blocks at lines {skipped} do not run"
    for line, code in BLOCKS:
        if opted_out(code):
            reason = code.lstrip().splitlines()[0][len(OPT_OUT) :].strip()
            assert reason, f"the block at line {line} opts out without saying why"


@pytest.mark.parametrize("line, code", BLOCKS, ids=[f"line{line}" for line, _ in BLOCKS])
def test_readme_block_runs(line, code):
    if opted_out(code):
        pytest.skip(code.lstrip().splitlines()[0])
    result = run_block(code)
    assert result.returncode == 0, (
        f"README.md block at line {line} failed:\n{code}\n{result.stderr[-3000:]}"
    )


def test_ci_runs_the_readmes_two_commands():
    commands, *_ = setup_blocks(README.read_text())
    assert commands == ["make run", "make test"], commands
    ci = {_without_comment(line) for line in CI.read_text().splitlines()}
    assert [c for c in commands if c not in ci] == [], ".ci/run differs from the README"


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
    written = run_block("open('figure.png', 'w').write('x')", tmp_path)
    assert written.returncode == 0 and list(tmp_path.iterdir()) == []
    setup = "## Set-up\n\n```bash\npip install x   # why\n# a comment\n```\n\n"
    setup += "```bash\nmake\n```\n\n## Usage\n```bash\nls\n```\n"
    assert setup_blocks(setup) == [["pip install x"], ["make"]]
