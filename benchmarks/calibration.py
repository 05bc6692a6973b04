"""Calibration of the estimator's predicted uncertainty (docs/design.md 6.9).

Plays the scripted policy (``agents.scripted.scripted_policy``) on the v2 ids and compares the
estimate's predicted covariance with its true error: the normalised estimation error squared
(NEES) of the position (2 dof) and the direction (2 dof; 3D ids only) after 3, 5 and 8
accepted measurements and at the end, each as its mean over the episodes divided by its
degrees of freedom (1 is honest), and the scalar stds the env observes, as
``mean(error^2) / mean(std^2)`` (1 is honest). The position is taken at the true hinge pin,
where the task's error is measured (``axis_error``); ``position_std`` is the estimate's own.
It also gives Spearman's rho between each episode's final predicted error
``U = position_std + 0.05 m/rad * angle_std`` and its true ``E``.

Four commands:

* ``record``: play episodes with the env's own estimator and store each one's accepted
  measurements (point, edge, stds, edge covariance, in order), the prior, the estimator's
  loss and the true axis in ``CACHE/<id>.npz``, with the truth at every measurement (the
  true edge line, the joint angle) for the error analysis;
* ``errors``: each recorded measurement's error against the true edge line, in the probed
  face's frame, against its handed noise: the figures behind the calibrated error model
  (``tactile_gym.estimation.calibration``);
* ``replay``: feed the recorded measurements through ``JointAxisEstimator`` with each
  ``--covariance`` and print the table. Approximate: in the env the gate's same-edge test and
  the policy react to the estimate, which a replay cannot;
* ``play``: play real episodes with the estimator of ``--covariance`` swapped into the env's
  pipeline (as ``MeasurementPipeline`` builds it) and print the table: the figure to quote.

Default seeds: the selection range (``agents.seeds``) for development; ``--seeds test`` for the
final table. ``--axes vertical|tilted`` keeps a recording's episodes of vertical or tilted true
axes (``errors``, ``replay``). ``--step-angle`` sets the scripted policy's turn (deg);
``--policy`` plays (``record``, ``play``) one of the adversaries of ``truth_free_reward.py``
instead of the scripted policy, with their env keywords; ``--env-kwargs`` passes keywords to
``gym.make`` (a noise-free sensor: ``"sensor:
{force_noise_std: 0, moment_noise_std: 0, force_drift: 0, moment_drift: 0}"``).

    python benchmarks/calibration.py record --cache /tmp/calib
    python benchmarks/calibration.py errors --cache /tmp/calib
    python benchmarks/calibration.py replay --cache /tmp/calib
    python benchmarks/calibration.py play --seeds test
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout's agents/

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

from agents.cli import KEY_VALUE_HELP, KeyValue  # noqa: E402
from agents.paired import resampled_means  # noqa: E402
from agents.seeds import SELECTION_SEED, TEST_SEED  # noqa: E402
from tactile_gym.estimation import (  # noqa: E402
    COVARIANCES,
    AxisEstimate,
    AxisPrior,
    JointAxisEstimator,
    axis_error,
    axis_nees,
)
from tactile_gym.estimation.calibration import CALIBRATED, press_noise  # noqa: E402

#: The ids measured: both tasks, both action modes.
IDS = (
    "tactile_gym/HingeProbe-v2",
    "tactile_gym/HingeProbe3D-v2",
    "tactile_gym/HingeProbePrimitive-v2",
    "tactile_gym/HingeProbe3DPrimitive-v2",
)
#: Accepted measurements after which the estimate is scored (and at the episode's end).
CHECKPOINTS = (3, 5, 8)
#: The weight of the angle in the task's error E and in U, m/rad (docs/design.md 7.4).
ANGLE_WEIGHT = 0.05
SEEDS = {"selection": SELECTION_SEED, "test": TEST_SEED}
#: Resamples of the episodes behind each figure's standard error.
BOOTSTRAP = 1000
#: What a recording holds per accepted measurement: the measurement as the pipeline hands it
#: to the estimator, then the truth at that control step (for the error analysis only).
MEASUREMENT_KEYS = (
    "point",
    "edge",
    "point_std",
    "edge_std",
    "edge_cov",
    "true_edge_point",
    "true_edge_direction",
    "joint_angle",
)
MEASUREMENT_SHAPES = ((3,), (3,), (), (), (3, 3), (3,), (3,), ())


@dataclass
class Score:
    """The scores of one estimate against the truth: NEES of the position at the pin and of
    the direction, the errors and the predicted stds (m, rad)."""

    nees_position: float
    nees_direction: float
    position_error: float
    angle_error: float
    position_std: float
    angle_std: float


def score(estimate: AxisEstimate, pin: np.ndarray, direction: np.ndarray) -> Score:
    """Score ``estimate`` against the true axis through ``pin`` along ``direction``."""
    _, nees_position, nees_direction = axis_nees(estimate, pin, direction, reference_point=pin)
    position, angle = axis_error(estimate, pin, direction, pin)
    return Score(
        nees_position, nees_direction, position, angle, estimate.position_std, estimate.angle_std
    )


@dataclass
class Episode:
    """One episode's scores: at each checkpoint it reached and at the end."""

    at: dict[int, Score] = field(default_factory=dict)
    final: Score | None = None


def replay(record: dict, covariance: str) -> list[Episode]:
    """Feed a recording's measurements, episode by episode, through an estimator of the
    recording's mode, loss and prior with ``covariance``."""
    prior = AxisPrior(
        record["prior_pin"],
        record["prior_pin_cov"],
        record["prior_direction"],
        float(record["prior_angle_std"]),
    )
    estimator = JointAxisEstimator(
        mode=str(record["mode"]), loss=str(record["loss"]), prior=prior, covariance=covariance
    )
    episodes = []
    bounds = np.concatenate([[0], np.cumsum(record["n_measurements"])])
    for k in range(len(record["seed"])):
        estimator.reset()
        pin, direction = record["axis_point"][k], record["axis_direction"][k]
        episode = Episode()
        for i in range(bounds[k], bounds[k + 1]):
            estimator.add(
                record["point"][i],
                record["edge"][i],
                float(record["point_std"][i]),
                float(record["edge_std"][i]),
                edge_cov=record["edge_cov"][i],
            )
            # Refit after every measurement, as the env does: the fits warm-start from the last.
            estimate = estimator.estimate()
            n = i - bounds[k] + 1
            if n in CHECKPOINTS:
                episode.at[n] = score(estimate, pin, direction)
        episode.final = score(estimator.estimate(), pin, direction)
        episodes.append(episode)
    return episodes


#: Per-episode arrays of a recording (the rest are per measurement, or the prior's).
EPISODE_KEYS = ("seed", "n_measurements", "axis_point", "axis_direction")
#: Consecutive presses whose joint angles differ by less than this are at one link angle, rad.
SAME_ANGLE = math.radians(0.3)
#: An axis within this of vertical counts as vertical for ``--axes``, rad.
VERTICAL_TOL = math.radians(0.5)


def select_episodes(record: dict, axes: str) -> dict:
    """The recording's episodes whose true axis is ``"vertical"`` or ``"tilted"``
    (``"all"``: all of them)."""
    if axes == "all":
        return record
    tilt = np.arccos(np.minimum(np.abs(record["axis_direction"][:, 2]), 1.0))
    keep = (tilt < VERTICAL_TOL) == (axes == "vertical")
    rows = np.repeat(keep, record["n_measurements"])
    out = dict(record)
    for key in EPISODE_KEYS:
        out[key] = record[key][keep]
    for key in MEASUREMENT_KEYS:
        out[key] = record[key][rows]
    return out


def mode_of(env_id: str) -> str:
    """The estimator mode of an id."""
    return "3d" if "3D" in env_id else "planar"


class _Recorder:
    """Wraps an env's measurement pipeline: logs every accepted measurement with the truth
    at that control step, and scores the estimate at the checkpoints. The truth is read
    here, for scoring only; the pipeline never sees it."""

    def __init__(self, env) -> None:
        self.base = env.unwrapped
        self.pipeline = self.base.pipeline
        self._step = self.pipeline.step
        self.pipeline.step = self.step
        self.log: dict[str, list] = {key: [] for key in MEASUREMENT_KEYS}
        self.episode = Episode()

    def begin(self) -> None:
        self.episode = Episode()

    def step(self, sample):
        perceived = self._step(sample)
        if perceived.accepted:
            scene = self.base.scene
            pin, direction = scene.true_axis
            edge_point, edge_direction = scene.edge_line
            for m in perceived.accepted:
                row = (m.point, m.edge, m.point_std, m.edge_std, m.edge_cov)
                row += (edge_point, edge_direction, scene.joint_angle)
                for key, value in zip(MEASUREMENT_KEYS, row, strict=True):
                    self.log[key].append(value)
            n = len(self.pipeline.measurements)
            if n in CHECKPOINTS:
                self.episode.at[n] = score(self.pipeline.estimate, pin, direction)
        return perceived


def play(
    env_id: str,
    seeds: range,
    covariance: str | None,
    env_kwargs: dict | None = None,
    step_angle: float | None = None,
    policy: str = "scripted",
) -> tuple[list[Episode], dict]:
    """Play the scripted policy, or an adversary, on ``seeds`` of ``env_id``.

    Args:
        env_id: a primitive or 6-D id (adversaries: a primitive id).
        seeds: the reset seeds, one episode each.
        covariance: the estimator's ``covariance`` swapped into the env's pipeline, or None
            for the env's own estimator.
        env_kwargs: keywords of ``gym.make``.
        step_angle: the scripted policy's turn between measurements, rad (None: its
            default).
        policy: ``"scripted"`` or one of the adversaries of ``truth_free_reward.py``
            (``ADVERSARIES``), played with its env keywords (the workspace centred at the
            start).

    Returns:
        The episodes' scores and the recording (arrays, as ``record`` stores them).
    """
    import gymnasium as gym
    from truth_free_reward import ADVERSARIES, TRUTH_FREE, Adversary

    import tactile_gym  # noqa: F401 - registers the envs
    from agents.scripted import ProberConfig, scripted_policy

    kwargs = dict(env_kwargs or {})
    if policy in ADVERSARIES:
        kwargs = {**TRUTH_FREE, **kwargs}
    env = gym.make(env_id, **kwargs)
    pipeline = env.unwrapped.pipeline
    if covariance is not None:
        own = pipeline.estimator
        pipeline.estimator = JointAxisEstimator(
            mode=own.mode, loss=own.loss, prior=own.prior, covariance=covariance
        )
    recorder = _Recorder(env)
    if policy == "scripted":
        config = ProberConfig() if step_angle is None else ProberConfig(step_angle=step_angle)
        agent = scripted_policy(env, config)
    else:
        agent = Adversary(env, policy)
    episodes, counts, truth = [], [], []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        agent.reset()
        recorder.begin()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(agent.get_action(obs))
            done = terminated or truncated
        pin, direction = info["true_axis_point"], info["true_axis_direction"]
        recorder.episode.final = score(pipeline.estimate, pin, direction)
        episodes.append(recorder.episode)
        counts.append(len(pipeline.measurements))
        truth.append((pin, direction))
    estimator = pipeline.estimator
    env.close()
    record = {
        key: np.array(values, dtype=float).reshape((-1, *shape))
        for (key, values), shape in zip(recorder.log.items(), MEASUREMENT_SHAPES, strict=True)
    }
    record.update(
        mode=estimator.mode,
        loss=estimator.loss,
        seed=np.array(list(seeds)),
        n_measurements=np.array(counts),
        axis_point=np.array([t[0] for t in truth]),
        axis_direction=np.array([t[1] for t in truth]),
        prior_pin=estimator.prior.pin,
        prior_pin_cov=estimator.prior.pin_cov,
        prior_direction=estimator.prior.direction,
        prior_angle_std=estimator.prior.angle_std,
    )
    return episodes, record


def measurement_errors(record: dict) -> dict[str, np.ndarray]:
    """Each recorded measurement's error against the true edge line at its control step.

    The frame is the probed face's: its normal is the true axis (the links turn in the plane
    of the face they are probed on), ``across`` the in-face normal of the edge pointing away
    from the pin. Returns (M,) arrays: the contact point's offset across the edge and along
    the face normal (m), the edge's error turning it within the face and out of it (rad),
    their handed variances (rad^2), the episode of each measurement and the frame's
    ``across`` and ``normal`` directions ((M, 3)).
    """
    episode = np.repeat(np.arange(len(record["seed"])), record["n_measurements"])
    normal = record["axis_direction"][episode]
    pin = record["axis_point"][episode]
    true_edge = record["true_edge_direction"]
    line_point = record["true_edge_point"]
    edge = record["edge"] * np.sign(np.einsum("ij,ij->i", record["edge"], true_edge))[:, None]
    across = np.cross(normal, true_edge)
    across /= np.linalg.norm(across, axis=1)[:, None]
    across *= np.sign(np.einsum("ij,ij->i", line_point - pin, across))[:, None]
    offset = record["point"] - line_point
    turn = edge - true_edge
    cov = record["edge_cov"]
    return {
        "episode": episode,
        "across": across,
        "normal": normal,
        "point_across": np.einsum("ij,ij->i", offset, across),
        "point_normal": np.einsum("ij,ij->i", offset, normal),
        "edge_in": np.einsum("ij,ij->i", turn, across),
        "edge_out": np.einsum("ij,ij->i", turn, normal),
        "var_in": np.einsum("ij,ijk,ik->i", across, cov, across),
        "var_out": np.einsum("ij,ijk,ik->i", normal, cov, normal),
    }


def _within(values: np.ndarray, episode: np.ndarray) -> float:
    """RMS deviation of the values from their episode's mean (episodes of two or more)."""
    deviations = []
    for k in np.unique(episode):
        v = values[episode == k]
        if v.size > 1:
            deviations.append((v - v.mean()) * np.sqrt(v.size / (v.size - 1)))
    return float(np.sqrt(np.mean(np.square(np.concatenate(deviations)))))


def print_errors(env_id: str, record: dict) -> None:
    """The measurements' errors behind the calibrated model (docs/design.md 6.9)."""
    m = measurement_errors(record)
    episode = m["episode"]
    mm, deg = 1e3, math.degrees(1.0)
    print(f"{env_id}: {episode.size} measurements of {len(record['seed'])} episodes")
    for key, label in (("point_across", "across the edge"), ("point_normal", "normal to face")):
        v = m[key]
        print(
            f"  contact point {label}: mean {v.mean() * mm:.2f} mm, scatter within an "
            f"episode {_within(v, episode) * mm:.3f} mm"
        )
    # The calibrated model's own edge covariance of each press, less the excess, which is
    # fitted below: the handed covariance plus the noise-free press's error.
    without = dataclasses.replace(CALIBRATED, edge_excess_std=0.0)
    own = np.array(
        [
            press_noise(e / np.linalg.norm(e), 3, s, c, p, without)[0]
            for e, s, c, p in zip(
                record["edge"],
                record["edge_std"],
                record["edge_cov"],
                record["point_std"],
                strict=True,
            )
        ]
    )
    excess = CALIBRATED.edge_excess_std**2
    for key, var, axis, label in (
        ("edge_in", "var_in", "across", "in the face"),
        ("edge_out", "var_out", "normal", "out of it"),
    ):
        v, handed = m[key], m[var]
        model = np.einsum("ij,ijk,ik->i", m[axis], own, m[axis])
        rms = np.sqrt(np.mean(v**2)) * deg
        print(
            f"  edge turn {label}: mean {v.mean() * deg:.3f} deg, RMS {rms:.3f} deg, scatter"
            f" within an episode {_within(v, episode) * deg:.3f} deg; predicted RMS handed"
            f" {np.sqrt(handed.mean()) * deg:.3f} deg, calibrated"
            f" {np.sqrt((model + excess).mean()) * deg:.3f} deg; z^2 handed"
            f" {np.mean(v**2 / handed):.2f}, calibrated {np.mean(v**2 / (model + excess)):.2f}"
        )
    # The excess that makes the out-of-face z^2 one (mean over the measurements).
    square = m["edge_out"] ** 2
    fitted = brentq(lambda s: np.mean(square / (model + s * s)) - 1.0, 0.0, 0.1)
    print(f"  edge excess for out-of-face z^2 = 1: {math.degrees(fitted):.3f} deg")
    cross = np.einsum("ij,ijk,ik->i", m["across"], record["edge_cov"], m["normal"])
    handed = np.mean(cross / np.sqrt(m["var_in"] * m["var_out"]))
    measured = np.corrcoef(m["edge_in"], m["edge_out"])[0, 1]
    print(f"  edge turn in / out correlation: handed {handed:.2f}, measured {measured:.2f}")
    # Consecutive presses at one link angle: the same spot pressed again.
    again = (episode[1:] == episode[:-1]) & (np.abs(np.diff(record["joint_angle"])) < SAME_ANGLE)
    if again.sum() > 2:
        pairs = ", ".join(
            f"{label} {np.corrcoef(m[key][:-1][again], m[key][1:][again])[0, 1]:.2f}"
            for key, label in (
                ("point_across", "point across"),
                ("edge_in", "edge in"),
                ("edge_out", "edge out"),
            )
        )
        print(f"  {again.sum()} presses again at one link angle, errors correlated: {pairs}")


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> str:
    """``mean(numerator) / mean(denominator)`` and its bootstrap standard error over the
    episodes, as ``value +- error``."""
    top, bottom = resampled_means(numerator, denominator, samples=BOOTSTRAP)
    spread = np.std(top / bottom)
    return f"{numerator.mean() / denominator.mean():.2f} +- {spread:.2f}"


def table_rows(env_id: str, covariance: str, episodes: list[Episode]) -> list[str]:
    """The markdown rows of one id and covariance: one per checkpoint and the end."""
    rows = []
    for at in (*CHECKPOINTS, None):
        scores = [e.final if at is None else e.at.get(at) for e in episodes]
        scores = [s for s in scores if s is not None]
        if not scores:
            continue
        columns = {
            name: np.array([getattr(s, name) for s in scores]) for name in Score.__annotations__
        }
        dof = np.full(len(scores), 2.0)
        cells = [_ratio(columns["nees_position"], dof), "-"]
        cells += [_ratio(columns["position_error"] ** 2, columns["position_std"] ** 2), "-"]
        if mode_of(env_id) == "3d":
            cells[1] = _ratio(columns["nees_direction"], dof)
            cells[3] = _ratio(columns["angle_error"] ** 2, columns["angle_std"] ** 2)
        rows.append(
            f"| {env_id.split('/')[-1]} | {covariance} | {'end' if at is None else at} | "
            f"{len(scores)} | {' | '.join(cells)} |"
        )
    return rows


def ranking_row(env_id: str, covariance: str, episodes: list[Episode]) -> str:
    """Spearman's rho between the final predicted error U and the true E, with their means."""
    u = [e.final.position_std + ANGLE_WEIGHT * e.final.angle_std for e in episodes]
    e = [e.final.position_error + ANGLE_WEIGHT * e.final.angle_error for e in episodes]
    rho = spearmanr(u, e).statistic
    return (
        f"| {env_id.split('/')[-1]} | {covariance} | {rho:.2f} | {1e3 * np.mean(u):.2f} | "
        f"{1e3 * np.mean(e):.2f} |"
    )


def print_tables(results: list[tuple[str, str, list[Episode]]]) -> None:
    """The NEES table and the ranking table of (id, covariance, episodes) results."""
    print(
        "| id | covariance | measurements | episodes | position NEES / 2 | direction NEES / 2 "
        "| position err^2 / std^2 | angle err^2 / std^2 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for env_id, covariance, episodes in results:
        print("\n".join(table_rows(env_id, covariance, episodes)))
    print("\n| id | covariance | Spearman rho(U, E) | mean U (mm) | mean E (mm) |")
    print("|---|---|---|---|---|")
    for env_id, covariance, episodes in results:
        print(ranking_row(env_id, covariance, episodes))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=("record", "errors", "replay", "play"))
    parser.add_argument("--ids", nargs="+", default=list(IDS))
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seeds", choices=tuple(SEEDS), default="selection")
    parser.add_argument("--cache", type=Path, help="directory of the recordings")
    parser.add_argument("--covariance", nargs="+", default=list(COVARIANCES), choices=COVARIANCES)
    parser.add_argument(
        "--step-angle", type=float, help="the scripted policy's turn, deg (default: its own)"
    )
    parser.add_argument("--env-kwargs", nargs="+", action=KeyValue, default={}, help=KEY_VALUE_HELP)
    parser.add_argument(
        "--policy",
        default="scripted",
        help="record and play: the scripted policy or an adversary of truth_free_reward.py "
        "('same spot', 'one edge', 'no turn'; their env keywords; default: scripted)",
    )
    parser.add_argument(
        "--axes",
        choices=("all", "vertical", "tilted"),
        default="all",
        help="errors and replay: only the episodes whose true axis is so (default: all)",
    )
    args = parser.parse_args(argv)
    from truth_free_reward import ADVERSARIES

    if args.policy not in ("scripted", *ADVERSARIES):
        parser.error(f"--policy must be scripted or one of {ADVERSARIES}, got {args.policy!r}")
    if args.command != "play" and args.cache is None:
        parser.error(f"{args.command} needs --cache DIR")
    seeds = range(SEEDS[args.seeds], SEEDS[args.seeds] + args.episodes)
    step = None if args.step_angle is None else math.radians(args.step_angle)
    if args.command in ("record", "play"):
        print(
            f"{args.command}: {args.policy}, {args.episodes} episodes per id, {args.seeds} "
            f"seeds {seeds.start}..{seeds.stop - 1}\n"
        )
    results = []
    for env_id in args.ids:
        name = env_id.split("/")[-1]
        if args.policy != "scripted":
            name += "_" + args.policy.replace(" ", "_")
        path = None if args.cache is None else args.cache / f"{name}.npz"
        if args.command == "record":
            args.cache.mkdir(parents=True, exist_ok=True)
            _, record = play(env_id, seeds, None, args.env_kwargs, step, args.policy)
            np.savez(path, **record)
            print(f"{env_id}: {len(seeds)} episodes, {record['point'].shape[0]} measurements")
            continue
        if args.command in ("errors", "replay"):
            if not path.exists():
                parser.error(f"no recording of {env_id} in {args.cache}: run record first")
            with np.load(path) as stored:
                record = dict(stored)
            record = select_episodes(record, args.axes)
            first, last = record["seed"][0], record["seed"][-1]
            print(f"{args.command} {path}: {len(record['seed'])} episodes, seeds {first}..{last}")
        if args.command == "errors":
            print_errors(env_id, record)
            continue
        for covariance in args.covariance:
            if args.command == "replay":
                episodes = replay(record, covariance)
            else:
                episodes = play(env_id, seeds, covariance, args.env_kwargs, step, args.policy)[0]
            results.append((env_id, covariance, episodes))
    if results:
        print_tables(results)


if __name__ == "__main__":
    main()
