"""Running time and calendar time of an axis: its running clock, its utilisation and the calendar date of
its precision limit.

An axis runs while it moves; a pause of at most ``idle_after_s`` (a tool change, a probe cycle, a dwell)
is part of running; a longer pause is idle. The running clock tau = t - (idle time so far) stops while the
axis is idle: the duty window (models/wear/archard.py) is kept in running time, so an idle machine keeps
the duty of its last running hour and its remaining life (in running hours) stays as it was, finite.
Exactly: a joint sample at t is

- *counted* when the axis moved into it, or when it is at most ``idle_after_s`` after the last motion
  t_m; then tau(t) = t - idle;
- *idle* otherwise (no duty; the status reports the duty at the last motion t_m, exactly the value it had
  then: the duty buckets after it hold no work);
- a motion after an idle pause ends it: idle += t - t_c, the pause (t_c, t) is recorded, tau(t) = tau(t_c).

A pause with no samples at all (machine or recorder off) is idle by the same rule when it is longer than
``idle_after_s``. Without such pauses tau = t and the duty equals the calendar one.

Utilisation over a calendar window D (``utilisation_window_days``) ending at the latest sample t_now:
    u = 1 - (idle time in [t_now - S, t_now]) / S,      S = min(D, t_now - t_first)
(the ongoing pause, (t_c, t_now] while idle, counts as idle). The remaining running life L [h] then lasts
L / u calendar hours: the limit's calendar date is t_now + L / u (its 90 % band from L's interval and the
daily utilisation's spread: models/wear/planning.py status_calendar_keys).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime

import numpy as np

NS_PER_S = 1_000_000_000
_NEVER = np.iinfo(np.int64).min


@dataclass
class RunningClock:
    """The running clock of one guide's samples (state persisted with the integrator)."""

    idle_after_s: float = 300.0
    utilisation_window_days: float = 7.0       # pauses that ended before it are forgotten
    first_t_ns: int | None = None
    last_t_ns: int | None = None
    last_motion_t_ns: int | None = None        # t_m
    last_counted_t_ns: int | None = None       # t_c
    idle_ns: int = 0                           # idle time excluded from tau so far
    idle_pause_start_ns: list = field(default_factory=list)    # ended idle pauses (t_c, t_resume)
    idle_pause_end_ns: list = field(default_factory=list)

    @property
    def idle_after_ns(self) -> int:
        return int(round(self.idle_after_s * NS_PER_S))

    def _start(self, t_ns: int) -> int:
        self.first_t_ns = self.last_t_ns = self.last_motion_t_ns = self.last_counted_t_ns = int(t_ns)
        return int(t_ns) - self.idle_ns

    def advance(self, t_ns: int, moving: bool) -> int | None:
        """tau [ns] of a sample (None: an idle sample); ``moving``: the axis slid into it."""
        t_ns = int(t_ns)
        if self.first_t_ns is None:
            return self._start(t_ns)
        self.last_t_ns = t_ns
        paused = t_ns - self.last_motion_t_ns > self.idle_after_ns
        if moving:
            if paused:                         # the end of an idle pause
                self.idle_ns += t_ns - self.last_counted_t_ns
                self.idle_pause_start_ns.append(self.last_counted_t_ns)
                self.idle_pause_end_ns.append(t_ns)
                self._forget(t_ns)
            self.last_motion_t_ns = self.last_counted_t_ns = t_ns
            return t_ns - self.idle_ns
        if paused:
            return None
        self.last_counted_t_ns = t_ns
        return t_ns - self.idle_ns

    def advance_many(self, t_ns, moving) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`advance` of arrays: (tau [ns], counted) per sample (the same decisions)."""
        t = np.asarray(t_ns, dtype=np.int64)
        moving = np.asarray(moving, dtype=bool)
        tau, counted = np.zeros(t.size, dtype=np.int64), np.ones(t.size, dtype=bool)
        if t.size == 0:
            return tau, counted
        lo = 0
        if self.first_t_ns is None:
            tau[0], lo = self._start(int(t[0])), 1
        t, moving = t[lo:], moving[lo:]
        if t.size:
            moved = np.maximum(np.maximum.accumulate(np.where(moving, t, _NEVER)), self.last_motion_t_ns)
            motion_before = np.concatenate(([self.last_motion_t_ns], moved[:-1]))
            paused = t - motion_before > self.idle_after_ns
            count = moving | ~paused
            seen = np.maximum(np.maximum.accumulate(np.where(count, t, _NEVER)), self.last_counted_t_ns)
            counted_before = np.concatenate(([self.last_counted_t_ns], seen[:-1]))
            resume = moving & paused
            idle = self.idle_ns + np.cumsum(np.where(resume, t - counted_before, 0))
            tau[lo:], counted[lo:] = t - idle, count
            self.idle_pause_start_ns.extend(counted_before[resume].tolist())
            self.idle_pause_end_ns.extend(t[resume].tolist())
            if resume.any():
                self._forget(int(t[resume][-1]))
            self.idle_ns = int(idle[-1])
            self.last_motion_t_ns, self.last_counted_t_ns = int(moved[-1]), int(seen[-1])
            self.last_t_ns = int(t[-1])
        return tau, counted

    # --- what the status reports ---------------------------------------------------------------------
    @property
    def running_now_t_ns(self) -> int | None:
        """The stamp the running present is at: the last counted sample, or while idle the last motion (an
        idle axis reports the duty of its last running window, the dwell before it turned idle not in it)."""
        if self.last_counted_t_ns is None:
            return None
        return self.last_motion_t_ns if self.idle_since_ns() is not None else self.last_counted_t_ns

    @property
    def tau_now_ns(self) -> int | None:
        """tau of :attr:`running_now_t_ns`: the running clock's present."""
        now = self.running_now_t_ns
        return None if now is None else now - self.idle_ns

    def idle_since_ns(self) -> int | None:
        """The last motion's stamp while the axis is idle (its latest sample more than idle_after_s after
        it), else None."""
        if self.last_t_ns is None or self.last_t_ns - self.last_motion_t_ns <= self.idle_after_ns:
            return None
        return self.last_motion_t_ns

    def utilisation(self) -> float:
        """u over the calendar window ending at the latest sample (module docstring); NaN before a span."""
        if self.first_t_ns is None:
            return math.nan
        now = self.last_t_ns
        span = min(int(round(self.utilisation_window_days * 86400.0 * NS_PER_S)), now - self.first_t_ns)
        if span <= 0:
            return math.nan
        start = now - span
        idle = sum(max(0, min(b, now) - max(a, start)) for a, b in self.idle_pauses())
        return 1.0 - idle / span

    def idle_pauses(self) -> list[tuple[int, int]]:
        """The idle pauses (start, end) [ns] the window remembers, the ongoing one ending at the latest sample."""
        pauses = list(zip(self.idle_pause_start_ns, self.idle_pause_end_ns))
        if self.idle_since_ns() is not None:
            pauses.append((self.last_counted_t_ns, self.last_t_ns))
        return pauses

    def _forget(self, t_ns: int) -> None:
        """Forget the pauses that ended before the utilisation window ending at ``t_ns`` (the latest pause's
        end: the same pauses go sample by sample and in arrays)."""
        start = t_ns - int(round(self.utilisation_window_days * 86400.0 * NS_PER_S))
        keep = [i for i, end in enumerate(self.idle_pause_end_ns) if end > start]
        self.idle_pause_start_ns = [self.idle_pause_start_ns[i] for i in keep]
        self.idle_pause_end_ns = [self.idle_pause_end_ns[i] for i in keep]

    def state(self) -> dict:
        return {"idle_ns": self.idle_ns, "last_motion_t_ns": self.last_motion_t_ns,
                "last_counted_t_ns": self.last_counted_t_ns, "idle_pause_start_ns": list(self.idle_pause_start_ns),
                "idle_pause_end_ns": list(self.idle_pause_end_ns)}

    def restore(self, state: dict, first_t_ns: int | None, last_t_ns: int | None) -> None:
        """From :meth:`state` (a state saved without these fields: running since its first sample)."""
        self.first_t_ns, self.last_t_ns = first_t_ns, last_t_ns
        self.idle_ns = int(state.get("idle_ns", 0))
        self.last_motion_t_ns = state.get("last_motion_t_ns", last_t_ns)
        self.last_counted_t_ns = state.get("last_counted_t_ns", last_t_ns)
        self.idle_pause_start_ns = [int(v) for v in state.get("idle_pause_start_ns", [])]
        self.idle_pause_end_ns = [int(v) for v in state.get("idle_pause_end_ns", [])]


def utc_text(t_ns: float) -> str:
    """ISO-8601 UTC date and time of a stamp [ns] to the second ('' when not finite or out of range)."""
    if not math.isfinite(t_ns):
        return ""
    try:
        return datetime.fromtimestamp(t_ns * 1e-9, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    except (OverflowError, OSError, ValueError):
        return ""
