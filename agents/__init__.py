"""The command-line agents: training, evaluation, sweeps, the scripted baseline, Table I.

Each ``python -m agents.<name>`` command is a module with a ``main``; the modules without
one are the library the commands share (``docs/design.md``, Learning, has the map).
"""
