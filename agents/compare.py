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
from pathlib import Path

from .cli import make_parser, run_main
from .paired import PairedDifference, paired_difference

__all__ = ["REFERENCE", "PairedDifference", "paired_difference", "paired_table"]

#: The reference policy of the table.
REFERENCE = "scripted"


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
