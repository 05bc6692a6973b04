"""Training progress as log lines: what ``agents.train`` prints where a progress bar would
be noise (a sweep's ``job.log``)."""

from __future__ import annotations

import math
import time


def progress_lines(total_steps: int, interval: float = 30.0):
    """A stable-baselines3 callback that prints env steps done of ``total_steps``, the time
    elapsed and an ETA, at most every ``interval`` seconds and at the end: progress for a
    log (a sweep's ``job.log``), where a progress bar would be noise."""
    from stable_baselines3.common.callbacks import BaseCallback

    class ProgressLines(BaseCallback):
        def _on_training_start(self) -> None:
            self.first = self.num_timesteps
            self.start = self.last = time.monotonic()
            self.reached = False

        def _on_step(self) -> bool:
            now, done = time.monotonic(), self.num_timesteps
            # SB3 finishes its last rollout past the total: say so once, not every step.
            reached = done >= total_steps and not self.reached
            if now - self.last >= interval or reached:
                self.last, self.reached = now, self.reached or reached
                rate = (done - self.first) / max(now - self.start, 1e-9)
                eta = max(total_steps - done, 0) / rate if rate > 0 else math.inf
                print(
                    f"{done}/{total_steps} env steps ({100 * done / total_steps:.0f} %), "
                    f"{clock(now - self.start)} elapsed, ETA {clock(eta)}",
                    flush=True,
                )
            return True

    return ProgressLines()


def clock(seconds: float) -> str:
    """``h:mm:ss``, or ``-`` where unknown."""
    if not math.isfinite(seconds):
        return "-"
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
