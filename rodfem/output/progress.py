"""A one-line progress bar on a terminal, shown only for runs that last more than a moment."""

from __future__ import annotations

import sys
import time


class Progress:
    """``update(n)`` with n out of ``total``; draws at most ten times a second, and only once the
    run has lasted ``delay`` seconds, so short runs stay quiet. With ``of_time`` (adaptive steps,
    whose number is not known in advance) n and ``total`` are the time reached and the end, and
    the bar says the time and the steps taken (``update(t, steps)``)."""

    def __init__(self, total: float, enabled: bool, delay: float = 2.0, stream=sys.stderr,
                 of_time: bool = False):
        self.total, self.enabled, self.delay, self.stream = total, enabled, delay, stream
        self.of_time = of_time
        self.started = time.perf_counter()
        self.drawn = 0.0
        self.shown = False

    def update(self, n: float, steps: int = 0) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self.started < self.delay or now - self.drawn < 0.1:
            return
        self.drawn, self.shown = now, True
        fraction = n / self.total
        elapsed = now - self.started
        eta = elapsed * (1 - fraction) / max(fraction, 1e-12)
        bar = "#" * int(30 * fraction)
        where = (f"t {n:.6g}/{self.total:g} ({steps} steps)" if self.of_time
                 else f"step {n}/{self.total}")
        self.stream.write(f"\r[{bar:<30}] {100 * fraction:5.1f}%  {where}  eta {eta:5.1f} s ")
        self.stream.flush()

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
