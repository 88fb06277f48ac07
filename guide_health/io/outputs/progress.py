"""A one-line progress bar on stderr (tqdm), usable as the `progress(done, total)` callback of the bag
reader and writer and of the models."""
from __future__ import annotations

import os
import sys
from collections.abc import Callable

from tqdm import tqdm

#: progress(done, total): called by long loops after every chunk (done <= total; total may be 0)
ProgressFn = Callable[[int, int], None]

_BAR_FORMAT = "{desc} [{bar:24}] {fraction_pct:5.1f}% {done}/{total_msg} msg {rate_msg_s:,.0f} msg/s {eta}"
_BAR_CHARS = ".#"                   # empty, full: an ASCII bar
_UNTRIMMED_COLS = 1000              # tqdm width when the stream reports none: the line is not trimmed


def _fields(done: int, total: int, elapsed_s: float) -> dict:
    """The numbers of the bar: fraction done, msg/s since the start, the ETA or 'done'."""
    rate = done / elapsed_s if elapsed_s > 0 else 0.0
    if done >= total > 0:
        eta = "done"
    elif rate > 0 and total > 0:
        eta = f"ETA {(total - done) / rate:.0f} s"
    else:
        eta = "ETA ?"
    return {"fraction_pct": 100 * min(1.0, done / total) if total > 0 else 0.0, "done": done,
            "total_msg": total, "rate_msg_s": rate, "eta": eta}


def _screen(stream) -> dict:
    """tqdm's ncols/nrows for `stream`: the terminal's size when it reports one. Else the line is not
    trimmed, and the screen has room for the bar: tqdm hides bars beyond a screen of 0 rows, which a
    pty without a size reports (`script`, `docker exec -t`): measured, it then drew nothing at all."""
    try:
        size = os.get_terminal_size(stream.fileno())
        cols, rows = size.columns, size.lines
    except (AttributeError, OSError, ValueError):
        cols = rows = 0
    return {"ncols": cols if cols > 0 else _UNTRIMMED_COLS, "nrows": rows if rows > 1 else 2}


class _MessageMeter(tqdm):
    """tqdm with the fields of _BAR_FORMAT (tqdm's own would show a smoothed rate and a clock ETA)."""

    monitor_interval = 0            # no tqdm monitor thread: the bar is redrawn by the calls only

    @property
    def format_dict(self):
        d = super().format_dict
        d.update(_fields(self.n, self.total or 0, d["elapsed"]))
        return d


class ProgressBar:
    """One-line progress bar on stderr, usable as `progress(done, total)`.

    Redraws at most `max_hz` times a second (tqdm's mininterval); disabled when the stream is not a TTY
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
        self.bar_format = _BAR_FORMAT.replace("{bar:24}", f"{{bar:{int(width)}}}")
        self._bar: _MessageMeter | None = None
        self._finished = False

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or self._finished:
            return
        if self._bar is None:           # drawn at once, then at most every min_interval
            self._bar = _MessageMeter(total=total, initial=done, desc=self.label, file=self.stream,
                                      mininterval=self.min_interval, miniters=1, ascii=_BAR_CHARS,
                                      bar_format=self.bar_format, leave=True, **_screen(self.stream))
        elif total != self._bar.total:
            self._bar.total = total
        if total > 0 and done >= total:  # final: close() draws the last state and ends the line
            self._bar.n = done
            self.close()
        elif done != self._bar.n:
            self._bar.update(done - self._bar.n)

    def render(self, done: int, total: int, elapsed_s: float) -> str:
        """The bar's text for `done` of `total` messages after `elapsed_s` seconds."""
        return tqdm.format_meter(done, total, elapsed_s, prefix=self.label, ascii=_BAR_CHARS,
                                 bar_format=self.bar_format, **_fields(done, total, elapsed_s))

    def close(self) -> None:
        """End the line if the bar was drawn but never reached 100 %."""
        if self._bar is not None and not self._finished:
            self._bar.close()
        self._finished = True

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
