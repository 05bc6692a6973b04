"""The perception layer on its own: a robot's stream of readings and poses in, the axis out.

* It imports and runs with pybullet and Gymnasium blocked.
* The simulator writes robot logs, and replaying one reproduces the env's own online estimate
  and its accepted measurements (a planar and a 3D id, NPZ and CSV).
* A bad log ends in one clear line with exit status 2: missing columns, time that goes
  backwards, NaN, a wrench in N mm, positions in mm, time in ms, no press.
* Faults within a stream (a dropped sample, a repeated time, a pose jump) refuse the press they
  break, with the fault's name; a tare taken while touching is flagged.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

from agents.scripted import scripted_policy
from tactile_gym.envs.recording import RecordProbeLog
from tactile_gym.perception import STREAM_FAULTS, MeasurementPipeline, Sample
from tactile_gym.perception.log import LogError, ProbeLog, load_log, replay, truth_path
from tactile_gym.replay import main as replay_main

IDS = ("tactile_gym/HingeProbe-v2", "tactile_gym/HingeProbe3DPrimitive-v2")


def _record(env_id: str, directory, suffix: str = ".npz", seed: int = 3):
    """One scripted episode recorded as a log; the env's pipeline at its end."""
    env = RecordProbeLog(gym.make(env_id), directory, suffix=suffix)
    policy = scripted_policy(env)
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy.get_action(obs))
        done = terminated or truncated
    base = env.unwrapped
    pipeline = getattr(base, "control_env", base).pipeline
    env.close()
    return env.paths[0], pipeline


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Each id's episode, recorded: (log path, the env's pipeline at the end)."""
    directory = tmp_path_factory.mktemp("logs")
    return {env_id: _record(env_id, directory / env_id.split("/")[1]) for env_id in IDS}


@pytest.mark.parametrize("env_id", IDS)
def test_replay_reproduces_the_envs_online_estimate(recorded, env_id):
    path, online = recorded[env_id]
    log = load_log(path)
    assert len(log) == 401  # the reset's reading and 400 control steps
    assert log.tare.sum() >= 6 and not log.lift.any()
    replayed = replay(log)
    assert len(online.measurements) >= 5
    assert len(replayed.measurements) == len(online.measurements)
    for got, want in zip(replayed.measurements, online.measurements):
        np.testing.assert_allclose(got.point, want.point, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.edge, want.edge, rtol=0, atol=1e-9)
    for name in ("point", "direction"):
        got, want = getattr(replayed.estimate, name), getattr(online.estimate, name)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert replayed.estimate.position_std == pytest.approx(online.estimate.position_std, abs=1e-9)
    assert [p.rule for p in replayed.presses] == [p.rule for p in online.presses]
    # The truth went into the sidecar only; the log holds what a robot has.
    truth = json.loads(truth_path(path).read_text())
    assert set(truth) >= {"axis_point", "axis_direction", "joint_type", "family"}


def test_a_csv_log_replays_like_the_npz(recorded, tmp_path):
    path, online = recorded[IDS[0]]
    log = load_log(path)
    csv = log.save(tmp_path / "same.csv")
    again = load_log(csv)
    np.testing.assert_array_equal(again.table(), log.table())
    assert again.header == log.header
    estimate = replay(again).estimate
    np.testing.assert_allclose(estimate.point, online.estimate.point, rtol=0, atol=1e-9)


def test_perception_runs_without_pybullet_or_gymnasium(recorded):
    """A robot's install: the perception layer and the replay with both blocked."""
    path, online = recorded[IDS[1]]
    script = textwrap.dedent(
        f"""
        import sys
        sys.modules["pybullet"] = None  # any import of it now fails
        sys.modules["gymnasium"] = None
        from tactile_gym.perception.log import load_log, replay
        from tactile_gym.replay import main
        pipeline = replay(load_log({str(path)!r}))
        print(len(pipeline.measurements), *pipeline.estimate.point.tolist())
        assert main([{str(path)!r}]) == 0
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    ).stdout
    first = out.splitlines()[0].split()
    assert int(first[0]) == len(online.measurements)
    np.testing.assert_allclose([float(v) for v in first[1:]], online.estimate.point, atol=1e-9)
    assert "presses:" in out and "95 % within" in out


def test_the_replay_command_reports_presses_refusals_tares_and_bounds(recorded, capsys, tmp_path):
    path, online = recorded[IDS[1]]
    plot = tmp_path / "top.png"
    assert replay_main([str(path), "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    accepted = len(online.measurements)
    assert f"{len(online.presses)} found, {accepted} accepted" in out
    for rule in {p.rule for p in online.presses if not p.accepted}:
        assert f"refused by {rule}:" in out
    assert "direction: 1-sigma" in out and "truth (" in out
    assert plot.stat().st_size > 10_000
    assert replay_main([str(path), "--mode", "planar"]) == 0
    assert "axis (planar" in capsys.readouterr().out


# --------------------------------------------------------------------------- bad logs


def _bad(log: ProbeLog, **changes) -> ProbeLog:
    return dataclasses.replace(log, **changes)


def _csv_without_column(log: ProbeLog, path, column: str):
    path = log.save(path)
    lines = path.read_text().splitlines()
    names = lines[1].split(",")
    k = names.index(column)
    rows = [",".join(v for i, v in enumerate(line.split(",")) if i != k) for line in lines[1:]]
    path.write_text("\n".join([lines[0], *rows]) + "\n")
    return path


def _bad_logs(log: ProbeLog):
    """Each bad log, as a function of a temporary directory, and what its line must say."""
    time = log.time.copy()
    time[50] = time[48]  # goes back
    wrench = log.wrench.copy()
    wrench[70, 4] = np.nan
    mm = log.wrench.copy()
    mm[:, 3:] *= 1e3
    far = log.position * 1e3
    return {
        "missing column": (lambda d: _csv_without_column(log, d / "a.csv", "qw"), "missing column"),
        "time backwards": (lambda d: _bad(log, time=time).save(d / "b.npz"), "time goes backwards"),
        "nan": (lambda d: _bad(log, wrench=wrench).save(d / "c.npz"), "column my is nan"),
        "newton millimetres": (lambda d: _bad(log, wrench=mm).save(d / "d.npz"), "in N mm?"),
        "millimetres": (lambda d: _bad(log, position=far).save(d / "e.npz"), "in millimetres?"),
        "milliseconds": (
            lambda d: _bad(log, time=log.time * 1e3).save(d / "f.npz"),
            "in milliseconds?",
        ),
        "no press": (
            lambda d: _bad(log, wrench=np.tile(log.wrench[:1], (len(log), 1))).save(d / "g.npz"),
            "no press in the log",
        ),
        "not a log": (lambda d: (d / "h.npz").write_bytes(b"not a zip") and d / "h.npz", "NPZ"),
    }


@pytest.mark.parametrize(
    "case",
    [
        "missing column",
        "time backwards",
        "nan",
        "newton millimetres",
        "millimetres",
        "milliseconds",
        "no press",
        "not a log",
    ],
)
def test_a_bad_log_ends_in_one_clear_line(recorded, tmp_path, capsys, case):
    log = load_log(recorded[IDS[0]][0])
    write, says = _bad_logs(log)[case]
    path = write(tmp_path)
    assert replay_main([str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile_gym.replay: error:"), lines
    assert says in lines[0], lines[0]
    with pytest.raises(LogError):
        replay_main([str(path), "--debug"])


# --------------------------------------------------------------------------- faults


def _accepted_press(log: ProbeLog) -> tuple[float, int]:
    """The time of the first accepted press of a log, and its row."""
    press = next(p for p in replay(log).presses if p.accepted)
    return press.time, int(np.flatnonzero(log.time == press.time)[0])


@pytest.mark.parametrize("fault", ["dropped_sample", "repeated_time", "pose_jump"])
def test_a_fault_refuses_the_press_it_breaks_with_its_name(recorded, fault):
    log = load_log(recorded[IDS[0]][0])
    time, row = _accepted_press(log)
    k = row - 2  # inside the press's still window (dwell readings)
    if fault == "dropped_sample":
        keep = np.ones(len(log), bool)
        keep[k] = False
        broken = _bad(
            log, **{n: getattr(log, n)[keep] for n in ("time", "wrench", "position")},
            quaternion=log.quaternion[keep], tare=log.tare[keep], lift=log.lift[keep],
        )  # fmt: skip
    elif fault == "repeated_time":
        t = log.time.copy()
        t[k] = t[k - 1]
        broken = _bad(log, time=t)
    else:
        position = log.position.copy()
        position[k] += [0.05, 0.0, 0.0]  # 50 mm in one 50 ms period
        broken = _bad(log, position=position)
    pipeline = replay(broken)
    refused = [p for p in pipeline.presses if p.rule == fault]
    assert len(refused) == 1 and fault in STREAM_FAULTS and refused[0].reason
    assert not any(p.accepted and abs(p.time - time) < 0.3 for p in pipeline.presses)
    assert np.isfinite(pipeline.estimate.point).all()
    # The other presses are judged as before.
    assert len(pipeline.measurements) == len(replay(log).measurements) - 1


def test_a_tare_taken_while_touching_is_flagged(recorded, capsys, tmp_path):
    log = load_log(recorded[IDS[0]][0])
    assert not any(t.flagged for t in replay(log).tares)
    rows = np.flatnonzero(log.tare)
    wrench = log.wrench.copy()
    wrench[rows[3], 2] += 0.15  # a light touch, below TOUCH_FORCE: the tare is taken
    path = _bad(log, wrench=wrench).save(tmp_path / "touched.npz")
    tares = replay(load_log(path)).tares
    # That tare's offset jumped, and the next one's jumps back: both are flagged, no other.
    assert [k for k, t in enumerate(tares) if t.flagged] == [3, 4]
    assert replay_main([str(path)]) == 0
    out = capsys.readouterr().out
    assert f"tares: {len(tares)}, 2 flagged" in out and "taken while touching?" in out


def test_a_lift_event_ends_the_touch(recorded):
    """The gate takes one measurement per touch; a lift event in a held press starts a new
    touch, whose press (its path starts at the lift) can give another."""
    log = load_log(recorded[IDS[0]][0])
    pipeline: MeasurementPipeline = log.header.pipeline()
    samples = list(log.samples())
    pipeline.reset(samples[0])
    _, row = _accepted_press(log)
    for sample in samples[1 : row + 1]:
        pipeline.step(sample)
    held = samples[row]
    count = len(pipeline.measurements)
    period = log.header.period
    for k in range(1, 9):
        pipeline.step(dataclasses.replace(held, time=held.time + k * period, lift=k == 1))
    assert pipeline.gate._touch_pose is not None  # touching again, as a new touch
    assert len(pipeline.measurements) == count  # no path since the lift: too shallow
    assert pipeline.presses[-1].rule == "press_depth"


def test_samples_are_checked_not_trusted():
    """A non-finite sample is dropped with its fault, never fed to the gate."""
    log_sample = Sample(0.0, np.zeros(6), np.zeros(3), np.eye(3))
    pipeline = load_pipeline()
    pipeline.reset(log_sample)
    got = pipeline.step(dataclasses.replace(log_sample, time=0.05, wrench=np.full(6, np.nan)))
    assert got.fault == "non_finite" and not got.accepted
    assert np.isfinite(pipeline.wrench).all()


def load_pipeline() -> MeasurementPipeline:
    from tactile_gym.perception.log import LogHeader

    return LogHeader(period=0.05, skin_stiffness=8.8e7, estimator={"mode": "planar"}).pipeline()
