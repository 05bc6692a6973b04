"""A paired difference with its bootstrap interval (``docs/design.md``, Learning): the
library behind ``agents.compare``'s table, for the commands and the benchmarks alike.

Two sets of values taken on the same seeded episodes are compared episode by episode, so
that each episode's own difficulty cancels.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["BOOTSTRAP_SAMPLES", "PairedDifference", "paired_difference"]

#: Bootstrap resamples: the interval's ends move by well under 1 % of its width between
#: generator seeds at this count.
BOOTSTRAP_SAMPLES = 10_000


@dataclass(frozen=True)
class PairedDifference:
    """Mean of per-episode differences (policy - reference) and its bootstrap interval.

    Attributes:
        mean: mean difference.
        low: lower end of the interval.
        high: upper end of the interval.
        episodes: paired episodes.
        better: episodes in which the policy's value was below the reference's.
    """

    mean: float
    low: float
    high: float
    episodes: int
    better: int


def paired_difference(
    values: Sequence[float],
    reference: Sequence[float],
    confidence: float = 0.95,
    samples: int = BOOTSTRAP_SAMPLES,
    seed: int = 0,
) -> PairedDifference:
    """The mean of ``values - reference`` (paired by index) with a percentile bootstrap
    interval at ``confidence``.

    Raises:
        ValueError: sequences of different lengths or empty, non-finite values, or a
            confidence outside (0, 1).
    """
    values, reference = np.asarray(values, float), np.asarray(reference, float)
    if values.shape != reference.shape or values.ndim != 1 or len(values) == 0:
        raise ValueError(
            f"values and reference must be equal-length, non-empty sequences, got shapes "
            f"{values.shape} and {reference.shape}"
        )
    if not (np.all(np.isfinite(values)) and np.all(np.isfinite(reference))):
        raise ValueError("values and reference must be finite")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    diff = values - reference
    rng = np.random.default_rng(seed)
    means = diff[rng.integers(0, len(diff), size=(samples, len(diff)))].mean(axis=1)
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(means, [tail, 100.0 - tail])
    return PairedDifference(
        float(diff.mean()), float(low), float(high), len(diff), int(np.sum(diff < 0))
    )
