"""The wear effects ``diagnose`` learnt, integrated live (pure numpy, SI; the terms of effects.py).

With effects the wear volume is V = K/H sum_i W_i ds_i m_i (models/wear/effects.py, the same functions the
discrepancy workflow fits and the simulator hides), m_i = K(s)/K x asperity share x (W/W_ref)^(n-1) x rho on
retract strokes. :class:`EffectWear` receives every sliding segment of the
:class:`~guide_health.models.wear.archard.WearIntegrator` (its ``segment_sink``, the live per-sample path and
the vectorised offline path alike) and keeps

- the effective work G_eff = sum W ds m [N m] (what the online K update regresses on: K stays linear);
- stroke_distribution's pass work P = sum over passes of (W ds m) / max(L, L_s) [N] (a pass: a run of one
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

from guide_health.models.wear.effects import (
    LUBRICATION_SPEED_EXPONENT,
    WearEffects,
    asperity_load_share,
    running_in_factor_mean,
    wear_rate_multiplier,
)

#: the order of the model file's effect_covariance rows (13 x 13, SI; the 6 x 6, 9 x 9, 10 x 10 or 12 x 12 of
#: an older file is widened on loading, params/schema.py LIST_UPGRADES). ``lubrication_wear_growth`` is b [1/s]
#: (recorded relubrications) or a [-] (interval). thermal_drift's gauge term c_T (T - T_ref) enters as c_T and
#: the offset e of the gauge at T_ref (0 at the fitted values; its variance is the fit's uncertainty of the
#: gauge term where the temperature is T_ref): the correction with both moved is (c_T + dc) (T - T_ref) + de.
#: ``straightness_initial_m`` is A0 when the fit freed it (A0 not given, or initial_offset named): A0 + dA0
#: moves the straightness now and every measured rise over A0 (y_j - A0)
COVARIANCE_NAMES = ("wear_coefficient", "running_in_ratio", "running_in_distance_m", "retract_wear_factor",
                    "lift_speed_m_s", "load_exponent", "load_gradient_per_m", "wear_rate_change_factor",
                    "lubrication_wear_growth", "stroke_distribution_weight", "thermal_drift_m_per_k",
                    "thermal_gauge_offset_m", "straightness_initial_m")
_PHI = len(COVARIANCE_NAMES) - 1       # effect parameters phi (all but K)
#: where w, c_T, the gauge offset at T_ref and A0's deviation sit in phi
W_INDEX, C_T_INDEX, OFFSET_INDEX, A0_INDEX, B_INDEX = (COVARIANCE_NAMES.index(n) - 1 for n in (
    "stroke_distribution_weight", "thermal_drift_m_per_k", "thermal_gauge_offset_m", "straightness_initial_m",
    "lubrication_wear_growth"))
#: the phi whose multipliers set the present rate, in bucket-sum order (sums[3:9]), and b's place among them
RATE_PHI = slice(2, 8)
B_RATE_INDEX = B_INDEX - RATE_PHI.start
#: per bucket: work, effective work w/o running-in, distance, d(effective work)/d(rho, v_lift, n, g, f, b),
#: the pass work sum W ds m / max(L, L_s) w/o running-in (stroke_distribution)
_SUMS = 10
PASS_SUM = 9
#: lengths of the saved lists (a work gradient, a bucket row: index then sums, a measurement's gradient):
#: (now, earlier ones); a state of an earlier length is zero-padded on restore (the terms added since were zero
#: then: w, c_T, e and A0 have no work gradient, and the pass sums only count for stroke_distribution)
STATE_LIST_LENGTHS = {"work_gradient": (_PHI, 11, 9, 8, 5), "buckets": (1 + _SUMS, 10, 7),
                      "measurement_gradients": (_PHI, 11, 9, 8, 5), "pass_open_buckets": (2,)}


@dataclass(frozen=True)
class LiveEffects:
    """Effect parameters of the live model (wear_monitor parameters written by ``diagnose --out``)."""

    effects: tuple[str, ...]
    running_in_ratio: float = 0.0
    running_in_distance_m: float = 100.0
    retract_wear_factor: float = 1.0
    retract_sign: int = -1
    lift_speed_m_s: float = math.inf
    load_exponent: float = 1.0
    load_reference_n: float = 1000.0
    # load_along_rail: m = max(1 + g (x - x_ref), 0)
    load_gradient_per_m: float = 0.0
    load_reference_position_m: float = 0.0
    # wear_rate_change: m = f from the stamp t_c on [s since the epoch of the stamps]
    wear_rate_change_factor: float = 1.0
    wear_rate_change_stamp_s: float = math.inf
    # lubrication_interval: m = max(1 + b tau, 0) (tau: time since the last relubricate event, interval_s = 0)
    # or m = 1 + a ((t - t_ref) mod T) / T (relubricated every T from t_ref); lubrication_growth is b or a
    lubrication_growth: float = 0.0
    lubrication_interval_s: float = 0.0
    lubrication_reference_stamp_s: float = 0.0
    lubrication_forecast_interval_s: float = 0.0     # recorded form: the future relubrications' interval
    # thermal_drift (a term of the gauge reading): y = A + c_T (T - T_ref); the live model corrects each
    # straightness measurement by it before the K update
    thermal_drift_m_per_k: float = 0.0
    thermal_reference_c: float = 20.0
    # stroke_distribution: A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P], P = sum W ds m / max(L, L_s)
    # over passes of length L (effects.straightness_wear_m; L_s the slider length)
    stroke_distribution_weight: float = 0.0
    slider_length_m: float = 0.0
    covariance: tuple = ()             # len(COVARIANCE_NAMES)^2 numbers, row-major in that order

    @classmethod
    def from_params(cls, p: dict) -> LiveEffects | None:
        ids = tuple(e.strip() for e in str(p.get("effects", "")).split(",") if e.strip())
        if not ids:
            return None
        return cls(
            effects=ids,
            running_in_ratio=float(p["running_in_ratio"]) if "running_in" in ids else 0.0,
            running_in_distance_m=float(p["running_in_distance_m"]),
            retract_wear_factor=float(p["retract_wear_factor"]) if "retract_asymmetry" in ids else 1.0,
            retract_sign=1 if p.get("retract_direction", "-x") == "+x" else -1,
            lift_speed_m_s=(float(p["lift_speed_m_s"]) if "speed_dependent_wear" in ids and p["lift_speed_m_s"] > 0
                            else math.inf),
            load_exponent=float(p["load_exponent"]) if "load_exponent" in ids else 1.0,
            load_reference_n=float(p["load_reference_n"]),
            load_gradient_per_m=float(p.get("load_gradient_per_m", 0.0)) if "load_along_rail" in ids else 0.0,
            load_reference_position_m=float(p.get("load_reference_position_m", 0.0)),
            wear_rate_change_factor=(float(p.get("wear_rate_change_factor", 1.0)) if "wear_rate_change" in ids
                                     else 1.0),
            wear_rate_change_stamp_s=(float(p.get("wear_rate_change_stamp_s", math.inf))
                                      if "wear_rate_change" in ids else math.inf),
            lubrication_growth=(float(p.get("lubrication_wear_growth", 0.0)) if "lubrication_interval" in ids
                                else 0.0),
            lubrication_interval_s=float(p.get("lubrication_interval_s", 0.0)),
            lubrication_reference_stamp_s=float(p.get("lubrication_reference_stamp_s", 0.0)),
            lubrication_forecast_interval_s=float(p.get("lubrication_forecast_interval_s", 0.0)),
            thermal_drift_m_per_k=float(p.get("thermal_drift_m_per_k", 0.0)) if "thermal_drift" in ids else 0.0,
            thermal_reference_c=float(p.get("thermal_reference_c", 20.0)),
            stroke_distribution_weight=(float(p.get("stroke_distribution_weight", 0.0))
                                        if "stroke_distribution" in ids else 0.0),
            slider_length_m=float(p.get("slider_length_m", 0.0)),
            covariance=tuple(float(v) for v in p.get("effect_covariance", ())),
        )

    def phi(self) -> np.ndarray:
        """The effect parameters in COVARIANCE_NAMES order after K (v_lift 0 when absent; the gauge offset and
        A0 as deviations, 0)."""
        return np.array([self.running_in_ratio, self.running_in_distance_m, self.retract_wear_factor,
                         self.lift_speed_m_s if math.isfinite(self.lift_speed_m_s) else 0.0, self.load_exponent,
                         self.load_gradient_per_m, self.wear_rate_change_factor, self.lubrication_growth,
                         self.stroke_distribution_weight, self.thermal_drift_m_per_k, 0.0, 0.0])

    def wear_effects(self) -> WearEffects:
        return WearEffects(retract_wear_factor=self.retract_wear_factor, lift_speed_m_s=self.lift_speed_m_s,
                           load_exponent=self.load_exponent, load_reference_n=self.load_reference_n)

    def covariance_matrix(self) -> np.ndarray:
        n = len(COVARIANCE_NAMES)
        c = np.asarray(self.covariance, dtype=float)
        if c.size == 0:
            return np.zeros((n, n))
        if c.size != n * n:       # the schema widens an older file's (params/schema.py LIST_UPGRADES)
            raise ValueError(f"effect_covariance has {c.size} numbers, not {n * n}")
        return c.reshape(n, n)


def time_since_relubrication_s(e: LiveEffects, t_s, last_relubrication_s):
    """lubrication_interval's tau [s] at times t [s since the stamps' epoch]: (t - t_ref) mod T in the interval
    form, t - the last relubrication (``last_relubrication_s``, EffectWear.relubrication_base_s) in the
    recorded form; 0 before the reference."""
    if e.lubrication_interval_s > 0:
        return np.mod(np.maximum(t_s - e.lubrication_reference_stamp_s, 0.0), e.lubrication_interval_s)
    return np.maximum(t_s - last_relubrication_s, 0.0)


def duty_factor_terms(e: LiveEffects, t_s: np.ndarray, x_m: np.ndarray, last_relubrication_s: np.ndarray):
    """The duty multipliers of load_along_rail, wear_rate_change and lubrication_interval (effects.py) at
    segment mid-times t [s since the stamps' epoch] and mid-positions x [m]: (m, dm/dg, dm/df, dm/db)
    (``last_relubrication_s``: the recorded form's time base per segment)."""
    rail = 1.0 + e.load_gradient_per_m * (x_m - e.load_reference_position_m)
    m_rail = np.maximum(rail, 0.0)
    d_g = np.where(rail > 0, x_m - e.load_reference_position_m, 0.0)
    after = t_s >= e.wear_rate_change_stamp_s
    m_change = np.where(after, e.wear_rate_change_factor, 1.0)
    tau = time_since_relubrication_s(e, t_s, last_relubrication_s)
    d_b = tau / e.lubrication_interval_s if e.lubrication_interval_s > 0 else tau
    lube = 1.0 + e.lubrication_growth * d_b
    m_lube = np.maximum(lube, 0.0)          # a negative growth past the fitted gap: no negative wear
    d_b = np.where(lube > 0, d_b, 0.0)
    m = m_rail * m_change * m_lube
    dm_g = m_change * m_lube * d_g                  # d_g is 0 where the rail factor is clipped
    dm_f = np.where(after, m_rail * m_lube, 0.0)
    dm_b = m_rail * m_change * d_b
    return m, dm_g, dm_f, dm_b


@dataclass
class EffectWear:
    """Effective Archard work of a guide with :class:`LiveEffects` (state persisted with the monitor)."""

    effects: LiveEffects
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
    # lubrication_interval's time base (recorded form): the last relubricate event seen, and the first stamp
    # this guide integrated (the record's start, before the first event) [ns since the epoch]; None: not yet
    last_relubrication_ns: int | None = None
    first_t_ns: int | None = None
    # stroke_distribution's pass work on the present surface (effects.straightness_wear_m's P): a pass (a run of
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
    # thermal_drift: T - T_ref of the reading that corrected each measurement [K] (0 without the effect)
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
        m = wear_rate_multiplier(e.wear_effects(), speed, np.maximum(w, 1e-12), retract)
        # the duty effects at the segment's middle (time in s since the stamps' epoch, position)
        t_mid_s = 0.5 * (ta_ns + tb_ns) * 1e-9
        m_duty, dm_g, dm_f, dm_b = duty_factor_terms(e, t_mid_s, 0.5 * (xa + xb),
                                                     self.relubrication_base_s(t_mid_s))
        work = w * ds
        base = work * m                                      # without the duty factors
        eff = base * m_duty
        ri = running_in_factor_mean(s_a, s_a + ds, e.running_in_ratio, e.running_in_distance_m)
        self.effective_work_nm += float((eff * ri).sum())
        share = asperity_load_share(speed, e.lift_speed_m_s)
        d_rho = np.where(retract, eff / e.retract_wear_factor if e.retract_wear_factor else work * m_duty, 0.0)
        d_vl = (eff * (1.0 - share) * 2.0 * LUBRICATION_SPEED_EXPONENT / e.lift_speed_m_s
                if math.isfinite(e.lift_speed_m_s) else np.zeros_like(eff))
        d_n = eff * np.log(np.maximum(w, 1e-12) / e.load_reference_n)
        d_g, d_f, d_b = base * dm_g, base * dm_f, base * dm_b
        s0 = e.running_in_distance_m
        decay = np.exp(-(s_a + 0.5 * ds) / s0)               # at the segment's middle (a gradient only)
        grads = (eff * decay, eff * e.running_in_ratio * decay * (s_a + 0.5 * ds) / s0 ** 2,
                 d_rho * ri, d_vl * ri, d_n * ri, d_g * ri, d_f * ri, d_b * ri)
        for j, g in enumerate(grads):
            self.work_gradient[j] += float(g.sum())
        bucket = (tb_ns * 1e-9 // self.duty_bucket_s).astype(np.int64)
        uniq, inverse = np.unique(bucket, return_inverse=True)
        sums = [np.bincount(inverse, weights=v, minlength=uniq.size)
                for v in (work, eff, ds, d_rho, d_vl, d_n, d_g, d_f, d_b)]
        for i, b in enumerate(uniq.tolist()):
            row = self.buckets.setdefault(int(b), [0.0] * _SUMS)
            for j in range(len(sums)):
                row[j] += float(sums[j][i])
        self._add_passes(np.sign(xb - xa).astype(np.int64), ds, eff * ri, eff, bucket)
        newest = max(self.buckets)
        for b in [b for b in self.buckets if b <= newest - self.duty_buckets]:
            del self.buckets[b]

    def _add_passes(self, direction: np.ndarray, ds: np.ndarray, work_ri: np.ndarray, work: np.ndarray,
                    bucket: np.ndarray) -> None:
        """stroke_distribution's passes: segments in time order with their direction (+-1), length [m],
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
            row[PASS_SUM] = row[1] * weight

    def relubrication_base_s(self, t_s: np.ndarray) -> np.ndarray:
        """The recorded form's last relubrication at each time t [s since the epoch]: the latest of the last
        relubricate event seen, the guide's first stamp and (once reached) the model file's reference (the
        last relubrication of the record diagnose fitted, or its start)."""
        known = [v * 1e-9 for v in (self.last_relubrication_ns, self.first_t_ns) if v is not None]
        base = np.full_like(t_s, max(known) if known else -np.inf)
        ref = self.effects.lubrication_reference_stamp_s
        return np.where(t_s >= ref, np.maximum(base, ref), base)

    def relubricated(self, t_ns: int) -> None:
        """A relubricate maintenance event: lubrication_interval's time since relubrication restarts."""
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
        T - T_ref [K] of the temperature reading that corrected it (thermal_drift)."""
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
        self.work_gradient = _padded(state.get("work_gradient", []), _PHI)
        self.buckets = {int(row[0]): _padded(row[1:], _SUMS) for row in state["buckets"]}
        self.measurement_gradients = [_padded(g, _PHI) for g in state.get("measurement_gradients", [])]
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


def _padded(values, size: int) -> list[float]:
    """A saved row of sums or gradients, zero-padded to ``size`` (states saved before the duty effects had
    5 gradients and 6 bucket sums; the added terms were zero then)."""
    out = [float(v) for v in values][:size]
    return out + [0.0] * (size - len(out))
