"""Duty cells: a machine's motion and load reduced to what the wear effects depend on (numpy, SI).

Samples count by the input rules of the precision monitor (:mod:`guide_health.models.wear.input_rules`,
the same functions), so ``diagnose`` sees the data ``replay`` sees. Every pair of consecutive accepted
axis samples is a sliding segment: distance ds = |dx| of the positions after the sliding deadband
(:func:`guide_health.models.wear.archard.sliding_positions_m`, as in the live monitor), speed ds/dt,
load W = the latest accepted load
stamped at or before the segment's end sample, direction, and the length L of the pass (monotone run of
the axis) it belongs to; before the first accepted load the distance counts and the wear does not.
Segments are summed into cells of (time block, direction, speed bin, load bin): bins 10 % wide in log
speed and log load and blocks of ``block_s`` seconds, so every effect multiplier (models/wear/effects/),
evaluated at a cell's work-weighted means, is the segment sum to well below the measurement noise. A fine
cell belongs to the measurement interval of its work-weighted mean time (an error of at most half a block
of wear at a measurement); cells of one interval with the same direction and bins are then merged,
keeping the variance of the sliding distance for the running-in term. A 20 h bag at 50 Hz (3.6 M
segments) becomes a few thousand cells.

Streaming: :meth:`DutyCellAccumulator.add` takes consecutive :class:`MachineRun` chunks (as
``io.bag.reader.iter_machine_bag`` yields them) and carries the last accepted sample, load and measurement
and the unfinished pass to the next chunk, so memory is bounded by one chunk and the result does not
depend on chunking.

Wear resets (a regrind or a new rail, from the maintenance events) split the record into epochs: a new
surface, whose wear and sliding distance (the running-in term's s) start from zero at the reset. Time blocks
restart at each reset, so no cell spans one; each cell carries its epoch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from guide_health.analysis.rejections import InputTally
from guide_health.io.bag.bag_set import iter_source_chunks
from guide_health.models.wear.archard import sliding_positions_m
from guide_health.models.wear.effects import pass_weight_per_m
from guide_health.models.wear.input_rules import (
    NO_LIMITS,
    STRAIGHTNESS_WITHOUT_TIME_BASE,
    InputLimits,
    RejectionCounter,
    StampBase,
    accept_run,
    accept_straightness_samples,
    main_way_load_n,
)
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun

# per-cell sums: work-weighted where the name says *_w
_BIN_OFFSET = 2048        # log bins of speed and load packed into one int64 key with block and direction:
_BINS = 2 * _BIN_OFFSET   # key = ((block * 2 + retract) * _BINS + speed bin) * _BINS + load bin
_BLOCK_STRIDE = 2 * _BINS ** 2
_SUMS = ("work_nm", "distance_m", "pass_work_n", "t_w", "s_w", "s2_w", "ln_v_w", "ln_load_w", "x_w", "pass_len_w")


def _cell_keys(block: np.ndarray, retract: np.ndarray, v_bin: np.ndarray,
               w_bin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sorted unique keys, index of each segment's key) of the keys ((block * 2 + retract) * _BINS + v_bin)
    * _BINS + w_bin: what ``np.unique(keys, return_inverse=True)`` gives, without its sort of every
    segment when the keys of a chunk span a small box (a chunk covers a few hundred blocks and a few dozen
    speed and load bins): a count per box position instead (the same keys, in the same order, so the
    per-cell sums are the same numbers)."""
    n = block.size
    lo = [int(a.min()) for a in (block, v_bin, w_bin)]
    nb, nv, nw = (int(a.max()) - m + 1 for a, m in zip((block, v_bin, w_bin), lo))
    size = nb * 2 * nv * nw
    if size > 8 * n + 65536:
        keys = ((block * 2 + retract) * _BINS + v_bin) * _BINS + w_bin
        return np.unique(keys, return_inverse=True)
    box = (((block - lo[0]) * 2 + retract) * nv + (v_bin - lo[1])) * nw + (w_bin - lo[2])
    used = np.flatnonzero(np.bincount(box, minlength=size))
    rank = np.zeros(size, np.int64)
    rank[used] = np.arange(used.size)
    b, rest = np.divmod(used, 2 * nv * nw)
    r, rest = np.divmod(rest, nv * nw)
    v, w = np.divmod(rest, nw)
    uniq = (((b + lo[0]) * 2 + r) * _BINS + v + lo[1]) * _BINS + w + lo[2]
    return uniq, rank[box]


@dataclass
class DutyCells:
    """Cells and measurements of one run. Times are seconds from ``t0_ns``."""

    t0_ns: int
    interval: np.ndarray                # k: the cell's wear counts in measurements k, k+1, ... (sorted)
    direction: np.ndarray               # +1 / -1 (sign of dx) per cell
    work_nm: np.ndarray                 # sum W ds
    distance_m: np.ndarray              # sum ds
    pass_work_n: np.ndarray             # sum W ds / max(L, L_s)
    time_s: np.ndarray                  # work-weighted mean time
    sliding_distance_m: np.ndarray      # work-weighted mean cumulative sliding distance s
    sliding_distance_var_m2: np.ndarray # its work-weighted variance within the cell
    speed_m_s: np.ndarray               # exp(work-weighted mean ln v)
    load_n: np.ndarray                  # exp(work-weighted mean ln W)
    position_m: np.ndarray              # work-weighted mean segment mid-position
    pass_length_m: np.ndarray           # work-weighted mean pass length
    measurement_t_s: np.ndarray
    measurement_m: np.ndarray
    temperature_t_s: np.ndarray
    temperature_c: np.ndarray
    pass_lengths_m: np.ndarray          # every completed pass (for l_min, l_max)
    segments: int                       # sliding segments with a known load
    rejected_segments: int              # sliding segments before the first accepted load (no wear)
    total_distance_m: float
    duration_s: float
    metadata: dict = field(default_factory=dict)
    rejected_samples: dict = field(default_factory=dict)   # input samples rejected, by reason
    inputs: InputTally = field(default_factory=InputTally)  # samples read per input (shares of the rejections)
    epoch: np.ndarray | None = None     # per cell: the wear resets before it (None: no reset in the record)
    reset_t_s: np.ndarray = field(default_factory=lambda: np.zeros(0))    # the wear resets [s from t0]
    reset_straightness_m: np.ndarray = field(default_factory=lambda: np.zeros(0))   # after each (NaN: A0)

    @property
    def cells(self) -> int:
        return int(self.work_nm.size)


#: the DutyCells fields with one entry per cell (epoch: None without wear resets)
PER_CELL_FIELDS = ("interval", "direction", "work_nm", "distance_m", "pass_work_n", "time_s", "sliding_distance_m",
                   "sliding_distance_var_m2", "speed_m_s", "load_n", "position_m", "pass_length_m", "epoch")


class DutyCellAccumulator:
    """Builds :class:`DutyCells` from consecutive MachineRun chunks of one machine."""

    def __init__(self, slider_length_m: float, block_s: float = 30.0, log_bin: float = 0.1,
                 limits: InputLimits = NO_LIMITS,
                 sliding_deadband_m: float = WEAR_MONITOR_DEFAULTS["sliding_deadband_m"],
                 resets_ns=(), reset_straightness_m=(), load_share: float = 1.0):
        self.slider_length_m = float(slider_length_m)
        order = np.argsort(np.asarray(resets_ns, dtype=np.int64), kind="stable")
        self.resets_ns = np.asarray(resets_ns, dtype=np.int64)[order]     # wear resets (module text)
        self.reset_straightness_m = (np.asarray(reset_straightness_m, dtype=float)[order] if len(reset_straightness_m)
                                     else np.full(order.size, np.nan))
        self._reset_s_m = np.full(self.resets_ns.size, np.nan)   # cumulative sliding distance at each reset
        self._epoch_block = np.zeros(0, np.int64)               # first time block of each epoch after the first
        self.load_share = float(load_share)    # the measured guide's share of the axis load
        self.limits = limits                   # the input rules' plausibility limits (InputLimits.from_params)
        self._joint_base = StampBase()         # time bases of the joint and load streams
        self._load_base = StampBase()
        self.sliding_deadband_m = float(sliding_deadband_m)
        self._direction = 0                    # of motion after the last sample (sliding_positions_m)
        self.block_s = float(block_s)
        self.log_bin = float(log_bin)
        self.t0_ns: int | None = None
        self._last_t_ns: int | None = None
        self._last_x = math.nan
        self._last_load_t: int | None = None
        self._last_load = math.nan
        self._last_meas_t: int | None = None
        self._first_joint_t: int | None = None    # first accepted joint stamp: the time base
        self._s_m = 0.0                        # cumulative sliding distance
        self._carry: dict[str, np.ndarray] | None = None   # segments of the unfinished pass
        self._cell_parts: list[tuple[np.ndarray, dict]] = []
        self._meas_t: list[np.ndarray] = []
        self._meas_y: list[np.ndarray] = []
        self._temp_t: list[np.ndarray] = []
        self._temp_c: list[np.ndarray] = []
        self._passes: list[np.ndarray] = []
        self.segments = 0
        self.rejected = 0                      # segments without a known load
        self.rejected_samples = RejectionCounter()
        self.inputs = InputTally()
        self.metadata: dict = {}
        self._t_end_ns: int | None = None

    # --- input -----------------------------------------------------------------------------
    def add(self, run: MachineRun) -> None:
        """One chunk (in time order after the previous one)."""
        if run.metadata and not self.metadata:
            self.metadata = dict(run.metadata)
        self.inputs.add(run)
        stamps = [np.asarray(a, dtype=np.int64) for a in (run.joint_t_ns, run.load_t_ns, run.straightness_t_ns)]
        if self.t0_ns is None:
            firsts = [int(a[0]) for a in stamps if len(a)]
            if not firsts:
                return
            self.t0_ns = min(firsts)
        for a in stamps:
            if len(a):
                self._t_end_ns = max(self._t_end_ns or int(a[-1]), int(a[-1]))
        accepted = accept_run(run, self._joint_base, self._load_base, self._last_load, self.limits)
        self._joint_base, self._load_base = accepted.joints.base, accepted.loads.base
        # a measurement processed before any accepted joint sample has no time base: rejected, as in
        # PrecisionMonitor.process_run (joints up to a measurement's stamp, and all earlier chunks', come first)
        if self._first_joint_t is not None:
            based = np.ones(stamps[2].size, dtype=bool)
        elif accepted.joint_t_ns.size:
            self._first_joint_t = int(accepted.joint_t_ns[0])
            based = np.maximum.accumulate(stamps[2]) >= self._first_joint_t if stamps[2].size else np.ones(0, bool)
        else:
            based = np.zeros(stamps[2].size, dtype=bool)
        meas_t, meas_y = stamps[2][based], np.asarray(run.straightness_m, dtype=float)[based]
        measurements = accept_straightness_samples(meas_t, meas_y, self._last_meas_t, self.limits)
        self.rejected_samples.count_all({**accepted.rejected, **measurements.rejected})
        for _, _, reason in getattr(run, "rejected_messages", ()):   # messages the reader took no sample from
            self.rejected_samples.reject(reason)
        if not based.all():
            self.rejected_samples.count(STRAIGHTNESS_WITHOUT_TIME_BASE, int((~based).sum()))
        self._meas_t.append(meas_t[measurements.accepted])
        self._meas_y.append(meas_y[measurements.accepted])
        if self._meas_t[-1].size:
            self._last_meas_t = int(self._meas_t[-1][-1])
        self._temp_t.append(np.asarray(run.temperature_t_ns, dtype=np.int64))
        self._temp_c.append(np.asarray(run.temperature_c, dtype=float))
        if accepted.load_t_ns.size:
            self._last_load_t, self._last_load = int(accepted.load_t_ns[-1]), float(accepted.load_n[-1])
        if accepted.joint_t_ns.size:
            load = main_way_load_n(accepted.load_at_joint_n)
            self._add_segments(accepted.joint_t_ns, accepted.joint_position_m,
                               load * self.load_share if self.load_share != 1.0 else load)

    def _add_segments(self, jt: np.ndarray, x: np.ndarray, load: np.ndarray) -> None:
        """Segments ending at the accepted joint samples ``jt`` (stamps increasing, positions finite)."""
        if self._last_t_ns is not None:
            x, self._direction = sliding_positions_m(x, self._last_x, self._direction, self.sliding_deadband_m)
            t_all = np.concatenate(([self._last_t_ns], jt))
            x_all = np.concatenate(([self._last_x], x))
        else:
            rest, self._direction = sliding_positions_m(x[1:], float(x[0]), 0, self.sliding_deadband_m)
            x = np.concatenate((x[:1], rest))
            t_all, x_all = jt, x
        self._last_t_ns, self._last_x = int(jt[-1]), float(x[-1])
        if t_all.size < 2:
            return
        dt = np.diff(t_all) * 1e-9
        dx = np.diff(x_all)
        seg_load = load[-dx.size:]
        ds = np.abs(dx)
        moving = ds > 0
        unloaded = moving & np.isnan(seg_load)     # before the first accepted load
        self.rejected += int(unloaded.sum())
        s_start = self._s_m
        s_end = self._s_m + np.cumsum(ds)          # ds = 0 where the axis stands
        self._s_m = float(s_end[-1])
        epoch = self._epochs(t_all[1:], s_start, s_end)
        sel = np.flatnonzero(moving)
        self.segments += int(sel.size) - int(unloaded.sum())
        seg = {
            "t_s": (t_all[1:][sel] - self.t0_ns) * 1e-9,
            "ds": ds[sel],
            "dir": np.sign(dx[sel]).astype(np.int8),
            "speed": ds[sel] / dt[sel],
            "load": seg_load[sel],
            "s": (s_end[sel] - 0.5 * ds[sel] - np.concatenate(([0.0], self._reset_s_m))[epoch[sel]]
                  if self.resets_ns.size else s_end[sel] - 0.5 * ds[sel]),
            "epoch": epoch[sel],
            "x": 0.5 * (x_all[:-1][sel] + x_all[1:][sel]),
        }
        self._absorb(seg, final=False)

    def _epochs(self, t_end_ns: np.ndarray, s_start: float, s_end: np.ndarray) -> np.ndarray:
        """The epoch of each segment (the wear resets before its end sample: a segment ending at a reset
        slid on the old surface); records the sliding distance at every reset the segments reach."""
        if not self.resets_ns.size:
            return np.zeros(t_end_ns.size, np.int64)
        for i in np.flatnonzero(np.isnan(self._reset_s_m) & (self.resets_ns <= t_end_ns[-1])):
            before = int(np.searchsorted(t_end_ns, self.resets_ns[i], side="right"))
            self._reset_s_m[i] = s_end[before - 1] if before else s_start
        return np.searchsorted(self.resets_ns, t_end_ns, side="left").astype(np.int64)

    def _blocks(self, t_s: np.ndarray, epoch: np.ndarray) -> np.ndarray:
        """Time blocks of ``block_s`` seconds, restarted at each wear reset (epoch e's blocks follow the
        blocks of epoch e - 1), so no block spans a reset."""
        if not self.resets_ns.size:
            return np.floor(t_s / self.block_s).astype(np.int64)
        reset_s = (self.resets_ns - self.t0_ns) * 1e-9
        starts = [0]                       # first block of each epoch
        for e, r in enumerate(reset_s):
            origin = reset_s[e - 1] if e else 0.0
            starts.append(starts[-1] + int(np.floor(max(r - origin, 0.0) / self.block_s)) + 1)
        self._epoch_block = np.asarray(starts[1:], np.int64)
        origins = np.concatenate(([0.0], reset_s))
        return (np.asarray(starts, np.int64)[epoch]
                + np.floor(np.maximum(t_s - origins[epoch], 0.0) / self.block_s).astype(np.int64))

    def _absorb(self, seg: dict[str, np.ndarray], final: bool) -> None:
        if self._carry is not None:
            seg = {k: np.concatenate((self._carry[k], seg[k])) for k in seg}
            self._carry = None
        n = seg["ds"].size
        if n == 0:
            return
        change = np.flatnonzero(np.diff(seg["dir"]) != 0) + 1          # first segment of each new pass
        starts = np.concatenate(([0], change))
        if final:
            done = n
        else:
            done = int(starts[-1])                                     # the last pass may go on
            self._carry = {k: v[done:] for k, v in seg.items()}
            starts = starts[:-1]
        if done == 0:
            return
        ends = np.concatenate((starts[1:], [done]))
        pass_len = np.add.reduceat(seg["ds"][:done], starts)
        # the record's last pass is cut by its end, not completed: not a stroke (as the live StrokeTracker)
        self._passes.append(pass_len[:-1] if final else pass_len)
        seg_pass_len = np.repeat(pass_len, ends - starts)
        self._reduce({k: v[:done] for k, v in seg.items()}, seg_pass_len)

    def _reduce(self, seg: dict[str, np.ndarray], pass_len: np.ndarray) -> None:
        work = seg["load"] * seg["ds"]
        loaded = work > 0
        if not loaded.any():
            return
        kept = np.flatnonzero(loaded)
        # the loaded segments are mostly one run (all but those before the first load): a slice, not a copy
        take = slice(kept[0], kept[-1] + 1) if kept[-1] - kept[0] + 1 == kept.size else kept
        seg = {k: v[take] for k, v in seg.items()}
        pass_len, work = pass_len[take], work[take]
        ln_v, ln_w = np.log(seg["speed"]), np.log(seg["load"])
        block = self._blocks(seg["t_s"], seg["epoch"])
        v_bin = np.clip(np.floor(ln_v / self.log_bin).astype(np.int64) + _BIN_OFFSET, 0, _BINS - 1)
        w_bin = np.clip(np.floor(ln_w / self.log_bin).astype(np.int64) + _BIN_OFFSET, 0, _BINS - 1)
        uniq, inverse = _cell_keys(block, seg["dir"] < 0, v_bin, w_bin)
        values = {
            "work_nm": work, "distance_m": seg["ds"],
            "pass_work_n": work * pass_weight_per_m(pass_len, self.slider_length_m),
            "t_w": work * seg["t_s"], "s_w": work * seg["s"], "s2_w": work * seg["s"] ** 2,
            "ln_v_w": work * ln_v, "ln_load_w": work * ln_w,
            "x_w": work * seg["x"], "pass_len_w": work * pass_len,
        }
        sums = {k: np.bincount(inverse, weights=v, minlength=uniq.shape[0]) for k, v in values.items()}
        self._cell_parts.append((uniq, sums))

    # --- output ------------------------------------------------------------------------------
    def finish(self) -> DutyCells:
        """The cells, merged per measurement interval: a fine cell (block, direction, speed bin, load
        bin) joins the interval of its work-weighted mean time, and cells of one interval with the same
        direction and bins are summed (their sliding-distance spread is kept as a variance)."""
        if self._carry is not None:
            carry, self._carry = self._carry, None
            self._absorb(carry, final=True)
        t0 = self.t0_ns or 0
        mt = np.concatenate(self._meas_t) if self._meas_t else np.zeros(0, np.int64)
        my = np.concatenate(self._meas_y) if self._meas_y else np.zeros(0)
        tt = np.concatenate(self._temp_t) if self._temp_t else np.zeros(0, np.int64)
        tc = np.concatenate(self._temp_c) if self._temp_c else np.zeros(0)
        keep = np.isfinite(tc)
        tt, tc = tt[keep], tc[keep]
        o = np.argsort(tt, kind="stable")
        tt, tc = tt[o], tc[o]
        meas_t_s = (mt - t0) * 1e-9
        if self._cell_parts:
            keys = np.concatenate([k for k, _ in self._cell_parts])
            uniq, inverse = np.unique(keys, return_inverse=True)
            fine = {name: np.bincount(inverse, weights=np.concatenate([s[name] for _, s in self._cell_parts]),
                                      minlength=uniq.shape[0]) for name in _SUMS}
            # interval k: the first measurement at or after the cell's mean time
            interval = np.searchsorted(meas_t_s, fine["t_w"] / fine["work_nm"], side="left")
            # key = block * _BLOCK_STRIDE + (direction, speed bin, load bin): swap the block for the interval
            # (with wear resets: interval * epochs + the epoch of the cell's block)
            epochs = self.resets_ns.size + 1
            fine_epoch = np.searchsorted(self._epoch_block, uniq // _BLOCK_STRIDE, side="right")
            coarse = (interval.astype(np.int64) * epochs + fine_epoch) * _BLOCK_STRIDE + uniq % _BLOCK_STRIDE
            uniq2, inv2 = np.unique(coarse, return_inverse=True)
            sums = {name: np.bincount(inv2, weights=fine[name], minlength=uniq2.size) for name in _SUMS}
            direction = np.where((uniq2 // _BINS ** 2) % 2 == 1, -1, 1).astype(np.int8)
            cell_interval = (uniq2 // _BLOCK_STRIDE // epochs).astype(np.int64)
            cell_epoch = (uniq2 // _BLOCK_STRIDE) % epochs
        else:
            sums = {name: np.zeros(0) for name in _SUMS}
            direction = np.zeros(0, np.int8)
            cell_interval = np.zeros(0, np.int64)
            cell_epoch = np.zeros(0, np.int64)
        w = sums["work_nm"]

        def mean(name):
            return sums[name] / w

        s_mean = mean("s_w")
        return DutyCells(
            t0_ns=int(t0),
            interval=cell_interval,
            direction=direction,
            work_nm=w,
            distance_m=sums["distance_m"],
            pass_work_n=sums["pass_work_n"],
            time_s=mean("t_w"),
            sliding_distance_m=s_mean,
            sliding_distance_var_m2=np.maximum(mean("s2_w") - s_mean ** 2, 0.0),
            speed_m_s=np.exp(mean("ln_v_w")),
            load_n=np.exp(mean("ln_load_w")),
            position_m=mean("x_w"),
            pass_length_m=mean("pass_len_w"),
            measurement_t_s=meas_t_s,
            measurement_m=my,
            temperature_t_s=(tt - t0) * 1e-9,
            temperature_c=tc,
            pass_lengths_m=np.concatenate(self._passes) if self._passes else np.zeros(0),
            segments=self.segments,
            rejected_segments=self.rejected,
            total_distance_m=self._s_m,
            duration_s=((self._t_end_ns or t0) - t0) * 1e-9,
            metadata=self.metadata,
            rejected_samples=dict(self.rejected_samples),
            inputs=self.inputs,
            epoch=cell_epoch if self.resets_ns.size else None,
            reset_t_s=(self.resets_ns - t0) * 1e-9,
            reset_straightness_m=self.reset_straightness_m,
        )


def duty_cells_from_runs(runs, slider_length_m: float, block_s: float = 30.0,
                         limits: InputLimits = NO_LIMITS,
                         sliding_deadband_m: float = WEAR_MONITOR_DEFAULTS["sliding_deadband_m"]) -> DutyCells:
    """:class:`DutyCells` of an iterable of MachineRun chunks (or a single MachineRun)."""
    acc = DutyCellAccumulator(slider_length_m, block_s=block_s, limits=limits, sliding_deadband_m=sliding_deadband_m)
    if isinstance(runs, MachineRun):
        runs = [runs]
    for run in runs:
        acc.add(run)
    return acc.finish()


def bag_accumulator(params: dict, resets=()) -> DutyCellAccumulator:
    """The accumulator ``diagnose`` reads a bag with: slider length, input limits and deadband of ``params``;
    ``resets``: the axis's wear resets as (t_ns, straightness after [m], NaN: A0). An axis of a machine
    (``guide_load_shares``) counts the load of its most loaded guide, whose straightness the axis reports."""
    shares = params["guide_load_shares"] if params["axes"] else None
    return DutyCellAccumulator(params["slider_length_m"], limits=InputLimits.from_params(wear_axis_params(params)),
                               sliding_deadband_m=params["sliding_deadband_m"], resets_ns=[r[0] for r in resets],
                               reset_straightness_m=[r[1] for r in resets],
                               load_share=max(shares) if shares else 1.0)


def iter_bag_chunks(bag, params: dict, namespace: str | None = None, progress=None, topics: dict | None = None):
    """The MachineRun chunks of a machine bag (a path or an io.bag.bag_set.BagSet) that :func:`read_duty_cells`
    accumulates; ``topics``: an axis's {role: relative topic} (analysis.machine_replay.axis_topics)."""
    return iter_source_chunks(bag, joint=params["joint"], namespace=namespace, progress=progress, topics=topics)


def read_duty_cells(bag, params: dict, namespace: str | None = None, progress=None, resets=(),
                    topics: dict | None = None) -> tuple[DutyCells, int]:
    """Stream a machine bag into duty cells (memory bounded by one chunk); (cells, messages read)."""
    acc = bag_accumulator(params, resets)
    messages = 0
    for chunk in iter_bag_chunks(bag, params, namespace, progress, topics):
        acc.add(chunk)
        messages += chunk.messages
    return acc.finish(), messages
