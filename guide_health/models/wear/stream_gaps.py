"""Samples missing from a fixed-rate input stream, estimated from the gaps in its header stamps.

A reliable KEEP_LAST writer overwrites the samples a slow reader has not taken yet; DDS reports no loss
for that (no message_lost event, and the reader sees no sequence-number gap without message info), so
the only trace left is a stamp gap in a stream whose driver stamps at a fixed rate (every joint_states
and load driver). :class:`StampGaps` learns the nominal sample period of one stream and counts the
samples that should have come between two accepted stamps (docs/ros.md "QoS").

The rule, on the stamps of accepted samples only (bad, duplicate or backward stamps are the input rules'
business, guide_health.models.wear.input_rules; a stamp <= the latest one is ignored here too):

- the stamp differences dt are collected in blocks of ``block`` (odd) differences; the period estimate of
  a block is its median (robust against the gaps themselves while fewer than half of a block's
  differences are gaps);
- a block is judged when the next one is complete, against the reference period
  ``T = max(median of the block before, of the block, of the block after)``, so a rate change is learnt
  without counting the slower samples of the new rate as loss. Warm-up: nothing is counted before the
  first ``block`` differences; then their own gaps count too (after the fact);
- a difference dt longer than both ``max_pause_s`` and ``pause_periods x T`` is a pause (the stream
  stopped: a machine at rest, a restarted driver), not loss. Both, because a reader that stalls for a
  tenth of a second under KEEP_LAST loses a thousand samples of a 10 kHz stream in one gap, while a 1 Hz
  load stream missing two samples has a 3 s gap;
- any other difference with ``dt > gap_factor x T`` is a gap of ``round(dt / T) - 1`` missing samples (at
  least 1). The factor 1.75 tolerates stamp jitter up to +-37 % of the period (dt < 1.75 T) and still
  sees a single missing sample without jitter (dt = 2 T).

:meth:`StampGaps.add` (live, per sample) and :meth:`StampGaps.add_many` (offline, an array) give the same
state for the same stamps. ``missing`` adds a provisional count of the blocks not judged yet (each
against the latest estimate), so it is complete at the end of a run.

Blind spots: samples lost at the end of a stream (no later stamp shows the gap); a gap of one sample when
the stamps jitter by more than +-12.5 % of the period (dt can fall below 1.75 T); one run of loss longer
than ``max_pause_s`` and ``pause_periods`` periods (a pause); loss of more than half of the samples spread
evenly (the medians then are multiples of the period).
"""
from __future__ import annotations

import numpy as np

BLOCK = 31                 # stamp differences per period estimate (odd: the median is one of them)
GAP_FACTOR = 1.75          # dt > GAP_FACTOR x period: samples missing
PAUSE_PERIODS = 50.0       # dt > PAUSE_PERIODS x period and dt > MAX_PAUSE_S: a pause, not loss
MAX_PAUSE_S = 1.0


def judge(dt_ns: np.ndarray, period_ns: int, gap_factor: float = GAP_FACTOR, pause_periods: float = PAUSE_PERIODS,
          max_pause_ns: int = int(MAX_PAUSE_S * 1e9)) -> np.ndarray:
    """[samples missing, gaps, pauses] in the stamp differences ``dt_ns`` [ns] of a stream of period
    ``period_ns`` (module text)."""
    if period_ns <= 0 or dt_ns.size == 0:
        return np.zeros(3, dtype=np.int64)
    return judge_rows(dt_ns[None, :], np.array([period_ns]), gap_factor, pause_periods, max_pause_ns)


def judge_rows(dt_ns: np.ndarray, period_ns: np.ndarray, gap_factor: float = GAP_FACTOR,
               pause_periods: float = PAUSE_PERIODS, max_pause_ns: int = int(MAX_PAUSE_S * 1e9)) -> np.ndarray:
    """:func:`judge` summed over the rows of ``dt_ns``, row i against ``period_ns[i]`` (> 0)."""
    ratio = dt_ns / period_ns.astype(float)[:, None]
    pause = (ratio > pause_periods) & (dt_ns > max_pause_ns)
    gaps = ratio[(ratio > gap_factor) & ~pause]
    return np.array([np.maximum(np.rint(gaps) - 1.0, 1.0).sum(), gaps.size, pause.sum()], dtype=np.int64)


class StampGaps:
    """The missing-sample estimate of one stream (module text)."""

    def __init__(self, block: int = BLOCK, gap_factor: float = GAP_FACTOR, pause_periods: float = PAUSE_PERIODS,
                 max_pause_s: float = MAX_PAUSE_S):
        if block < 3 or block % 2 == 0:
            raise ValueError("block must be odd and >= 3")
        if not 1.5 <= gap_factor < pause_periods:
            raise ValueError("need 1.5 <= gap_factor < pause_periods")
        self.block, self.gap_factor, self.pause_periods = int(block), float(gap_factor), float(pause_periods)
        self.max_pause_ns = int(max_pause_s * 1e9)
        self.last_t_ns: int | None = None
        self.open: list[int] = []                   # differences of the block being filled
        self.waiting: np.ndarray | None = None      # the last complete block, judged when the next completes
        self.waiting_period_ns = 0
        self.before_period_ns = 0                   # median of the block before it (0: none)
        self.judged = np.zeros(3, dtype=np.int64)   # [missing, gaps, pauses] of the judged blocks

    @property
    def period_ns(self) -> int:
        """The latest period estimate [ns] (0 before the first ``block`` differences)."""
        return self.waiting_period_ns

    def add(self, t_ns: int) -> None:
        """The stamp [ns] of an accepted sample."""
        last = self.last_t_ns
        if last is None or t_ns > last:
            self.last_t_ns = int(t_ns)
        if last is None or t_ns <= last:
            return
        self.open.append(int(t_ns) - last)
        if len(self.open) == self.block:
            self._close(np.asarray(self.open, dtype=np.int64))
            self.open = []

    def add_many(self, t_ns) -> None:
        """The stamps [ns] of accepted samples, in arrival order: the state :meth:`add` of each would give."""
        t = np.asarray(t_ns, dtype=np.int64)
        if t.size == 0:
            return
        if self.last_t_ns is not None:
            t = np.concatenate(([self.last_t_ns], t))
        top = np.maximum.accumulate(t)             # the latest stamp before each sample (add's last_t_ns)
        self.last_t_ns = int(top[-1])
        dt = t[1:] - top[:-1]
        dt = dt[dt > 0]
        need = self.block - len(self.open)
        if dt.size < need:
            self.open.extend(dt.tolist())
            return
        full = (dt.size - need) // self.block * self.block
        first = np.concatenate((np.asarray(self.open, dtype=np.int64), dt[:need]))
        self._close_many(np.vstack((first, dt[need:need + full].reshape(-1, self.block))))
        self.open = dt[need + full:].tolist()

    def _close_many(self, blocks: np.ndarray) -> None:
        """:meth:`_close` of each row of ``blocks`` in turn, vectorised (the same numbers)."""
        medians = np.median(blocks, axis=1).astype(np.int64)
        if self.waiting is not None:
            blocks = np.vstack((self.waiting[None, :], blocks))
            medians = np.concatenate(([self.waiting_period_ns], medians))
        if medians.size > 1:            # every block but the last is judged (before the first: 0, none)
            before = np.concatenate(([self.before_period_ns], medians[:-2]))
            ref = np.maximum(np.maximum(before, medians[:-1]), medians[1:])
            self.judged += judge_rows(blocks[:-1], ref, self.gap_factor, self.pause_periods, self.max_pause_ns)
            self.before_period_ns = int(medians[-2])
        self.waiting, self.waiting_period_ns = blocks[-1].copy(), int(medians[-1])

    def _close(self, block_dt: np.ndarray) -> None:
        period = sorted(block_dt.tolist())[self.block // 2]        # the median (odd block)
        if self.waiting is not None:
            ref = max(self.before_period_ns, self.waiting_period_ns, period)
            self.judged += self._judge(self.waiting, ref)
            self.before_period_ns = self.waiting_period_ns
        self.waiting, self.waiting_period_ns = block_dt, period

    def _judge(self, dt_ns: np.ndarray, period_ns: int) -> np.ndarray:
        return judge(dt_ns, period_ns, self.gap_factor, self.pause_periods, self.max_pause_ns)

    def counts(self) -> np.ndarray:
        """[missing, gaps, pauses] so far: the judged blocks plus a provisional judgement of the rest
        (against the latest estimate)."""
        if self.waiting is None:
            return self.judged.copy()
        ref = max(self.before_period_ns, self.waiting_period_ns)
        return (self.judged + self._judge(self.waiting, ref)
                + self._judge(np.asarray(self.open, dtype=np.int64), self.waiting_period_ns))

    @property
    def judged_missing(self) -> int:
        return int(self.judged[0])

    @property
    def missing(self) -> int:
        """Samples missing so far (:meth:`counts`)."""
        return int(self.counts()[0])

    @property
    def gaps(self) -> int:
        return int(self.counts()[1])

    @property
    def pauses(self) -> int:
        return int(self.counts()[2])


class StreamGaps:
    """The estimates of the joint and load streams of one guide; ``values()`` its status keys."""

    def __init__(self, **kwargs):
        self.joint = StampGaps(**kwargs)
        self.load = StampGaps(**kwargs)

    def values(self) -> dict:
        joint, load = self.joint.missing, self.load.missing
        return {"samples_missing_estimate": joint + load, "joint_samples_missing_estimate": joint,
                "load_samples_missing_estimate": load, "joint_period_estimate_us": self.joint.period_ns * 1e-3,
                "joint_stamp_pauses": self.joint.pauses}

    def message(self) -> str:
        """'' or '37 samples missing (stamp gaps: joint_states 37, load 0)'."""
        joint, load = self.joint.missing, self.load.missing
        if joint + load == 0:
            return ""
        return f"{joint + load} samples missing (stamp gaps: joint_states {joint}, load {load})"
