"""Live inputs aligned by header stamps: the live node's way to the offline load rule."""
from __future__ import annotations

import math
from collections import deque

from guide_health.models.wear.precision import PrecisionMonitor


class StampAlignedFeed:
    """Live inputs aligned by header stamps, with the offline rule of process_run: a joint sample is
    integrated with the latest load whose stamp is <= its own.

    Joint and load messages come from different DDS writers, which keep order per writer only, so a
    load change (or the very first load) can arrive after joint samples stamped later than it. Joint
    samples newer than the latest load therefore wait here until a load stamped after them arrives
    (then the load they need is known) or until they have waited `window_s` of wall time (then the load
    stream is just slower, and they take the latest load, as without alignment). window_s = 0 integrates
    every sample on arrival.

    The other way round, a joint sample can arrive after a load stamped later than it (seen at start-up:
    the first load overtook the first joint samples). It is integrated at once, with the load in force at
    its stamp, not the newer one: the feed keeps the accepted loads stamped after the joint stream
    (``loads``) and gives every sample the latest of them stamped <= its own, NaN before the first (no
    wear), as :func:`~guide_health.models.wear.input_rules.load_at_joint_samples` does offline. So the
    result does not depend on the arrival order of loads and joint samples, except for a load that comes
    more than `window_s` after the joint samples stamped after it.
    Validation (:mod:`guide_health.models.wear.input_rules`) happens on arrival,
    so bad samples are rejected at once and counted in the monitor's ``rejected``.
    Every method returns the rejection reasons of the samples it handled.
    """

    def __init__(self, monitor: PrecisionMonitor, window_s: float = 0.5):
        if window_s < 0:
            raise ValueError("window_s must be >= 0")
        self.monitor = monitor
        self.window_s = float(window_s)
        self.pending = deque()              # (t_ns, position_m, velocity_m_s, arrival_s)
        # (t_ns, load_n): the accepted loads not yet behind the joint stream (bounded: with no joint
        # samples at all, the oldest go first; a sample older than every kept load would get NaN)
        self.loads = deque(maxlen=4096)

    def joint(self, t_ns: int, position_m: float, velocity_m_s: float, now_s: float) -> list[str]:
        reason = self.monitor.validate_joint(t_ns, position_m, velocity_m_s)
        if reason is not None:
            return [reason]
        load_t = self.monitor.load_t_ns
        if self.window_s == 0 or (not self.pending and load_t is not None and t_ns < load_t):
            # nothing can come that changes this sample's load (or alignment is off)
            return self._integrate([(t_ns, position_m, velocity_m_s)]) + self.flush_aged(now_s)
        self.pending.append((int(t_ns), position_m, velocity_m_s, now_s))
        return self.flush_aged(now_s)

    def load(self, t_ns: int, load_n: float, now_s: float) -> list[str]:
        m = self.monitor
        if m.check_load(t_ns, load_n) is not None:
            return [m.on_load(t_ns, load_n)]          # rejected (and counted) by the monitor
        reasons = self._integrate(self._take(lambda t: t < t_ns))   # they used the previous load
        if not self.loads and m.load_t_ns is not None:
            self.loads.append((m.load_t_ns, m.load_n))     # the monitor's load before this feed's first
        r = m.on_load(t_ns, load_n)
        if r is None:
            self.loads.append((int(t_ns), float(load_n)))
        return reasons + ([r] if r else []) + self.flush_aged(now_s)

    def flush_aged(self, now_s: float) -> list[str]:
        """Integrate samples that waited longer than the window (with the latest load)."""
        if not self.pending or now_s - self.pending[0][3] <= self.window_s:
            return []
        cutoff = now_s - self.window_s
        batch = []
        while self.pending and self.pending[0][3] < cutoff:
            batch.append(self.pending.popleft()[:3])
        return self._integrate(batch)

    def flush_all(self) -> list[str]:
        """Integrate everything waiting (before a straightness measurement, a checkpoint, shutdown)."""
        return self._integrate(self._take(lambda t: True))

    def _take(self, older) -> list:
        batch = []
        while self.pending and older(self.pending[0][0]):
            batch.append(self.pending.popleft()[:3])
        return batch

    def load_at(self, t_ns: int) -> float | None:
        """The accepted load [N] stamped at or before ``t_ns`` (NaN: none; None: no load came through this
        feed, the monitor's latest counts). Called in joint stamp order: older loads are dropped."""
        loads = self.loads
        if not loads:
            return None
        while len(loads) > 1 and loads[1][0] <= t_ns:
            loads.popleft()
        return loads[0][1] if loads[0][0] <= t_ns else math.nan

    def _integrate(self, samples) -> list[str]:
        for t_ns, x, _ in samples:
            self.monitor.integrate_joint(t_ns, x, self.load_at(t_ns))   # validated on arrival
        return []
