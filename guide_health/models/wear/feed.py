"""Live inputs aligned by header stamps: the live node's way to the offline load rule."""
from __future__ import annotations

from collections import deque

import numpy as np

from guide_health.models.wear.input_rules import REASON_CODES, accept_joint_samples, accept_load_samples
from guide_health.models.wear.precision import PrecisionMonitor


class StampAlignedFeed:
    """Live inputs aligned by header stamps, with the offline rule of process_run: a joint sample is
    integrated with the latest load whose stamp is <= its own.

    Joint and load messages come from different DDS writers, which keep order per writer only, so a
    load change (or the very first load) can arrive after joint samples stamped later than it. Joint
    samples newer than the latest load therefore wait here until a load stamped after them arrives
    (then the load they need is known) or until they have waited `window_s` of wall time (then the load
    stream is just slower, and they take the latest load, as without alignment). window_s = 0 integrates
    every sample on arrival. Validation (:mod:`guide_health.models.wear.input_rules`) happens on arrival,
    so bad samples are rejected at once and counted in the monitor's ``rejected``.
    Every method returns the rejection reasons of the samples it handled.

    batch_events > 1 (issue 14): joint() and load() only copy the sample into a buffer; every
    `batch_events` samples (and in flush_aged / flush_all) the buffer is handled at once: validation with
    the vectorised rules (accept_joint_samples / accept_load_samples, the same verdicts as one by one),
    the alignment decisions above event by event in plain Python, and the integration in one call of the
    model's batch path (PrecisionMonitor._advance_many). The numbers equal those of batch_events = 1 to
    rounding (tested); rejections are reported when the batch is handled instead of on arrival. With
    window_s = 0, or for a monitor other than a PrecisionMonitor, every sample is handled on arrival.
    """

    def __init__(self, monitor: PrecisionMonitor, window_s: float = 0.5, batch_events: int = 1):
        if window_s < 0:
            raise ValueError("window_s must be >= 0")
        self.monitor = monitor
        self.window_s = float(window_s)
        self.pending = deque()              # (t_ns, position_m, velocity_m_s, arrival_s)
        self.batch_events = max(1, int(batch_events))
        self._events: list = []             # (is_load, t_ns, value, velocity, arrival_s) not yet handled

    def joint(self, t_ns: int, position_m: float, velocity_m_s: float, now_s: float) -> list[str]:
        if self._batching():
            return self._buffer((False, t_ns, position_m, velocity_m_s, now_s))
        reasons = self.process() if self._events else []     # the window was set to 0 with samples copied
        return reasons + self._joint_now(t_ns, position_m, velocity_m_s, now_s)

    def _joint_now(self, t_ns: int, position_m: float, velocity_m_s: float, now_s: float) -> list[str]:
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
        if self._batching():
            return self._buffer((True, t_ns, load_n, 0.0, now_s))
        reasons = self.process() if self._events else []
        return reasons + self._load_now(t_ns, load_n, now_s)

    def _load_now(self, t_ns: int, load_n: float, now_s: float) -> list[str]:
        m = self.monitor
        if m.check_load(t_ns, load_n) is not None:
            return [m.on_load(t_ns, load_n)]          # rejected (and counted) by the monitor
        reasons = self._integrate(self._take(lambda t: t < t_ns))   # they used the previous load
        r = m.on_load(t_ns, load_n)
        return reasons + ([r] if r else []) + self.flush_aged(now_s)

    def flush_aged(self, now_s: float) -> list[str]:
        """Integrate samples that waited longer than the window (with the latest load)."""
        if self._events:
            return self.process() + self.flush_aged(now_s)
        if not self.pending or now_s - self.pending[0][3] <= self.window_s:
            return []
        cutoff = now_s - self.window_s
        batch = []
        while self.pending and self.pending[0][3] < cutoff:
            batch.append(self.pending.popleft()[:3])
        return self._integrate(batch)

    def flush_all(self) -> list[str]:
        """Integrate everything waiting (before a straightness measurement, a checkpoint, shutdown)."""
        reasons = self.process() if self._events else []
        return reasons + self._integrate(self._take(lambda t: True))

    def _take(self, older) -> list:
        batch = []
        while self.pending and older(self.pending[0][0]):
            batch.append(self.pending.popleft()[:3])
        return batch

    def _integrate(self, samples) -> list[str]:
        if len(samples) > 1 and self._batch_model():     # the model's batch path (same numbers to rounding)
            t_ns, x, _ = zip(*samples)
            m = self.monitor
            m._advance_many(np.array(t_ns, np.int64), np.array(x, float), np.full(len(x), m.load_n))
            return []
        for t_ns, x, _ in samples:
            self.monitor.integrate_joint(t_ns, x)   # validated on arrival
        return []

    # --- batch_events > 1 ---------------------------------------------------------------------------
    def _batch_model(self) -> bool:
        """The batch path needs a PrecisionMonitor (an AxisMonitor, several guides with maintenance events
        between samples, is fed sample by sample)."""
        return isinstance(self.monitor, PrecisionMonitor)

    def _batching(self) -> bool:
        # window_s = 0: every sample on arrival
        return self.batch_events > 1 and self.window_s > 0 and self._batch_model()

    def _buffer(self, event: tuple) -> list[str]:
        self._events.append(event)
        return self.process() if len(self._events) >= self.batch_events else []

    def process(self) -> list[str]:
        """Handle the buffered samples as joint() and load() would have one by one; returns the reasons."""
        events, self._events = self._events, []
        if not events:
            return []
        is_load, t_ns, value, velocity, now = (np.asarray(c) for c in zip(*events))
        t_ns = t_ns.astype(np.int64)
        ok = np.zeros(is_load.size, bool)
        reasons: list[str] = []
        m = self.monitor
        for load, stream in ((False, "joint_states"), (True, "guide/load")):
            sel = np.flatnonzero(is_load == load)
            if not sel.size:
                continue
            if load:
                acc = accept_load_samples(t_ns[sel], value[sel].astype(float), m.load_base, m.limits)
                m.load_base = acc.base
            else:
                acc = accept_joint_samples(t_ns[sel], value[sel].astype(float), velocity[sel].astype(float),
                                           m.joint_base, m.limits)
                m.joint_base = acc.base
            ok[sel] = acc.accepted
            m.rejected.count_all(acc.rejected)
            window = m.recent[stream]
            window.extend(REASON_CODES[c] for c in acc.codes[-window.maxlen:].tolist())
            reasons += [reason for reason, n in acc.rejected.items() for _ in range(n)]
        self._align(np.flatnonzero(ok).tolist(), is_load.tolist(), t_ns.tolist(), value.tolist(),
                    velocity.tolist(), now.tolist())
        return reasons

    def _align(self, accepted, is_load, t_ns, value, velocity, now) -> None:
        """joint()/load()/flush_aged() decisions for the accepted events, the integration batched."""
        m = self.monitor
        out_t, out_x, out_w = [], [], []
        load_n, load_t = m.load_n, m.load_t_ns
        pending, window = self.pending, self.window_s

        def emit(count: int) -> None:
            for _ in range(count):
                t, x = pending.popleft()[:2]
                out_t.append(t)
                out_x.append(x)
                out_w.append(load_n)
        for k in accepted:
            t = t_ns[k]
            if is_load[k]:
                older = 0
                while older < len(pending) and pending[older][0] < t:
                    older += 1
                emit(older)
                load_n, load_t = float(value[k]), t
                m.load_samples += 1
            elif window == 0 or (not pending and load_t is not None and t < load_t):
                out_t.append(t)
                out_x.append(value[k])
                out_w.append(load_n)
            else:
                pending.append((t, value[k], velocity[k], now[k]))
            if pending and now[k] - pending[0][3] > window:      # flush_aged(now), the same tests
                cutoff, aged = now[k] - window, 0
                while aged < len(pending) and pending[aged][3] < cutoff:
                    aged += 1
                emit(aged)
        if out_t:
            m._advance_many(np.array(out_t, np.int64), np.array(out_x, float), np.array(out_w, float))
        m.load_n, m.load_t_ns = load_n, load_t
