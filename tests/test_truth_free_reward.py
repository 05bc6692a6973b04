"""The truth-free reward cannot be gamed by presses that leave the axis unidentified.

``benchmarks/truth_free_reward.py`` measures it on 200 episodes per policy (docs/design.md
6.9); this checks its claims on fewer. Each adversary of the benchmark presses without ever
turning the link, so its presses say nothing about the axis: its true return is zero or
below, and the truth-free return (the reduction of the estimator's own predicted error) must
not pay it either. Before the calibrated estimator counted presses at one link angle as one
line, the 3D adversaries earned +3.0 to +5.4 in truth-free return on the same episodes, so
the bound below separates the fix from the bug by a factor of 30 and more.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import truth_free_reward as bench  # noqa: E402

from agents.seeds import SELECTION_SEED  # noqa: E402

EPISODES = 10
#: An adversary's mean truth-free return, at most: a tenth of a millimetre of predicted error.
GAIN_BOUND = 0.1


@pytest.fixture(scope="module", params=bench.IDS)
def outcomes(request):
    seeds = list(range(SELECTION_SEED, SELECTION_SEED + EPISODES))
    policies = ("scripted", *bench.ADVERSARIES)
    return {policy: bench.play(request.param, policy, seeds) for policy in policies}


@pytest.mark.parametrize("adversary", bench.ADVERSARIES)
def test_an_adversary_gains_no_truth_free_return(outcomes, adversary):
    free = outcomes[adversary].free_gain
    assert np.all(np.isfinite(free))
    assert free.mean() <= GAIN_BOUND, (adversary, free)
    # The truth agrees that the adversary learned nothing about the axis.
    assert outcomes[adversary].true_gain.mean() <= GAIN_BOUND


def test_the_scripted_policy_earns_what_the_adversaries_do_not(outcomes):
    scripted = outcomes["scripted"]
    assert scripted.true_gain.mean() > 0.3
    assert scripted.free_gain.mean() > 0.3
    best_adversary = max(outcomes[a].free_gain.mean() for a in bench.ADVERSARIES)
    assert scripted.free_gain.mean() > best_adversary + 0.2
