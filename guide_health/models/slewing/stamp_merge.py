"""Load samples and axis angles of a slewing bearing taken in header-stamp order, as the offline analysis
takes them (guide_health/analysis/slewing_replay.py: an angle stamped before a load first, a load first at
equal stamps), although they arrive on two topics in whatever order the transport delivers them.

Each stream arrives in stamp order (one publisher each). A held sample is released once the other stream has
shown that nothing stamped earlier can still come (an angle when a load stamped after it was seen, a load when
an angle stamped at or after it was seen), or once the other stream has been silent for ``window_s`` (it
stopped; a backlogged stream still arriving keeps the order however late it is).
Until both streams have been seen, and for samples without a valid stamp, nothing is held.

Pure: no ROS, no I/O; times in ns (stamps) and s (arrival clock, any monotonic clock).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

LOAD, ANGLE = 0, 1


class StampMerge:
    """``add(kind, t_ns, item, now_s)`` holds a sample; ``release(now_s)`` hands the samples that may go, in
    stamp order, to ``consume(kind, item)``; ``flush()`` hands every held one."""

    def __init__(self, consume: Callable[[int, Any], None], window_s: float) -> None:
        self.consume = consume
        self.window_s = float(window_s)
        self.held: tuple[deque, deque] = (deque(), deque())     # (t_ns, item) per kind
        self.last_seen: list[int | None] = [None, None]
        self.last_arrival_s = [0.0, 0.0]

    def add(self, kind: int, t_ns: int | None, item: Any, now_s: float) -> None:
        self.last_arrival_s[kind] = now_s
        if t_ns is None or self.last_seen[1 - kind] is None:
            self.release(now_s, everything=True)        # no order to keep: what is held goes first
            self.consume(kind, item)
            if t_ns is not None:
                self.last_seen[kind] = t_ns
            return
        self.last_seen[kind] = t_ns
        self.held[kind].append((t_ns, item))
        self.release(now_s)

    def _first(self, kind: int, t_ns: int) -> bool:
        """The head ``t_ns`` of ``kind`` goes before any sample of the other stream not yet seen."""
        other = self.last_seen[1 - kind]
        return other is not None and (other > t_ns if kind == ANGLE else other >= t_ns)

    def release(self, now_s: float, everything: bool = False) -> None:
        loads, angles = self.held
        while loads or angles:
            if loads and angles:        # both heads known: the earlier (an angle first only when stamped earlier)
                kind = ANGLE if angles[0][0] < loads[0][0] else LOAD
            else:
                kind = LOAD if loads else ANGLE
                t_ns = self.held[kind][0][0]
                silent_s = now_s - self.last_arrival_s[1 - kind]
                if not (everything or self._first(kind, t_ns) or silent_s >= self.window_s):
                    return
            self.consume(kind, self.held[kind].popleft()[1])

    def flush(self) -> None:
        self.release(0.0, everything=True)
