"""A one-line progress bar on a terminal, shown only for runs that last more than a moment."""

from __future__ import annotations

import sys
import time


class Progress:
    """``update(n)`` with n out of ``total``; draws at most ten times a second, and only once the
    run has lasted ``delay`` seconds, so short runs stay quiet."""

    def __init__(self, total: int, enabled: bool, delay: float = 2.0, stream=sys.stderr):
        self.total, self.enabled, self.delay, self.stream = total, enabled, delay, stream
        self.started = time.perf_counter()
        self.drawn = 0.0
        self.shown = False

    def update(self, n: int) -> None:
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
        self.stream.write(f"\r[{bar:<30}] {100 * fraction:5.1f}%  step {n}/{self.total}  "
                          f"eta {eta:5.1f} s ")
        self.stream.flush()

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
