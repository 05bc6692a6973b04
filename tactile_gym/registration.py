"""How an id's registered keywords take those of ``gym.make``: merged section by section, so
that ``gym.make("tactile_gym/HingeProbe-v3", gate={"dwell_budget": 20})`` changes that one
gate field and keeps the other gate fields the id registers (``docs/design.md`` 9).

Gymnasium lays the keywords of ``gym.make(id, **kwargs)`` and ``gym.make_vec`` over a copy of
the spec's with ``dict.update``, one level deep, so a nested section (``gate``, ``skin``, ...)
would replace the registered one whole. ``tactile_gym`` registers each id's keywords as
:class:`RegisteredKeywords`, whose ``update`` merges nested sections key by key instead. The
entry points stay the env classes and functions they name: an entry point per id that merged
would have to be a callable, which Gymnasium cannot serialise (``EnvSpec.to_json``, which
Minari's datasets store), whereas these keywords are a plain mapping to it.

Python only: ``tactile_gym`` imports this module to register its ids, with or without
Gymnasium.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["RegisteredKeywords", "merge_keywords"]


def merge_keywords(base: Mapping[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``changes`` laid over it: a value that is a mapping in both (a nested
    section such as ``gate``) is merged key by key, at any depth; any other value replaces
    the base's. Neither argument is changed.

    To set a registered nested field back to its class default, pass that default: a merge
    cannot drop a key.
    """
    merged = dict(base)
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            value = merge_keywords(merged[key], value)
        merged[key] = value
    return merged


class RegisteredKeywords(dict):
    """An id's registered keywords (``gym.spec(id).kwargs``). ``gym.make`` and
    ``gym.make_vec`` lay their keywords over a copy of them with :meth:`update`, which merges
    nested sections (:func:`merge_keywords`) rather than replacing them."""

    def update(self, other: Any = (), /, **kwargs: Any) -> None:
        """Lay ``other`` and ``kwargs`` over these keywords, nested sections merged."""
        super().update(merge_keywords(self, dict(other, **kwargs)))
