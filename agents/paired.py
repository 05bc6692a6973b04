"""Bootstrap intervals (``docs/design.md``, Learning): of a mean, and of a paired difference.
The library behind ``agents.compare``'s and ``agents.aggregate``'s tables, for the commands
and the benchmarks alike: every interval of the project resamples here, so that one seed and
one count of resamples give the same figure wherever it is printed.

Two sets of values taken on the same seeded episodes are compared episode by episode, so
that each episode's own difficulty cancels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BOOTSTRAP_SAMPLES",
    "PairedDifference",
    "bootstrap_ci",
    "paired_difference",
    "resampled_means",
]

#: Bootstrap resamples: the interval's ends move by well under 1 % of its width between
#: generator seeds at this count.
BOOTSTRAP_SAMPLES = 10_000


def resampled_means(
    *values: np.ndarray, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0
) -> list[np.ndarray]:
    """The means of ``samples`` bootstrap resamples of each of ``values`` (equal-length 1-D
    arrays, one entry per episode), each resample drawing the same episodes from every array,
    so that a statistic of several arrays (a ratio of their means) keeps them paired.

    Returns:
        One ``(samples,)`` array per array of ``values``, in order.
    """
    n = len(values[0])
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, n, size=(samples, n))
    return [np.asarray(v, dtype=float)[draws].mean(axis=1) for v in values]


def bootstrap_ci(
    values, confidence: float = 0.95, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap confidence interval of the mean.

    Args:
        values: finite samples (one per episode, or per seed).
        confidence: coverage, in (0, 1).
        samples: bootstrap resamples.
        seed: seeds the resampling, so a table is reproducible.

    Returns:
        ``(low, high)``; ``(nan, nan)`` for fewer than two values, which give no interval.

    Raises:
        ValueError: a confidence outside (0, 1).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    values = np.asarray(values, dtype=float)
    if values.size < 2:
        return math.nan, math.nan
    (means,) = resampled_means(values, samples=samples, seed=seed)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(means, [alpha, 1.0 - alpha])
    return float(low), float(high)


@dataclass(frozen=True)
class PairedDifference:
    """Mean of per-episode differences (policy - reference) and its bootstrap interval.

    Attributes:
        mean: mean difference.
        low: lower end of the interval (NaN for one episode).
        high: upper end of the interval (NaN for one episode).
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
    interval at ``confidence`` (:func:`~agents.paired.bootstrap_ci`).

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
    diff = values - reference
    low, high = bootstrap_ci(diff, confidence, samples, seed)
    return PairedDifference(float(diff.mean()), low, high, len(diff), int(np.sum(diff < 0)))
