"""Travel of a life-test carriage from what the machine records (no ROS, no I/O; m, s, ns stamps).

Two sources, the better one used as soon as it is present:

* **position**: the test axis' position x_i (a JointState of the axis): travel = sum_i |x_i - x_{i-1}| (every
  stroke counts both ways; a standing axis adds nothing, so a bench stop is never travel);
* **speed x moving time**: the constant test speed v times the time the bench ran, t_moving = sum of the gaps
  between consecutive inputs (blocks or sound levels, any stream) that are <= ``pause_gap_s``; a longer gap (no
  block and no level for longer than it) is a stop and adds one typical input spacing only (the median of the
  last SPACINGS moving gaps: the bench ran about half a spacing after the last input and half before the next,
  the recorder sampling at its rate while it moves). The gap must exceed the recording's own
  input spacing (a snapshot recorder) and stay below the shortest stop worth excluding.

Both start at the start stamp (the first stamp seen unless given) and add ``offset_m`` (travel before the
recording, e.g. a specimen moved to a new rig).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

SPACINGS = 16       # moving gaps kept for the typical input spacing


@dataclass
class TravelClock:
    """Travel [m] at a stamp [ns] (module docstring). Inputs of one stream come in stamp order; an input older
    than the newest stamp seen (another stream) is placed back from the newest along the moving time."""

    speed_m_s: float
    pause_gap_s: float = 10800.0
    offset_m: float = 0.0
    start_ns: int | None = None
    joint_name: str = ""
    last_ns: int | None = None
    moving_s: float = 0.0
    moving_at_resume_s: float = 0.0
    paused_s: float = 0.0
    pauses: int = 0
    position_m: float | None = None
    path_m: float = 0.0
    positions: int = 0
    spacings_s: list = field(default_factory=list)

    def __post_init__(self) -> None:
        for name in ("speed_m_s", "pause_gap_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if not math.isfinite(self.offset_m):
            raise ValueError(f"travel offset must be finite, got {self.offset_m!r}")

    def on_position(self, t_ns: int, x_m: float) -> None:
        """One position of the test axis [m]; ValueError (state unchanged) when not finite. Positions before the
        start stamp set the reference only."""
        if not math.isfinite(x_m):
            raise ValueError(f"axis position must be finite, got {x_m!r}")
        if self.position_m is not None and (self.start_ns is None or int(t_ns) >= self.start_ns):
            self.path_m += abs(float(x_m) - self.position_m)
        self.position_m = float(x_m)
        self.positions += 1

    def travel_m(self, t_ns: int) -> float:
        """Travel at stamp t_ns; negative (speed x time) before the start stamp so the caller can refuse it."""
        t_ns = int(t_ns)
        if self.start_ns is None:
            self.start_ns = t_ns
        if t_ns < self.start_ns:
            return self.offset_m + self.speed_m_s * (t_ns - self.start_ns) / 1e9
        if self.positions:
            return self.offset_m + self.path_m
        if self.last_ns is None:
            self.last_ns = self.start_ns
        if t_ns >= self.last_ns:
            gap_s = (t_ns - self.last_ns) / 1e9
            if gap_s > self.pause_gap_s:
                spacing_s = float(np.median(self.spacings_s)) if self.spacings_s else 0.0
                self.pauses += 1
                self.paused_s += gap_s - spacing_s
                self.moving_s += spacing_s
                self.moving_at_resume_s = self.moving_s
            else:
                self.moving_s += gap_s
                if gap_s > 0:
                    self.spacings_s = (self.spacings_s + [gap_s])[-SPACINGS:]
            self.last_ns = t_ns
            return self.offset_m + self.speed_m_s * self.moving_s
        back_s = (self.last_ns - t_ns) / 1e9
        return self.offset_m + self.speed_m_s * max(self.moving_s - back_s, self.moving_at_resume_s)

    def source(self) -> str:
        """The travel source in words (for the report)."""
        if self.positions:
            return f"position: sum |dx| of joint '{self.joint_name}' ({self.positions} positions)"
        return (f"speed x moving time: {self.speed_m_s:g} m/s, input gaps > pause_gap_s {self.pause_gap_s:g} s "
                f"are stops ({self.pauses} stops, {self.paused_s / 3600.0:.2f} h)")
