"""Paired comparison of policies against a reference, episode by episode
(``docs/design.md``, Learning).

Every policy that ``agents.evaluate`` runs plays the same seeded episodes, so the difference
(policy - reference) of final position errors can be taken per episode: the episode's own
difficulty (the prior's error, the object) cancels. :func:`paired_difference` gives its
mean with a percentile bootstrap confidence interval over episodes; ``agents.evaluate`` prints
:func:`paired_table` whenever ``scripted`` is among its policies, and

    python -m agents.compare results/evaluation/evaluation.json

prints it for a saved evaluation.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .cli import make_parser, run_main

__all__ = ["REFERENCE", "PairedDifference", "paired_difference", "paired_table"]

#: Bootstrap resamples: the interval's ends move by well under 1 % of its width between
#: generator seeds at this count.
BOOTSTRAP_SAMPLES = 10_000
#: The reference policy of the table.
REFERENCE = "scripted"


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


def final_position_errors(episodes: Sequence[Mapping]) -> dict[int, float]:
    """Final position error (m) by seed, from ``agents.evaluate``'s episode records."""
    return {int(e["seed"]): float(e["position_error"][-1]) for e in episodes}


def paired_table(detail: Mapping[str, Sequence[Mapping]], reference: str = REFERENCE) -> str:
    """A markdown table: for each policy other than ``reference``, the paired difference of
    final position errors (mm) with its 95 % interval, on the seeds both played.

    Args:
        detail: episode records by label (``evaluation.json``'s ``episodes_detail``).
        reference: the label compared against.

    Raises:
        ValueError: ``reference`` missing from ``detail``.
    """
    if reference not in detail:
        raise ValueError(f"reference {reference!r} is not among the policies {sorted(detail)}")
    base = final_position_errors(detail[reference])
    lines = [
        f"| policy | paired episodes | mean final error - {reference}'s (mm) | 95 % CI (mm) "
        f"| episodes better |",
        "|---|---|---|---|---|",
    ]
    for label, episodes in detail.items():
        if label == reference:
            continue
        errors = final_position_errors(episodes)
        seeds = sorted(set(errors) & set(base))
        d = paired_difference([errors[s] for s in seeds], [base[s] for s in seeds])
        lines.append(
            f"| {label} | {d.episodes} | {1e3 * d.mean:+.2f} | "
            f"[{1e3 * d.low:+.2f}, {1e3 * d.high:+.2f}] | {d.better} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> str:
    parser = make_parser(__spec__.name if __spec__ else "agents.compare", __doc__)
    parser.add_argument("evaluation", help="an evaluation.json written by agents.evaluate")
    parser.add_argument("--reference", default=REFERENCE, help="the policy compared against")
    args = parser.parse_args(argv)
    data = json.loads(Path(args.evaluation).read_text())
    table = paired_table(data["episodes_detail"], args.reference)
    print(table)
    return table


if __name__ == "__main__":
    sys.exit(run_main(main))
