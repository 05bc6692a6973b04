"""The env's touch sensing: ``Touch`` and ``TouchSensor`` of ``tactile_gym.sensing.probing``.

They moved there so that the env, the Table I protocol and the regime map read a wrench one
way (``docs/design.md`` 5); this module keeps the env's import path until its users import
from ``tactile_gym.sensing``.
"""

from tactile_gym.sensing.probing import Touch, TouchSensor

__all__ = ["Touch", "TouchSensor"]
