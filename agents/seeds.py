"""The seed ranges of training, demonstrations, model selection and testing, in one place
(``docs/design.md``, Learning).

An episode of a tactile_gym id depends on its reset seed alone (``env.reset(seed=s)``), so
keeping the ranges apart keeps the test episodes unseen by every step that shaped a model:

* a training run with ``--seed s`` seeds its sub-env ``i`` with ``s + i`` once; its later
  episodes follow from that seed's generator;
* demonstrations (``agents.demos``) use ``DEMO_SEED + k``;
* the periodic evaluation that picks ``best_model`` plays the same episodes
  ``SELECTION_SEED + k`` every time (``agents.selection``);
* ``agents.evaluate`` reports on ``TEST_SEED + k`` unless told otherwise.

Each range holds ``RANGE_SIZE`` seeds; a run's ``config.yml`` records the ranges it used.
"""

from __future__ import annotations

__all__ = ["DEMO_SEED", "RANGE_SIZE", "SELECTION_SEED", "TEST_SEED", "TRAIN_SEED", "seed_ranges"]

#: Seeds per range: no count of episodes or training seeds used here comes near it.
RANGE_SIZE = 100_000
#: First seed of training runs (``agents.train --seed``).
TRAIN_SEED = 0
#: First seed of recorded demonstrations.
DEMO_SEED = 100_000
#: First seed of the fixed episodes that select ``best_model``.
SELECTION_SEED = 200_000
#: First seed of the test episodes that ``agents.evaluate`` reports by default.
TEST_SEED = 1_000_000


def seed_ranges() -> dict[str, list[int]]:
    """Each range as ``[first, last]`` (inclusive), for a run's config."""
    starts = {
        "training": TRAIN_SEED,
        "demonstrations": DEMO_SEED,
        "selection": SELECTION_SEED,
        "test": TEST_SEED,
    }
    return {name: [first, first + RANGE_SIZE - 1] for name, first in starts.items()}
