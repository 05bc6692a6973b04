"""Sphinx configuration of the tactile_gym site (``make docs``; docs/design.md 13).

The stack Gymnasium's docs use: Sphinx with MyST Markdown and the furo theme; the API
reference from the Google-style docstrings (autodoc and napoleon). It builds offline: no
intersphinx, nothing fetched.
"""

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path[:0] = [str(ROOT), str(DOCS / "_ext")]  # the package, agents/, and the hooks

import tactile_gym  # noqa: E402

project = "tactile_gym"
author = "the tactile_gym authors"
copyright = f"2026, {author}"
release = tactile_gym.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "tactile_docs",
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "figures"]

html_theme = "furo"
html_title = f"tactile_gym {release}"
html_static_path: list[str] = []
html_show_sourcelink = False

# MyST: anchors for headings (links such as design.md#71-one-step), dollar maths off (prices
# and shell variables are not maths), and the directives the pages use.
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "deflist"]

# autodoc and napoleon: Google-style docstrings. The docstrings put units where Google style
# puts types ("force (N): ..."), so a field's parenthesis is shown as written, not made a
# cross-reference; "Attributes:" reads like "Args:" (a dataclass's fields are not described
# twice). The signatures carry the types.
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
# The API documents the package's own words; what Gymnasium says of reset and step is in its docs.
autodoc_inherit_docstrings = False
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_param = False
napoleon_use_rtype = False
napoleon_custom_sections = [("Attributes", "params_style")]
python_use_unqualified_type_names = True

# Every cross-reference is checked (-n in the Makefile) except those into the packages
# tactile_gym builds on and the standard library: their inventories would have to be fetched,
# and the build stays offline. Builtins (int, str, ...) need no inventory.
nitpicky = True
EXTERNAL = (
    "numpy np scipy gymnasium gym torch stable_baselines3 sb3 pybullet ray matplotlib plt yaml"
    " PIL numba tqdm rich argparse collections concurrent dataclasses enum io logging"
    " multiprocessing os pathlib subprocess types typing"
).split()
nitpick_ignore_regex = [(r"py:.*", rf"({'|'.join(EXTERNAL)})(\..*)?")]
