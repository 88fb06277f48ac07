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

The remaining life (seed 000 Eq. 12 from the present state) integrates the running-in decay forward:
A(t_now + T) - A(t_now) = K c [T + r s0 / v_s e^(-s/s0) (1 - e^(-v_s T / s0))], c = dA/dt per K at steady
wear of the present duty, v_s the present sliding speed (closed-form integral of K(s) = K (1 + r e^(-s/s0))).
Its interval (:func:`life_interval_s`) profiles K out, as the live model does: the effect parameters phi are
held at the model file's values and K is the online estimate K(phi) from the measurements. A change of phi
moves K(phi) (d K / d phi from the measurements' effective-work gradients, :func:`online_k_sensitivity`),
the straightness now and the rate; the life's variance is grad_phi' Sigma_phi grad_phi (Sigma_phi: the file's
marginal covariance of phi) plus (d life / d K)^2 var(K | phi) (the online update's posterior). With the
same measurements this equals the offline fit's joint delta method (the regression of K on phi is the
fit's Sigma_K,phi Sigma_phi^-1); unlike a fixed joint covariance it stays right when K is recalibrated on
later measurements and whatever stroke range maps the work to straightness (K's scale).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

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
#: the phi whose multipliers set the present rate, in bucket-sum order (sums[3:9])
_RATE_PHI = slice(2, 8)
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


def covariance_problem(values) -> str:
    """'' when ``values`` (row-major, COVARIANCE_NAMES order) is a covariance matrix: the right size, finite,
    variances >= 0, symmetric (1e-9 of sd_i sd_j) and positive semidefinite (no correlation beyond +-1: the
    correlation matrix's smallest eigenvalue >= -1e-6); else what is wrong, naming the parameters. A matrix
    that is none of these would give a narrowed or NaN interval without a word."""
    n = len(COVARIANCE_NAMES)
    c = np.asarray(values, dtype=float).ravel()
    if c.size != n * n:
        return f"has {c.size} numbers, not {n * n} ({n} x {n})"
    if not np.all(np.isfinite(c)):
        return "has non-finite entries"
    c = c.reshape(n, n)
    var = np.diag(c)
    for i in np.flatnonzero(var < 0):
        return f"the variance of {COVARIANCE_NAMES[i]} is negative ({var[i]:.3g})"
    sd = np.sqrt(var)
    bad = np.abs(c - c.T) > 1e-9 * np.outer(sd, sd)
    for i, j in zip(*np.nonzero(bad)):
        return (f"is not symmetric: ({COVARIANCE_NAMES[i]}, {COVARIANCE_NAMES[j]}) {c[i, j]:.3g} but "
                f"({COVARIANCE_NAMES[j]}, {COVARIANCE_NAMES[i]}) {c[j, i]:.3g}")
    kept = np.flatnonzero(var > 0)
    corr = c[np.ix_(kept, kept)] / np.outer(sd[kept], sd[kept])
    if kept.size and np.linalg.eigvalsh(corr).min() < -1e-6:
        off = np.abs(corr - np.eye(kept.size))
        i, j = np.unravel_index(int(np.argmax(off)), off.shape)
        return (f"is not positive semidefinite (largest correlation: {COVARIANCE_NAMES[kept[i]]} with "
                f"{COVARIANCE_NAMES[kept[j]]} {corr[i, j]:.3g})")
    return ""


def duty_factor_terms(e: LiveEffects, t_s: np.ndarray, x_m: np.ndarray, last_relubrication_s: np.ndarray):
    """The duty multipliers of load_along_rail, wear_rate_change and lubrication_interval (effects.py) at
    segment mid-times t [s since the stamps' epoch] and mid-positions x [m]: (m, dm/dg, dm/df, dm/db)
    (``last_relubrication_s``: the recorded form's time base per segment)."""
    rail = 1.0 + e.load_gradient_per_m * (x_m - e.load_reference_position_m)
    m_rail = np.maximum(rail, 0.0)
    d_g = np.where(rail > 0, x_m - e.load_reference_position_m, 0.0)
    after = t_s >= e.wear_rate_change_stamp_s
    m_change = np.where(after, e.wear_rate_change_factor, 1.0)
    if e.lubrication_interval_s > 0:
        tau = np.mod(np.maximum(t_s - e.lubrication_reference_stamp_s, 0.0), e.lubrication_interval_s)
        d_b = tau / e.lubrication_interval_s
    else:
        d_b = np.maximum(t_s - last_relubrication_s, 0.0)
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
        if self.pass_length_m > 0:
            weight = 1.0 / max(self.pass_length_m, self.effects.slider_length_m)
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
        """For a state saved before the pass work was kept (stop 12): P = G / max(L, L_s) and each duty
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
        # the pass work (stop 12); a state saved before it has none: PrecisionMonitor.restore estimates P
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


def running_in_extra_m_per_rate(horizon_s, ratio: float, distance_m: float, s_now_m: float,
                                sliding_speed_m_s: float):
    """int_0^T r e^(-(s + v_s t)/s0) dt = r s0 / v_s e^(-s/s0) (1 - e^(-v_s T/s0)) [s] (running-in's extra
    wear time per unit steady wear rate over a horizon T)."""
    if ratio == 0.0 or not sliding_speed_m_s > 0:
        return 0.0 * np.asarray(horizon_s, dtype=float)
    return (ratio * distance_m / sliding_speed_m_s * math.exp(-s_now_m / distance_m)
            * (1.0 - np.exp(-sliding_speed_m_s * np.asarray(horizon_s, dtype=float) / distance_m)))


def lubrication_multiplier_integral_s(horizon_s, growth_per_s: float, tau_now_s: float, interval_s: float):
    """int_0^T max(1 + b tau(u), 0) du [s]: lubrication_interval's wear multiplier (effects.py, m = max(1 + b
    tau, 0)) over a horizon T from now. tau(u) = tau_now + u until the next relubrication, due at interval -
    tau_now (now, when overdue), then 0 .. interval, every interval; interval 0: none expected. Closed form
    per relubrication cycle (the multiplier is linear in tau, clipped at 0 for a negative b)."""
    t = np.maximum(np.asarray(horizon_s, dtype=float), 0.0)
    cap = -1.0 / growth_per_s if growth_per_s < 0 else math.inf

    def seg(a, b):      # int_a^b max(1 + g tau, 0) dtau
        a, b = np.minimum(a, cap), np.minimum(b, cap)
        return (b - a) + growth_per_s * (b * b - a * a) / 2.0

    if not interval_s > 0:
        return seg(tau_now_s, tau_now_s + t)
    due = max(interval_s - tau_now_s, 0.0)
    first = seg(tau_now_s, tau_now_s + np.minimum(t, due))
    rest = np.maximum(t - due, 0.0)
    cycles = np.floor(rest / interval_s)
    return first + cycles * seg(0.0, interval_s) + seg(0.0, rest - cycles * interval_s)


def wear_time_s(horizon_s, ratio: float, distance_m: float, s_now_m: float, sliding_speed_m_s: float,
                lubrication: tuple | None = None):
    """E(T) [s] with A(t_now + T) - A(t_now) = (present rate) x E(T), the present rate that of the duty window
    (its steady dA/dt with the effects). Running-in decays on the way: E = T + extra(T)
    (:func:`running_in_extra_m_per_rate`). ``lubrication`` = (b [1/s], tau_now [s], interval [s], the window's
    mean multiplier m_w): the multiplier follows the relubrication schedule instead of staying at the window's,
    E = [M(T) + m(0) extra(T)] / m_w, M of :func:`lubrication_multiplier_integral_s` (the running-in extra
    weighted by the present multiplier: an approximation that matters only with both named, early in life)."""
    extra = running_in_extra_m_per_rate(horizon_s, ratio, distance_m, s_now_m, sliding_speed_m_s)
    if lubrication is None:
        return np.asarray(horizon_s, dtype=float) + extra
    growth, tau_now, interval, window_mean = lubrication
    m_now = max(1.0 + growth * tau_now, 0.0) if not interval > 0 or tau_now < interval else 1.0
    return (lubrication_multiplier_integral_s(horizon_s, growth, tau_now, interval) + m_now * extra) / window_mean


def remaining_life_with_running_in_s(margin_m: float, steady_rate_m_s: float, ratio: float, distance_m: float,
                                     s_now_m: float, sliding_speed_m_s: float,
                                     lubrication: tuple | None = None) -> float:
    """T with steady_rate E(T) = margin (:func:`wear_time_s`): the time to the limit with K(s) decaying and
    the lubrication multiplier following its schedule on the way (seed 000 Eq. 12 with the effects). 0 when
    the margin is used up; inf without wear (or when a negative lubrication growth stops it first)."""
    if not (math.isfinite(margin_m) and math.isfinite(steady_rate_m_s)):
        return math.nan
    if margin_m <= 0:
        return 0.0
    if steady_rate_m_s <= 0:
        return math.inf
    hi = float(margin_m / steady_rate_m_s)
    if lubrication is None and (ratio == 0.0 or not sliding_speed_m_s > 0):
        return hi

    def gap(t):
        return steady_rate_m_s * float(wear_time_s(t, ratio, distance_m, s_now_m, sliding_speed_m_s,
                                                   lubrication)) - margin_m

    lo = 0.0
    for _ in range(80):                 # E(T) grows at least like T m_min / m_w: bracket by doubling
        if gap(hi) >= 0:
            break
        lo, hi = hi, 2.0 * hi
    else:
        return math.inf
    return float(brentq(gap, lo, hi, xtol=1e-9 * hi))


def forecast_straightness_m(horizon_s: np.ndarray, straightness_now_m: float, steady_rate_m_s: float,
                            ratio: float, distance_m: float, s_now_m: float, sliding_speed_m_s: float,
                            lubrication: tuple | None = None) -> np.ndarray:
    """A(t_now + T) at the present duty with the running-in decay and the lubrication schedule [m] (the
    forecast curve)."""
    return straightness_now_m + steady_rate_m_s * wear_time_s(horizon_s, ratio, distance_m, s_now_m,
                                                              sliding_speed_m_s, lubrication)


def online_k_sensitivity(loss_per_k_m: np.ndarray, rise_m: np.ndarray, loss_gradient_m: np.ndarray, k: float,
                         k_sd: float, sigma_m: float, rise_gradient_m: np.ndarray | None = None) -> np.ndarray:
    """d K(phi) / d phi of the online K update (calibration.WearCoefficientEstimator: K = (K0 / v0 + sum g y /
    sigma^2) / P, P = 1 / v0 + sum g^2 / sigma^2 = 1 / k_sd^2) when the effect parameters phi change the
    measurements' losses per unit K g_j by dg_j / dphi (``loss_gradient_m``, one row per measurement) and the
    corrected readings y_j by dy_j / dphi (``rise_gradient_m``: the gauge terms; None = 0):
    dK = k_sd^2 / sigma^2 sum_j [dg_j (y_j - 2 K g_j) + g_j dy_j], y_j the measured rise over A0 [m]."""
    g = np.asarray(loss_per_k_m, dtype=float)
    dg = np.asarray(loss_gradient_m, dtype=float).reshape(g.size, -1)
    dy = np.zeros_like(dg) if rise_gradient_m is None else np.asarray(rise_gradient_m, dtype=float).reshape(dg.shape)
    y = np.asarray(rise_m, dtype=float)
    ok = np.isfinite(g) & np.isfinite(y) & np.all(np.isfinite(dg), axis=1) & np.all(np.isfinite(dy), axis=1)
    if not ok.any() or not sigma_m > 0:
        return np.zeros(dg.shape[1])
    return k_sd ** 2 / sigma_m ** 2 * (dg[ok].T @ (y[ok] - 2.0 * k * g[ok]) + dy[ok].T @ g[ok])


def life_interval_s(k: float, k_sd: float, e: LiveEffects, now: dict, z: float) -> tuple[float, float, float]:
    """(life, low, high) [s] of remaining life with the effects, and its interval: the delta method on ln life
    with K profiled (module text): the effect parameters phi = (r, s0, rho, v_lift, n, g, f, b, w, c_T, e, dA0;
    ``LiveEffects.phi``; the change time t_c, the interval T and the rail's x_ref are held) vary with the model
    file's marginal covariance, K follows as the online update would (``now["k_sensitivity"]`` = dK / dphi),
    and K's own spread given phi is the online posterior sd ``k_sd``.

    ``now``: margin0 = A_max - A0 [m]; work G = effective work [N m] and pass_work P [N] (stroke_distribution),
    with straightness per unit K and G, loss_work = 2 / (H b (l_min + l_max)) [m / (N m)], and per unit K and
    P, loss_pass = 1 / (H b) [m / N] (effects.straightness_wear_m: loss = (1 - w) loss_work G + w loss_pass P);
    work_gradient (d G / d phi; P moves in proportion), k_sensitivity (d K / d phi), rate_work_per_k and
    rate_pass_per_k (the two parts of the steady dA/dt per K [m/s]), dln_rate (d ln rate / d(rho, v_lift, n, g,
    f, b) at the present duty), s_now (distance of the present surface [m]), v_s [m/s], lubrication (None, or
    the relubrication schedule: growth_per_unit (b per unit of phi's b: 1, or 1 / T for the interval form),
    tau_now_s, interval_s, window_mean; :func:`wear_time_s`), a0_measured (A0 was set
    by a measurement after a regrind or a new rail: the file's A0 variance no longer applies). A change of phi
    moves the straightness now (through the past effective work and K, and A0 directly) and the rate."""
    phi0 = e.phi()
    dk = np.asarray(now.get("k_sensitivity", np.zeros(phi0.size)), dtype=float)
    work0, pass0 = now["work"], now.get("pass_work", 0.0)

    def life(k_: float, phi: np.ndarray) -> float:
        d = phi - phi0
        kk = k_ + float(np.dot(dk, d))
        w = phi[W_INDEX]
        work = work0 + float(np.dot(now["work_gradient"], d))
        passes = pass0 * work / work0 if work0 > 0 else pass0
        loss = (1.0 - w) * now["loss_work"] * work + w * now["loss_pass"] * passes
        rate_per_k = (1.0 - w) * now["rate_work_per_k"] + w * now.get("rate_pass_per_k", 0.0)
        rate = kk * rate_per_k * (1.0 + float(np.dot(now["dln_rate"], d[_RATE_PHI])))
        return remaining_life_with_running_in_s(now["margin0"] - d[A0_INDEX] - kk * loss, rate, phi[0],
                                                max(phi[1], 1e-9), now["s_now"], now["v_s"], schedule(phi, d))

    def schedule(phi: np.ndarray, d: np.ndarray) -> tuple | None:
        """The lubrication schedule with b moved: the window's mean multiplier moves with the window's rate
        (d ln rate / d b), the future multiplier with b itself."""
        lub = now.get("lubrication")
        if lub is None:
            return None
        dln_b = now["dln_rate"][B_INDEX - _RATE_PHI.start]
        return (phi[B_INDEX] * lub["growth_per_unit"], lub["tau_now_s"], lub["interval_s"],
                lub["window_mean"] * (1.0 + dln_b * d[B_INDEX]))

    centre = life(k, phi0)
    if not (math.isfinite(centre) and centre > 0):
        return centre, centre, centre
    cov = e.covariance_matrix()[1:, 1:].copy()
    if now.get("a0_measured", False):   # A0 measured after a regrind or a new rail: the file's A0 is not used
        cov[A0_INDEX, :] = cov[:, A0_INDEX] = 0.0

    def dln(h: float, i: int | None) -> float:
        phi = phi0.copy()
        if i is not None:
            phi[i] += h
        return (math.log(max(life(k + (h if i is None else 0.0), phi), 1e-30)) - math.log(centre)) / h

    grad = np.array([dln(1e-2 * math.sqrt(cov[i, i]), i) if cov[i, i] > 0 else 0.0 for i in range(phi0.size)])
    if not np.all(np.isfinite(grad)):
        # a hundredth of a parameter's sd already takes the life to no wear or to the limit: no linear interval
        return float(centre), 0.0, math.inf
    var = float(grad @ cov @ grad)
    if k_sd > 0:
        var += (dln(1e-2 * k_sd, None) * k_sd) ** 2
    sd = math.sqrt(max(var, 0.0))
    return float(centre), float(centre * math.exp(-z * sd)), float(centre * math.exp(z * sd))
