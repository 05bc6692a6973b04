"""The joint ids' scripted baseline against issue 28's targets: which joint, how sure, how well.

Run: ``python benchmarks/joint_type_scripted.py`` (``--help`` for the options). Each joint id
plays ``--episodes`` test episodes (seeds from ``agents.seeds.TEST_SEED``) with
``agents.joint_scripted.joint_policy``, and prints:

1. per id and family: episodes, final type accuracy (the true type strictly the most
   probable), the share with a wrong type above 0.9, the median final probability of the
   true type, success, terminations, the position and angle errors (median; P90 of the
   angle), and the primitives until the true type first reaches 0.95 (median, and the share
   of episodes that never do);
2. per id, the calibration of the revolute estimate's predicted stds on the hinges typed
   right (``mean(error^2) / mean(std^2)`` of the final position and angle, as
   ``benchmarks/calibration.py``'s scalar stds: 1 is honest), and the confusion matrix
   (rows the true type, columns the most probable outcome);
3. with ``--paired N``, the revolute families on the primitive ids against the HingeProbe
   ids' scripted baseline on the same N episodes (the same scenario draws: the v3 HingeProbe
   ids, whose physics and estimator the joint ids share, made with the joint ids' revolute
   families, layout and objects, both 400 control steps): the paired difference of the
   final position errors, its mean and percentile-bootstrap 95 % interval
   (``agents.paired``);
4. with ``--presses``, each id played with the v2 press and with the adaptive one
   (``docs/design.md`` 5.2) on the same episodes: both tables, and the paired differences of
   the final position error (revolute) and direction error (prismatic).

``--env-kwargs`` adds keywords of ``gym.make`` to every joint id.

On a 6-D id a primitive is one the skill executor ran (``SkillProber``'s choices).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(_ROOT))

from adaptive_press import V3_GATE, adaptive, press_kwargs  # noqa: E402

import tactile_gym  # noqa: E402
from agents.cli import KEY_VALUE_HELP, KeyValue  # noqa: E402
from agents.joint_scripted import joint_policy  # noqa: E402
from agents.paired import paired_difference  # noqa: E402
from agents.scripted import scripted_policy  # noqa: E402
from agents.seeds import TEST_SEED  # noqa: E402
from tactile_gym.envs.joint_config import JOINT_SCENARIO  # noqa: E402
from tactile_gym.estimation import JOINT_TYPES, OUTCOMES  # noqa: E402

CONFIDENT = 0.9
REACHED = 0.95


class _Counting:
    """Counts the primitives a joint policy chooses (a 6-D id's executor runs several control
    steps for each)."""

    def __init__(self, policy) -> None:
        self.policy = policy
        prober = policy.prober
        self.chooser = prober.chooser if hasattr(prober, "chooser") else prober
        self.count = 0
        act = self.chooser.act

        def counted(obs):
            self.count += 1
            return act(obs)

        self.chooser.act = counted

    def reset(self) -> None:
        self.policy.reset()
        self.count = 0

    def get_action(self, obs):
        return self.policy.get_action(obs)


def play(env_id: str, seeds, **kwargs) -> list[dict]:
    """The scripted baseline's episodes on a joint id: one record each."""
    env = gym.make(env_id, **kwargs)
    policy = _Counting(joint_policy(env))
    out = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        policy.reset()
        family = env.unwrapped.scene.object_config.family
        reached = None
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
            done = terminated or truncated
            p = info["type_probabilities"]
            if reached is None and p[info["joint_type"]] >= REACHED:
                reached = policy.count
        p = info["type_probabilities"]
        truth = int(info["joint_type"])
        # The revolute model's axis (the pipeline's ``estimate``) and its predicted stds.
        axis = getattr(env.unwrapped, "control_env", env.unwrapped).pipeline.estimate
        out.append(
            {
                "seed": seed,
                "family": family,
                "truth": truth,
                "best": int(np.argmax(p)),
                "correct": bool(info["type_correct"]),
                "p_true": float(p[truth]),
                "wrong_confident": bool(np.delete(p, truth).max() > CONFIDENT),
                "position": float(info["position_error"]),
                "angle": float(info["angle_error"]),
                "position_std": float(axis.position_std),
                "angle_std": float(axis.angle_std),
                "success": bool(info["is_success"]),
                "terminated": bool(terminated),
                "reached": reached,
                "primitives": policy.count,
            }
        )
    env.close()
    return out


def report(env_id: str, records: list[dict]) -> None:
    print(f"\n{env_id}: {len(records)} episodes")
    print(
        "| family | n | type accuracy | wrong > 0.9 | p(true) median | success | terminated"
        " | position error median (mm) | angle error median / P90 (deg)"
        " | primitives to 0.95: median / never |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    families = sorted({r["family"] for r in records}, key=lambda f: (records[0]["family"] != f, f))
    for family in [*families, "all"]:
        rs = [r for r in records if family in ("all", r["family"])]
        reached = [r["reached"] for r in rs if r["reached"] is not None]
        truth = JOINT_TYPES[rs[0]["truth"]] if family != "all" else ""
        position = np.median([r["position"] for r in rs]) * 1e3 if truth == "revolute" else 0.0
        angles = np.degrees([r["angle"] for r in rs])
        print(
            f"| {family} | {len(rs)} | {np.mean([r['correct'] for r in rs]):.1%}"
            f" | {np.mean([r['wrong_confident'] for r in rs]):.1%}"
            f" | {np.median([r['p_true'] for r in rs]):.3f}"
            f" | {np.mean([r['success'] for r in rs]):.1%}"
            f" | {np.mean([r['terminated'] for r in rs]):.1%}"
            f" | {position:.2f}"
            f" | {np.median(angles):.2f} / {np.percentile(angles, 90):.2f}"
            f" | {np.median(reached) if reached else float('nan'):.0f}"
            f" / {1 - len(reached) / len(rs):.1%} |"
        )
    hinges = [r for r in records if JOINT_TYPES[r["truth"]] == "revolute" and r["correct"]]
    if hinges:
        # As benchmarks/calibration.py's scalar stds: mean(error^2) / mean(std^2), 1 honest.
        ratios = []
        for k in ("position", "angle"):
            std2 = np.mean([r[f"{k}_std"] ** 2 for r in hinges])
            if std2 > 0.0:  # the planar fit's direction is assumed: no angle std
                ratios.append(f"{k} {np.mean([r[k] ** 2 for r in hinges]) / std2:.2f}")
        print(
            f"\nrevolute episodes typed right ({len(hinges)}): final error^2 over predicted"
            f" std^2, {', '.join(ratios)} (1 honest)"
        )
    confusion = np.zeros((len(JOINT_TYPES), len(OUTCOMES)), dtype=int)
    for r in records:
        confusion[r["truth"], r["best"]] += 1
    print("\nconfusion (rows: truth; columns: most probable):")
    print("| truth | " + " | ".join(OUTCOMES) + " |")
    print("|---|" + "---:|" * len(OUTCOMES))
    for i, name in enumerate(JOINT_TYPES):
        if confusion[i].sum():
            print(f"| {name} | " + " | ".join(str(c) for c in confusion[i]) + " |")


def paired(joint_id: str, hinge_id: str, episodes: int, steps: int) -> None:
    """The revolute families' final position errors, joint id against hinge id, paired."""
    spec = gym.spec(joint_id).kwargs
    estimator = spec["estimator"]
    revolute = tuple(f for f in spec["families"] if f in ("scissors", "door", "tilted"))
    full = gym.make(joint_id)
    prior = {"type_probabilities": full.unwrapped.pipeline.estimator.prior.type_probabilities}
    full.close()
    common = {"families": revolute, "max_steps": steps}
    seeds = range(TEST_SEED, TEST_SEED + episodes)
    joint = play(joint_id, seeds, **common, joint_prior=prior)
    scenario = dict(JOINT_SCENARIO[estimator])
    env = gym.make(hinge_id, scenario=scenario, object=spec.get("object", {}), **common)
    policy = scripted_policy(env)
    hinge = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        policy.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
            done = terminated or truncated
        hinge.append(float(info["position_error"]))
    env.close()
    ours = np.array([r["position"] for r in joint])
    theirs = np.array(hinge)
    d = paired_difference(ours, theirs)
    mean, low, high = d.mean, d.low, d.high
    print(
        f"\n{joint_id} against {hinge_id}, revolute families {revolute}, {episodes} paired"
        f" episodes of {steps} control steps: final position error mean {ours.mean() * 1e3:.2f}"
        f" / {theirs.mean() * 1e3:.2f} mm, median {np.median(ours) * 1e3:.2f} /"
        f" {np.median(theirs) * 1e3:.2f} mm; difference {mean * 1e3:+.2f} mm,"
        f" 95 % CI [{low * 1e3:+.2f}, {high * 1e3:+.2f}] mm; type accuracy"
        f" {np.mean([r['correct'] for r in joint]):.1%}"
    )


def presses(env_id: str, seeds, env_kwargs: dict) -> None:
    """The baseline with the v2 press and the adaptive press on the same episodes, paired."""
    # Each press over the id's keywords (whichever press it registers), as the v3 HingeProbe
    # ids register the adaptive one.
    chosen = adaptive(math.degrees(V3_GATE["edge_std_target"]), V3_GATE["dwell_budget"])
    runs = {}
    for name, press in (("v2 press", None), ("adaptive press", chosen)):
        kwargs = press_kwargs(env_id, press)
        gate = {**kwargs["gate"], **env_kwargs.get("gate", {})}
        runs[name] = play(env_id, seeds, **{**kwargs, **env_kwargs, "gate": gate})
    for name, records in runs.items():
        report(f"{env_id}, {name}", records)
    v2, new = runs.values()
    for truth, error, unit in (("revolute", "position", 1e3), ("prismatic", "angle", 57.2958)):
        index = [i for i, r in enumerate(v2) if JOINT_TYPES[r["truth"]] == truth]
        if len(index) < 2:
            continue
        ours = np.array([new[i][error] for i in index]) * unit
        theirs = np.array([v2[i][error] for i in index]) * unit
        d = paired_difference(ours, theirs)
        print(
            f"{env_id} {truth} final {error} error, adaptive against v2 press, {len(index)}"
            f" episodes: mean {ours.mean():.2f} / {theirs.mean():.2f}, difference"
            f" {d.mean:+.2f}, 95 % CI [{d.low:+.2f}, {d.high:+.2f}]"
            f" ({'mm' if truth == 'revolute' else 'deg'})"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=200, help="test episodes per id")
    parser.add_argument("--envs", nargs="+", default=list(tactile_gym.JOINT_ENV_IDS))
    parser.add_argument("--paired", type=int, default=0, help="paired episodes (0: none)")
    parser.add_argument(
        "--presses", action="store_true", help="the v2 press against the adaptive press"
    )
    parser.add_argument("--env-kwargs", nargs="+", action=KeyValue, default={}, help=KEY_VALUE_HELP)
    args = parser.parse_args(argv)
    seeds = range(TEST_SEED, TEST_SEED + args.episodes)
    for env_id in args.envs:
        start = time.perf_counter()
        if args.presses:
            presses(env_id, seeds, args.env_kwargs)
        else:
            report(env_id, play(env_id, seeds, **args.env_kwargs))
        print(f"({time.perf_counter() - start:.0f} s)", flush=True)
    if args.paired:
        primitive = [e for e in tactile_gym.JOINT_ENV_IDS if "Primitive" in e]
        hinge = [e for e in tactile_gym.ENV_IDS if "Primitive" in e]
        for joint_id, hinge_id in zip(primitive, hinge, strict=True):
            paired(joint_id, hinge_id, args.paired, 400)


if __name__ == "__main__":
    main()
