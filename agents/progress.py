"""Progress as log lines: what ``agents.train`` prints where a progress bar would be noise (a
sweep's ``job.log``), for its env steps and for the demonstrations it records."""

from __future__ import annotations

import math
import time

__all__ = ["ProgressLines", "clock", "progress_lines"]


class ProgressLines:
    """Prints ``<done>/<total> <unit> (<percent> %), <elapsed> elapsed, ETA <eta>`` at most
    every ``interval`` seconds, and once when ``done`` first reaches ``total``.

    Args:
        total: the count at the end.
        unit: what is counted ("env steps", "demonstrations").
        interval: seconds between lines.
        first: the count at the start (a resumed run's), from which the rate is measured.
    """

    def __init__(self, total: int, unit: str, interval: float = 30.0, first: int = 0) -> None:
        self.total, self.unit, self.interval, self.first = total, unit, interval, first
        self.start = self.last = time.monotonic()
        self.reached = False

    def update(self, done: int) -> None:
        now = time.monotonic()
        # SB3 finishes its last rollout past the total: say so once, not every step.
        reached = done >= self.total and not self.reached
        if now - self.last >= self.interval or reached:
            self.last, self.reached = now, self.reached or reached
            rate = (done - self.first) / max(now - self.start, 1e-9)
            eta = max(self.total - done, 0) / rate if rate > 0 else math.inf
            print(
                f"{done}/{self.total} {self.unit} ({100 * done / self.total:.0f} %), "
                f"{clock(now - self.start)} elapsed, ETA {clock(eta)}",
                flush=True,
            )


def progress_lines(total_steps: int, interval: float = 30.0):
    """A stable-baselines3 callback that prints :class:`ProgressLines` of the env steps done
    of ``total_steps``: progress for a log (a sweep's ``job.log``), where a progress bar
    would be noise."""
    from stable_baselines3.common.callbacks import BaseCallback

    class ProgressLinesCallback(BaseCallback):
        def _on_training_start(self) -> None:
            self.lines = ProgressLines(total_steps, "env steps", interval, self.num_timesteps)

        def _on_step(self) -> bool:
            self.lines.update(self.num_timesteps)
            return True

    return ProgressLinesCallback()


def clock(seconds: float) -> str:
    """``h:mm:ss``, or ``-`` where unknown."""
    if not math.isfinite(seconds):
        return "-"
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
