"""The command-line agents: training, evaluation, sweeps, the scripted baseline, Table I.

Importing the package imports :mod:`agents.cli` first, which imports pybullet without its
start-up line, so a command's output is its own whatever it imports next.
"""

from . import cli  # noqa: F401 - first, for its quiet pybullet import
