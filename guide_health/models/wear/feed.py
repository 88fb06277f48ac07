"""Live inputs aligned by header stamps: the live node's way to the offline load rule."""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.input_rules import REASON_CODES


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
    Validation (the axis's input gate, models/wear/gate.py) happens on arrival, so bad samples are rejected
    at once and counted in the axis's ``rejected``. The feed talks to its AxisMonitor only. Every method
    returns the rejection reasons of the samples it handled.

    Batches (:meth:`process`): the live node only copies messages in its callbacks and hands the feed the
    joint and load samples that arrived since the last batch, in arrays, with their arrival times and their
    interleaving. The axis's gate judges them with the vectorised input rules (its counters, recent windows,
    time bases and stamp gaps, as on arrival), the feed replays the decisions above
    event by event in arrival order (which samples wait, which are integrated when, with which load in
    force at their stamp) and integrates the result with the model's batch path (AxisMonitor.integrate_many:
    split at pending maintenance events, each guide its share of the load). The numbers equal those of
    :meth:`joint` / :meth:`load` one by one (test_live_batch.py).
    """

    def __init__(self, monitor: AxisMonitor, window_s: float = 0.5):
        if window_s < 0:
            raise ValueError("window_s must be >= 0")
        self.monitor = monitor
        self.window_s = float(window_s)
        self.pending = deque()              # (t_ns, position_m, velocity_m_s, arrival_s)
        # (t_ns, load_n): the accepted loads not yet behind the joint stream (bounded: with no joint
        # samples at all, the oldest go first; a sample older than every kept load would get NaN)
        self.loads = deque(maxlen=4096)
        self.batches = [0, 0]               # batches aligned without / with the event loop (_align_fast)

    def joint(self, t_ns: int, position_m: float, velocity_m_s: float, now_s: float) -> list[str]:
        reason = self.monitor.validate_joint(t_ns, position_m, velocity_m_s)
        if reason is not None:
            return [reason]
        load_t = self.monitor.load_t_ns
        if self.monitor.load_model is not None:      # no load stream to wait for: the model's load now
            return self._integrate([(t_ns, position_m, velocity_m_s)])
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
        if len(samples) > 1:
            t = np.array([s[0] for s in samples], dtype=np.int64)
            x = np.array([s[1] for s in samples], dtype=float)
            loads = [self.load_at(int(s[0])) for s in samples]
            if None not in loads:        # (None: no load through the feed yet, each guide its latest)
                self.monitor.integrate_many(t, x, np.array(loads, dtype=float))
                return []
            for ti, xi, w in zip(t.tolist(), x.tolist(), loads):
                self.monitor.integrate_joint(ti, xi, w)
            return []
        for t_ns, x, _ in samples:
            self.monitor.integrate_joint(t_ns, x, self.load_at(t_ns))   # validated on arrival
        return []

    # --- batches -------------------------------------------------------------------------------------
    def process(self, joint_t_ns, position_m, velocity_m_s, joint_now_s, load_t_ns, load_n, load_now_s,
                load_after) -> list[str]:
        """The joint samples (stamps [ns], positions [m], velocities [m/s], arrival times [s]) and load
        samples (stamps, axis loads [N], arrival times) that arrived since the last call, each in arrival
        order; ``load_after[i]``: how many of the joint samples arrived before load i (non-decreasing).
        Exactly what joint() and load() in that arrival order do; returns the rejection reasons."""
        jt = np.asarray(joint_t_ns, dtype=np.int64)
        lt = np.asarray(load_t_ns, dtype=np.int64)
        lw = np.asarray(load_n, dtype=float)
        axis = self.monitor
        start_t = axis.load_t_ns                       # the axis load before the batch
        joints = axis.accept_joints(jt, position_m, velocity_m_s)
        loads, start_n = axis.accept_loads(lt, lw)
        if axis.load_model is not None:                # every accepted sample now, with the model's load
            ok = joints.accepted
            if ok.any():
                axis.integrate_many(jt[ok], np.asarray(position_m, dtype=float)[ok], None)
            return _reasons(joints.codes, loads.codes, load_after)
        fast = self._align_fast(joints.accepted, jt, np.asarray(position_m, dtype=float),
                                np.asarray(joint_now_s, dtype=float), loads.accepted, lt, lw,
                                np.asarray(load_now_s, dtype=float), start_t)
        if fast is not None:
            self.batches[0] += 1
            if fast[0].size:
                axis.integrate_many(*fast)
            return _reasons(joints.codes, loads.codes, load_after)
        self.batches[1] += 1
        out_t, out_x, out_w, own = self._align(
            joints.accepted.tolist(), jt.tolist(), np.asarray(position_m, dtype=float).tolist(),
            list(joint_now_s), loads.accepted.tolist(), lt.tolist(), lw.tolist(), list(load_now_s),
            list(load_after), start_t, start_n)
        if out_t:
            t, x, w = np.array(out_t, dtype=np.int64), np.array(out_x, dtype=float), np.array(out_w, dtype=float)
            own_loads = None
            if own:
                at, counts = np.array([a for a, _ in own]), np.array([c for _, c in own])
                own_loads = (at, _latest_after(loads.accepted, lw, start_n, counts))
            axis.integrate_many(t, x, w, own_loads)
        return _reasons(joints.codes, loads.codes, load_after)

    def _align_fast(self, ok_j, jt, jx, jnow, ok_l, lt, lw, lnow, load_t):
        """What :meth:`_align` gives, without the event loop, in the steady state: the feed keeps a load,
        no sample ages in the batch (the latest arrival minus the earliest one that can wait is within the
        window; rounding is monotone, so then no event's test `now - first waiting > window` holds) and
        the kept loads stay under the deque's bound. None when that does not hold.

        Then a sample is integrated in the batch iff it is stamped before the latest accepted load (it
        waits for a load stamped after it, or is integrated on arrival when one came already), in stamp
        order, and every load stamped at or before it has arrived by then (loads are accepted in stamp
        order), so :meth:`load_at` gives the latest of all kept and new loads stamped <= it, and leaves the
        kept loads from that one on."""
        pending, loads, window = self.pending, self.loads, self.window_s
        ja, la = np.flatnonzero(ok_j), np.flatnonzero(ok_l)
        if window == 0 or not loads or len(loads) + la.size > loads.maxlen:
            return None
        first = pending[0][3] if pending else (float(jnow[ja[0]]) if ja.size else None)
        last = max(float(jnow[ja[-1]]) if ja.size else -math.inf, float(lnow[la[-1]]) if la.size else -math.inf)
        if first is not None and last - first > window:
            return None
        end_t = int(lt[la[-1]]) if la.size else load_t
        st = np.array([e[0] for e in loads] + lt[la].tolist(), dtype=np.int64)
        sw = np.array([e[1] for e in loads] + lw[la].tolist(), dtype=float)
        t = np.concatenate((np.array([p[0] for p in pending], dtype=np.int64), jt[ja]))
        x = np.concatenate((np.array([p[1] for p in pending], dtype=float), jx[ja]))
        now = [p[3] for p in pending] + jnow[ja].tolist()
        k = int(np.searchsorted(t, end_t, side="left"))          # stamped before the latest load
        idx = np.searchsorted(st, t[:k], side="right") - 1
        w = np.where(idx >= 0, sw[np.maximum(idx, 0)], math.nan)
        keep = int(idx[-1]) if k and idx[-1] > 0 else 0
        self.loads = deque(zip(st[keep:].tolist(), sw[keep:].tolist()), maxlen=loads.maxlen)
        self.pending = deque(zip(t[k:].tolist(), x[k:].tolist(), [0.0] * (t.size - k), now[k:]))
        return t[:k], x[:k], w

    def _align(self, ok_j, jt, jx, jnow, ok_l, lt, lw, lnow, lpos, load_t, axis_n):
        """joint()/load()/flush_aged() decisions in arrival order, the integration deferred: the samples
        in integration order with the axis load at their stamp (NaN when it is the guides' own latest:
        ``own`` lists (index, loads handled before) of those)."""
        pending, loads, window = self.pending, self.loads, self.window_s
        out_t, out_x, out_w, own = [], [], [], []
        load_at = self.load_at

        def emit(t, x, count):
            w = load_at(t)
            if w is None:
                own.append((len(out_t), count))
                w = math.nan
            out_t.append(t)
            out_x.append(x)
            out_w.append(w)

        def aged(now, count):
            cutoff = now - window
            while pending and pending[0][3] < cutoff:
                t, x = pending.popleft()[:2]
                emit(t, x, count)

        j, n_j = 0, len(jt)
        for i in range(len(lt) + 1):
            stop = lpos[i] if i < len(lt) else n_j
            while j < stop:
                if ok_j[j]:
                    t, now = jt[j], jnow[j]
                    if window == 0 or (not pending and load_t is not None and t < load_t):
                        emit(t, jx[j], i)
                    else:
                        pending.append((t, jx[j], 0.0, now))
                    if pending and now - pending[0][3] > window:
                        aged(now, i)
                j += 1
            if i < len(lt) and ok_l[i]:
                t, now = lt[i], lnow[i]
                while pending and pending[0][0] < t:
                    pt, px = pending.popleft()[:2]
                    emit(pt, px, i)
                if not loads and load_t is not None:
                    loads.append((load_t, axis_n))          # the axis's latest load before this feed's first
                loads.append((t, lw[i]))
                load_t, axis_n = t, lw[i]
                if pending and now - pending[0][3] > window:
                    aged(now, i + 1)
        return out_t, out_x, out_w, own


def _latest_after(accepted, load_n, before: float, counts):
    """The axis's latest accepted load [N] once the first ``counts`` loads of the batch were handled."""
    ok = np.flatnonzero(accepted)
    k = np.searchsorted(ok, counts, side="left") - 1
    return np.where(k >= 0, load_n[ok[np.maximum(k, 0)]] if ok.size else math.nan, before)


def _reasons(joint_codes, load_codes, load_after) -> list[str]:
    """The rejection reasons of a batch in arrival order (as joint()/load() return them)."""
    bad = [(j, 1, REASON_CODES[c]) for j, c in zip(np.flatnonzero(joint_codes).tolist(),
                                                     joint_codes[joint_codes != 0].tolist())]
    bad += [(load_after[i], 0, REASON_CODES[c]) for i, c in zip(np.flatnonzero(load_codes).tolist(),
                                                                load_codes[load_codes != 0].tolist())]
    return [reason for *_, reason in sorted(bad, key=lambda b: b[:2])]
