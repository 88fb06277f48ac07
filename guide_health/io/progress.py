"""A one-line progress bar on stderr, usable as the `progress(done, total)` callback of the bag reader
and writer and of the models."""
from __future__ import annotations

import math
import sys
import time
from typing import Callable

#: progress(done, total): called by long loops after every chunk (done <= total; total may be 0)
ProgressFn = Callable[[int, int], None]


class ProgressBar:
    """One-line progress bar on stderr, usable as `progress(done, total)`.

    Redraws with '\\r' at most `max_hz` times a second; disabled when the stream is not a TTY
    unless `force`. Shows done/total messages, msg/s and the ETA; ends the line when done.
    """

    def __init__(self, label: str = "reading", stream=None, force: bool = False, max_hz: float = 5.0,
                 width: int = 24):
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        try:
            tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            tty = False
        self.enabled = force or tty
        self.min_interval = 1.0 / max_hz if max_hz > 0 else 0.0
        self.width = width
        self._t0: float | None = None
        self._last = -math.inf
        self._finished = False
        self._last_len = 0

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or self._finished:
            return
        now = time.monotonic()
        if self._t0 is None:
            self._t0 = now
        final = total > 0 and done >= total
        if not final and now - self._last < self.min_interval:
            return
        self._last = now
        self.stream.write("\r" + self.render(done, total, now - self._t0))
        if final:
            self.stream.write("\n")
            self._finished = True
        self.stream.flush()

    def render(self, done: int, total: int, elapsed_s: float) -> str:
        frac = min(1.0, done / total) if total > 0 else 0.0
        filled = int(round(frac * self.width))
        rate = done / elapsed_s if elapsed_s > 0 else 0.0
        if done >= total > 0:
            eta = "done"
        elif rate > 0 and total > 0:
            eta = f"ETA {(total - done) / rate:.0f} s"
        else:
            eta = "ETA ?"
        text = (f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:5.1f}% "
                f"{done}/{total} msg {rate:,.0f} msg/s {eta}")
        pad = max(0, self._last_len - len(text))
        self._last_len = len(text)
        return text + " " * pad

    def close(self) -> None:
        """End the line if the bar was drawn but never reached 100 %."""
        if self.enabled and not self._finished and self._t0 is not None:
            self.stream.write("\n")
            self.stream.flush()
        self._finished = True

    def __enter__(self) -> "ProgressBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
