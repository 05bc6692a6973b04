"""YAML presets of tactile_gym, installed as ``tactile_gym.configs``.

Load them by name with :mod:`tactile_gym.presets`; see ``docs/design.md``.
"""
