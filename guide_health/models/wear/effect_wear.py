"""The wear effects ``diagnose`` learnt, integrated live (pure numpy, SI; the terms of models/wear/effects/).

With effects the wear volume is V = K/H sum_i W_i ds_i m_i (models/wear/effects/, the same functions the
discrepancy workflow fits and the simulator hides), m_i = K(s)/K x asperity share x (W/W_ref)^(n-1) x rho on
retract strokes. :class:`EffectWear` receives every sliding segment of the
:class:`~guide_health.models.wear.archard.WearIntegrator` (its ``segment_sink``, the live per-sample path and
the vectorised offline path alike) and keeps

- the effective work G_eff = sum W ds m [N m] (what the online K update regresses on: K stays linear);
- the pass work P = sum over passes of (W ds m) / max(L, L_s) [N] (a pass: a run of one
  direction of sliding, L its length, L_s the slider's; the straightness per unit K is
  [(1 - w) 2 G / (l_min + l_max) + w P] / (H b), effects.straightness_wear_m);
- per duty bucket (the integrator's buckets): the work, the effective work without running-in, the sliding
  distance, the work-weighted derivatives of m by rho, v_lift, n, g, f and b (for the interval), and the
  pass work without running-in (for the rate).

The remaining life with these effects and its interval: models/wear/effect_life.py.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from guide_health.models.wear.effects.base import LiveSegments
from guide_health.models.wear.effects.multiplier import combined_multiplier, wear_rate_multiplier
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import (
    BUCKET_LAYOUTS,
    BUCKET_ROW_LENGTHS,
    BUCKET_SUMS,
    DUTY_FACTORS,
    MATERIAL_FACTORS,
    PHI_INDEX,
    PHI_LAYOUTS,
    PHI_LENGTHS,
    PHI_NAMES,
    RELUBRICATION,
    SLIDING_DECAY,
    SUM_INDEX,
)

_PHI = len(PHI_NAMES)       # effect parameters phi (every covariance row but K)
_SUMS = len(BUCKET_SUMS)
PASS_SUM = SUM_INDEX["pass_work_n"]
#: lengths of the saved lists (a work gradient, a bucket row: index then sums, a measurement's gradient):
#: (now, earlier ones); a list of an earlier length is restored by name (registry.state_layouts), the terms added
#: since at 0 (they were zero then: the straightness and gauge terms and A0 have no work gradient, the pass sums
#: only count with a weighted pass work, an effect added later was at its no-effect value)
STATE_LIST_LENGTHS = {"work_gradient": PHI_LENGTHS, "buckets": BUCKET_ROW_LENGTHS,
                      "measurement_gradients": PHI_LENGTHS, "pass_open_buckets": (2,)}


def time_since_relubrication_s(e: EffectParameters, t_s, last_relubrication_s):
    """The relubrication duty factor's live tau [s] at times t [s since the stamps' epoch] with the parameters
    of ``e`` (registry.RELUBRICATION)."""
    return RELUBRICATION.live_tau_s(e, t_s, last_relubrication_s)


def duty_factor_terms(e: EffectParameters, t_s: np.ndarray, x_m: np.ndarray, last_relubrication_s: np.ndarray):
    """The duty multipliers (registry.DUTY_FACTORS, their live forms) at segment mid-times t [s since the stamps'
    epoch] and mid-positions x [m]: (m, {rate row name: dm/d(its parameter)}), m the product in DUTY_FACTORS
    order and dm/d(one) its own derivative times the others' product (``last_relubrication_s``: the recorded
    relubrications' time base per segment)."""
    terms = [f.live_duty_factor(e, t_s, x_m, last_relubrication_s) for f in DUTY_FACTORS]
    m = terms[0][0]
    for factor, _ in terms[1:]:
        m = m * factor
    dm = {}
    for i, effect in enumerate(DUTY_FACTORS):
        others = [factor for j, (factor, _) in enumerate(terms) if j != i]
        product = others[0]
        for factor in others[1:]:
            product = product * factor
        dm[effect.rate_row] = product * terms[i][1]     # 0 where the factor is clipped or not yet in force
    return m, dm


@dataclass
class EffectWear:
    """Effective Archard work of a guide with live :class:`EffectParameters` (state persisted with the monitor)."""

    effects: EffectParameters
    duty_bucket_s: float
    duty_buckets: int
    effective_work_nm: float = 0.0
    buckets: dict = field(default_factory=dict)       # bucket index -> [_SUMS sums]
    # d(effective work)/d(phi) over the whole history, phi = (r, s0, rho, v_lift, n, g, f, b) [N m per unit]
    work_gradient: list = field(default_factory=lambda: [0.0] * _PHI)
    # work_gradient at each straightness measurement (parallel to the estimator's measurements)
    measurement_gradients: list = field(default_factory=list)
    # the guide's sliding distance when the present surface was made (0, or at the last regrind / new rail):
    # running-in counts the distance slid on this surface [m]
    surface_start_m: float = 0.0
    # the relubrication factor's time base (recorded form): the last relubricate event seen, and the first stamp
    # this guide integrated (the record's start, before the first event) [ns since the epoch]; None: not yet
    last_relubrication_ns: int | None = None
    first_t_ns: int | None = None
    # the pass work on the present surface (effects.straightness_wear_m's P): a pass (a run of
    # one direction of sliding, as diagnose's duty cells count it) weighs 1 / max(L, L_s), known when it ends;
    # the open pass counts with its length so far. P of the ended passes [N] (with running-in), the open
    # pass's direction (+-1, 0 before any), length so far [m], effective work with running-in [N m] and
    # without it per duty bucket (added to the buckets' pass sums when it ends)
    pass_work_n: float = 0.0
    pass_direction: int = 0
    pass_length_m: float = 0.0
    pass_open_work_nm: float = 0.0
    pass_open_buckets: dict = field(default_factory=dict)
    # pass_work_now_n at each straightness measurement (parallel to measurement_gradients)
    measurement_pass_work_n: list = field(default_factory=list)
    # the gauge's temperature term: T - T_ref of the reading that corrected each measurement [K] (0 without the effect)
    measurement_temperature_offset_k: list = field(default_factory=list)

    def add_segments(self, t_start_ns, t_end_ns, xa_m, xb_m, load_n, s_start_m) -> None:
        """Sliding segments from xa to xb between the stamps, under load_n (NaN / 0: no wear), starting at
        cumulative sliding distance s_start [m]."""
        xa, xb = np.asarray(xa_m, dtype=float), np.asarray(xb_m, dtype=float)
        if xa.size == 0:
            return
        ta_ns = np.asarray(t_start_ns, dtype=np.int64)
        tb_ns = np.asarray(t_end_ns, dtype=np.int64)
        if self.first_t_ns is None:
            self.first_t_ns = int(ta_ns.min())
        ds = np.abs(xb - xa)
        w = np.nan_to_num(np.asarray(load_n, dtype=float))
        dt = (tb_ns - ta_ns) * 1e-9
        speed = np.divide(ds, dt, out=np.zeros_like(ds), where=dt > 0)
        e = self.effects
        retract = np.sign(xb - xa) == e.retract_sign
        s_a = np.maximum(np.asarray(s_start_m, dtype=float) - self.surface_start_m, 0.0)   # on this surface
        m = wear_rate_multiplier(e, speed, np.maximum(w, 1e-12), retract)
        # the duty effects at the segment's middle (time in s since the stamps' epoch, position)
        t_mid_s = 0.5 * (ta_ns + tb_ns) * 1e-9
        m_duty, dm_duty = duty_factor_terms(e, t_mid_s, 0.5 * (xa + xb), self.relubrication_base_s(t_mid_s))
        work = w * ds
        base = work * m                                      # without the duty factors
        eff = base * m_duty
        ri = SLIDING_DECAY.live_factor_mean(e, s_a, s_a + ds)
        work_ri = work * combined_multiplier(m, ri, m_duty)        # the effective work of each segment
        self.effective_work_nm += float(work_ri.sum())
        # d(effective work)/d(each rate parameter) without running-in (the duty buckets' sums)
        seg = LiveSegments(w, speed, retract, work, eff, m_duty)
        rate = {}
        for effect in MATERIAL_FACTORS:
            rate.update(effect.live_rate_gradients(e, seg))
        rate.update({name: base * d for name, d in dm_duty.items()})
        grads = SLIDING_DECAY.live_decay_gradients(e, eff, s_a, ds) | {n: g * ri for n, g in rate.items()}
        for name, g in grads.items():
            self.work_gradient[PHI_INDEX[name]] += float(g.sum())
        bucket = (tb_ns * 1e-9 // self.duty_bucket_s).astype(np.int64)
        uniq, inverse = np.unique(bucket, return_inverse=True)
        columns = {"work_nm": work, "effective_work_nm": eff, "distance_m": ds} | {f"d_{n}": g for n, g in rate.items()}
        sums = {SUM_INDEX[n]: np.bincount(inverse, weights=v, minlength=uniq.size) for n, v in columns.items()}
        for i, b in enumerate(uniq.tolist()):
            row = self.buckets.setdefault(int(b), [0.0] * _SUMS)
            for j, column in sums.items():
                row[j] += float(column[i])
        self._add_passes(np.sign(xb - xa).astype(np.int64), ds, work_ri, eff, bucket)
        newest = max(self.buckets)
        for b in [b for b in self.buckets if b <= newest - self.duty_buckets]:
            del self.buckets[b]

    def _add_passes(self, direction: np.ndarray, ds: np.ndarray, work_ri: np.ndarray, work: np.ndarray,
                    bucket: np.ndarray) -> None:
        """The passes of the pass work: segments in time order with their direction (+-1), length [m],
        effective work with and without running-in [N m] and duty bucket. A change of direction ends the
        open pass; the passes that end here add W ds m / max(L, L_s) to P and to their buckets' pass sums."""
        if int(direction[0]) != self.pass_direction:
            self._end_pass()
        if direction.size == 1:                         # the live per-sample path: the same, in plain Python
            b = int(bucket[0])
            self.pass_direction = int(direction[0])
            self.pass_length_m += float(ds[0])
            self.pass_open_work_nm += float(work_ri[0])
            self.pass_open_buckets[b] = self.pass_open_buckets.get(b, 0.0) + float(work[0])
            return
        starts = np.concatenate(([0], np.flatnonzero(direction[1:] != direction[:-1]) + 1))
        lengths = np.add.reduceat(ds, starts)
        works = np.add.reduceat(work_ri, starts)
        lengths[0] += self.pass_length_m
        works[0] += self.pass_open_work_nm
        ended = starts.size - 1                         # passes [0, ended) end in this call
        if ended:
            weight = 1.0 / np.maximum(lengths[:ended], self.effects.slider_length_m)
            self.pass_work_n += float(works[:ended] @ weight)
            self._add_pass_sums(self.pass_open_buckets, float(weight[0]))
            cut = int(starts[-1])
            seg_weight = np.repeat(weight, np.diff(starts))
            uniq, inverse = np.unique(bucket[:cut], return_inverse=True)
            self._add_pass_sums(dict(zip(uniq.tolist(), np.bincount(inverse, work[:cut] * seg_weight).tolist())), 1.0)
            self.pass_open_buckets = {}
        else:
            cut = 0
        uniq, inverse = np.unique(bucket[cut:], return_inverse=True)
        for b, v in zip(uniq.tolist(), np.bincount(inverse, work[cut:]).tolist()):
            self.pass_open_buckets[int(b)] = self.pass_open_buckets.get(int(b), 0.0) + v
        self.pass_direction = int(direction[-1])
        self.pass_length_m = float(lengths[-1])
        self.pass_open_work_nm = float(works[-1])

    def _end_pass(self) -> None:
        """The open pass ended (a change of direction): its work joins P and its buckets' pass sums."""
        weight = self._open_pass_weight()
        if weight:
            self.pass_work_n += self.pass_open_work_nm * weight
            self._add_pass_sums(self.pass_open_buckets, weight)
        self.pass_length_m, self.pass_open_work_nm, self.pass_open_buckets = 0.0, 0.0, {}

    def _add_pass_sums(self, work_by_bucket: dict, weight: float) -> None:
        for b, v in work_by_bucket.items():
            row = self.buckets.get(int(b))
            if row is not None:                       # (a bucket older than the duty window is gone)
                row[PASS_SUM] += v * weight

    def _open_pass_weight(self) -> float:
        return 1.0 / max(self.pass_length_m, self.effects.slider_length_m) if self.pass_length_m > 0 else 0.0

    def pass_work_now_n(self) -> float:
        """P now [N]: the ended passes' and the open pass's with its length so far."""
        return self.pass_work_n + self.pass_open_work_nm * self._open_pass_weight()

    def estimate_pass_work(self, pass_length_m: float) -> None:
        """For a state saved without the pass work: P = G / max(L, L_s) and each duty
        bucket's pass sum its effective work over it, L the mean stroke (exact for strokes of one length)."""
        length = max(pass_length_m, self.effects.slider_length_m)
        weight = 1.0 / length if length > 0 else 0.0
        self.pass_work_n = self.effective_work_nm * weight
        for row in self.buckets.values():
            row[PASS_SUM] = row[SUM_INDEX["effective_work_nm"]] * weight

    def relubrication_base_s(self, t_s: np.ndarray) -> np.ndarray:
        """The recorded form's last relubrication at each time t [s since the epoch]: the latest of the last
        relubricate event seen, the guide's first stamp and (once reached) the model file's reference (the
        last relubrication of the record diagnose fitted, or its start)."""
        known = [v * 1e-9 for v in (self.last_relubrication_ns, self.first_t_ns) if v is not None]
        base = np.full_like(t_s, max(known) if known else -np.inf)
        ref = RELUBRICATION.reference_stamp_s(self.effects)
        return np.where(t_s >= ref, np.maximum(base, ref), base)

    def relubricated(self, t_ns: int) -> None:
        """A relubricate maintenance event: the time since relubrication restarts (registry.RELUBRICATION)."""
        self.last_relubrication_ns = int(t_ns)

    def window_sums(self, last_t_ns: int | None) -> np.ndarray:
        """The bucket sums over the duty window ending at ``last_t_ns``."""
        if last_t_ns is None or not self.buckets:
            return np.zeros(_SUMS)
        now = int(last_t_ns * 1e-9 // self.duty_bucket_s)
        rows = [v for b, v in self.buckets.items() if b > now - self.duty_buckets]
        sums = np.sum(rows, axis=0) if rows else np.zeros(_SUMS)
        # the open pass with its length so far
        weight = self._open_pass_weight()
        sums[PASS_SUM] += sum(v * weight for b, v in self.pass_open_buckets.items() if b > now - self.duty_buckets)
        return sums

    def new_surface(self, sliding_distance_m: float) -> None:
        """The worn surface made new at the guide's sliding distance (regrind, new rail): its effective work
        and gradients restart and so does running-in (a fresh scraped or ground surface runs in again); the
        duty buckets are kept (they describe the machine's use)."""
        self.surface_start_m = float(sliding_distance_m)
        self.effective_work_nm = 0.0
        self.work_gradient = [0.0] * len(self.work_gradient)
        self.measurement_gradients = []
        self.pass_work_n, self.pass_open_work_nm = 0.0, 0.0   # the open pass goes on, on the new surface
        self.measurement_pass_work_n = []
        self.measurement_temperature_offset_k = []

    def on_measurement(self, temperature_offset_k: float = 0.0) -> None:
        """A straightness measurement was taken now: keep the work gradient and pass work it saw, and the
        T - T_ref [K] of the temperature reading that corrected it (registry.GAUGE_TEMPERATURE)."""
        self.measurement_gradients.append(list(self.work_gradient))
        self.measurement_pass_work_n.append(self.pass_work_now_n())
        self.measurement_temperature_offset_k.append(float(temperature_offset_k))

    def rebuild_temperature_offsets(self, measurement_t_ns: list, first_reading_t_ns: int, offset_at_k) -> None:
        """A state saved without the T - T_ref of each measurement has NaN there, which leaves
        c_T and the gauge offset out of the interval: rebuilt by ``offset_at_k(stamp)`` (the reading in force)
        where the kept readings reach back to the measurement (older readings only are trimmed, so the one in
        force is then among them)."""
        offsets = self.measurement_temperature_offset_k
        if len(offsets) != len(measurement_t_ns):
            return
        for j, (offset, t_ns) in enumerate(zip(offsets, measurement_t_ns)):
            if math.isnan(offset) and t_ns >= first_reading_t_ns:
                offsets[j] = offset_at_k(t_ns)

    def state(self) -> dict:
        return {"effective_work_nm": self.effective_work_nm, "work_gradient": list(self.work_gradient),
                "buckets": [[b, *v] for b, v in sorted(self.buckets.items())],
                "measurement_gradients": [list(g) for g in self.measurement_gradients],
                "surface_start_m": self.surface_start_m,
                "last_relubrication_t_ns": self.last_relubrication_ns, "first_sample_t_ns": self.first_t_ns,
                "pass_work_n": self.pass_work_n, "pass_direction": self.pass_direction,
                "pass_length_m": self.pass_length_m, "pass_open_work_nm": self.pass_open_work_nm,
                "pass_open_buckets": [[b, v] for b, v in sorted(self.pass_open_buckets.items())],
                "measurement_pass_work_n": list(self.measurement_pass_work_n),
                "measurement_temperature_offset_k": list(self.measurement_temperature_offset_k)}

    def restore(self, state: dict) -> None:
        self.effective_work_nm = float(state["effective_work_nm"])
        self.work_gradient = by_name(state.get("work_gradient", []), PHI_LAYOUTS, PHI_NAMES)
        self.buckets = {int(row[0]): by_name(row[1:], BUCKET_LAYOUTS, BUCKET_SUMS) for row in state["buckets"]}
        self.measurement_gradients = [by_name(g, PHI_LAYOUTS, PHI_NAMES)
                                      for g in state.get("measurement_gradients", [])]
        self.surface_start_m = float(state.get("surface_start_m", 0.0))
        last, first = state.get("last_relubrication_t_ns"), state.get("first_sample_t_ns")
        self.last_relubrication_ns = None if last is None else int(last)
        self.first_t_ns = None if first is None else int(first)
        # the pass work; a state saved without it has none: PrecisionMonitor.restore estimates P
        self.pass_work_n = float(state.get("pass_work_n", 0.0))
        self.pass_direction = int(np.sign(state.get("pass_direction", 0)))
        self.pass_length_m = float(state.get("pass_length_m", 0.0))
        self.pass_open_work_nm = float(state.get("pass_open_work_nm", 0.0))
        self.pass_open_buckets = {int(b): float(v) for b, v in state.get("pass_open_buckets", [])}
        # per measurement, parallel to measurement_gradients: NaN (not kept) for a state saved before them
        unknown = [math.nan] * len(self.measurement_gradients)
        self.measurement_pass_work_n = [float(v) for v in state.get("measurement_pass_work_n", unknown)]
        self.measurement_temperature_offset_k = [float(v) for v in state.get("measurement_temperature_offset_k",
                                                                              unknown)]


def by_name(values, layouts: dict[int, tuple[str, ...]], names: tuple[str, ...]) -> list[float]:
    """A saved row of sums or gradients in today's ``names``: its values named by the layout of its length
    (``layouts``: registry.PHI_LAYOUTS or BUCKET_LAYOUTS; state_schema accepts only those lengths), a name it does
    not hold at 0 (the term's value before its effect existed, or with an empty list: nothing yet)."""
    saved = dict(zip(layouts.get(len(values), ()), (float(v) for v in values)))
    return [saved.get(name, 0.0) for name in names]
