"""The precision-retention model of one guide: the single object behind the live node and offline replay.

It validates samples with :mod:`guide_health.models.wear.input_rules` (bad ones are rejected with a
reason and never change the state), integrates the Archard work
(:class:`~guide_health.models.wear.archard.WearIntegrator`), updates K from measured straightness
(:class:`~guide_health.models.wear.calibration.WearCoefficientEstimator`) and reports straightness, wear
and remaining precision life (seed 000 Eqs. 7, 10, 11, 12) with a 90 % interval.
"""
from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.special import stdtrit

from guide_health.models.levels import Level, exceeds, falls_below
from guide_health.models.wear.archard import (
    DUTY_BUCKETS,
    WearGeometry,
    WearIntegrator,
    straightness_from_wear_volume_m,
)
from guide_health.models.wear.calibration import Z90, WearCoefficientEstimator, remaining_life_s
from guide_health.models.wear.effect_life import (
    forecast_straightness_m,
    life_interval_s,
    lubrication_schedule,
    online_k_sensitivity,
    schedule_tuple,
)
from guide_health.models.wear.effect_wear import EffectWear
from guide_health.models.wear.effects import straightness_wear_m
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import PHI_INDEX, RATE_NAMES, RATE_SUMS, SUM_INDEX
from guide_health.models.wear.input_rules import (
    REASON_CODES,
    STRAIGHTNESS_WITHOUT_TEMPERATURE,
    STRAIGHTNESS_WITHOUT_TIME_BASE,
    TEMPERATURE_IMPLAUSIBLE,
    InputLimits,
    RejectionCounter,
    StampBase,
    accept_run,
    check_joint_sample,
    check_load_sample,
    check_straightness_sample,
    main_way_load_n,
    plausible_temperature,
    reading_in_force_index,
    rejected_key,
)
from guide_health.models.wear.stream_gaps import StreamGaps

STREAMS = ("joint_states", "guide/load")     # the inputs whose recent rejected share the status judges


#: guide/temperature readings kept for the thermal_drift correction (by stamp; a measurement takes the one in
#: force at its stamp, so a reading may arrive after the measurement it precedes)
TEMPERATURE_HISTORY = 4096


class PrecisionMonitor:
    """Sliding-guide precision monitor (parameters: guide_health.params.WEAR_MONITOR_DEFAULTS)."""

    STATE_VERSION = 1

    def __init__(self, params: dict[str, Any]):
        self.params = dict(params)
        self.geometry = WearGeometry.from_params(params)
        self.integrator = WearIntegrator(self.geometry)
        # the effects diagnose learnt (DIR/model.yaml): K stays linear over the effective work
        self.effects = EffectParameters.from_params(params)
        self.effect_wear = None
        self._attach_effects()
        self.estimator = WearCoefficientEstimator(
            prior_wear_coefficient=params["wear_coefficient"],
            prior_rel_sd=params["wear_coefficient_prior_rel_sd"],
            noise_sd_m=params["straightness_noise_m"],
            straightness_initial_m=params["straightness_initial_m"],
        )
        self.load_n = math.nan           # latest accepted load
        self.load_t_ns: int | None = None
        self.rejected = RejectionCounter()   # by reason; the node counts its message-level reasons here too
        self.limits = InputLimits.from_params(params)
        self.joint_base = StampBase()         # time bases of the joint and load streams (input_rules)
        self.load_base = StampBase()
        # the last rejected_window_samples samples of each stream: None (accepted) or the rejection reason
        window = int(params["rejected_window_samples"])
        self.recent = {name: deque(maxlen=window) for name in STREAMS}
        self.load_samples = 0            # accepted load samples
        self.stream_gaps = StreamGaps()  # samples missing by stamp gaps (not persisted: a count of this run)
        # guide/temperature readings by stamp (the last TEMPERATURE_HISTORY): the thermal_drift correction
        # takes the one in force at a measurement's stamp
        self.temperature_t_ns: list[int] = []
        self.temperature_c: list[float] = []
        self.thermal_correction_m = 0.0   # the last correction applied (c_T (T - T_ref)) [m]
        self.rolling = None
        if params.get("guide_type") == "rolling":
            from guide_health.models.rolling.rolling_guide import RollingGuideMonitor

            self.rolling = RollingGuideMonitor(params)

    # --- input validation + live updates (O(1) per sample) ---------------------------------------
    def validate_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """Apply the joint rules to an axis sample (counted, the time base moves on when accepted) without
        integrating it; returns the rejection reason or None (the caller integrates it later)."""
        reason, self.joint_base = check_joint_sample(t_ns, position_m, velocity_m_s, self.joint_base, self.limits)
        if reason is None:
            self.stream_gaps.joint.add(t_ns)
        return self._record("joint_states", reason)

    def integrate_joint(self, t_ns: int, position_m: float, load_n: float | None = None) -> None:
        """Integrate an axis sample accepted by :meth:`validate_joint` with ``load_n`` [N] (None: the latest
        accepted load; StampAlignedFeed passes the load in force at the sample's stamp; main-way load: a
        lifting load is 0)."""
        load = self.load_n if load_n is None else load_n
        self.integrator.advance(t_ns, position_m, main_way_load_n(load))
        if self.rolling is not None:
            self.rolling.advance(t_ns, position_m, load)

    def on_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """Axis sample; returns the rejection reason or None when accepted."""
        reason = self.validate_joint(t_ns, position_m, velocity_m_s)
        if reason is None:
            self.integrate_joint(t_ns, position_m)
        return reason

    def check_load(self, t_ns: int, load_n: float) -> str | None:
        """The rejection reason :meth:`on_load` would give (nothing counted or changed)."""
        return check_load_sample(t_ns, load_n, self.load_base, self.limits)[0]

    def on_load(self, t_ns: int, load_n: float) -> str | None:
        """Guide-load sample [N]; returns the rejection reason or None when accepted."""
        reason, self.load_base = check_load_sample(t_ns, load_n, self.load_base, self.limits)
        if reason is not None:
            return self._record("guide/load", reason)
        self._record("guide/load", None)
        self.stream_gaps.load.add(t_ns)
        self.load_n = float(load_n)
        self.load_t_ns = int(t_ns)
        self.load_samples += 1
        return None

    def on_temperature(self, t_ns: int, temperature_c: float) -> str | None:
        """A guide/temperature reading: the rolling guide's oil viscosity from its stamp on (Walther oil);
        kept by stamp for the thermal_drift correction of straightness measurements. An implausible reading
        (input_rules.plausible_temperature) is a counted rejection; returns its reason, else None."""
        if not plausible_temperature(temperature_c):
            return self.rejected.reject(TEMPERATURE_IMPLAUSIBLE)
        if self.rolling is not None:
            self.rolling.add_temperature(t_ns, temperature_c)
        self._keep_temperatures(np.array([t_ns], dtype=np.int64), np.array([temperature_c], dtype=float))
        return None

    def _thermal(self) -> bool:
        return self.effects is not None and self.effects.thermal_drift_m_per_k != 0.0

    def _keep_temperatures(self, t_ns: np.ndarray, temperature_c: np.ndarray, keep: int = TEMPERATURE_HISTORY) -> None:
        """Add readings (non-finite ones dropped), sorted by stamp, keeping the last ``keep``."""
        if not self._thermal() or t_ns.size == 0:
            return
        ok = np.isfinite(temperature_c)
        t = np.concatenate((np.asarray(self.temperature_t_ns, dtype=np.int64), t_ns[ok]))
        c = np.concatenate((np.asarray(self.temperature_c, dtype=float), temperature_c[ok]))
        order = np.argsort(t, kind="stable")[-keep:]
        self.temperature_t_ns, self.temperature_c = t[order].tolist(), c[order].tolist()

    def thermal_offset_at_k(self, t_ns: int) -> float | None:
        """T - T_ref [K] of the temperature reading in force at ``t_ns`` (thermal_drift; 0 without the
        effect); None when no reading is stamped at or before it."""
        if not self._thermal():
            return 0.0
        i = reading_in_force_index(self.temperature_t_ns, int(t_ns))
        if i < 0:
            return None
        return self.temperature_c[i] - self.effects.thermal_reference_c

    def on_straightness(self, t_ns: int, straightness_m: float) -> str | None:
        """Straightness measurement [m]; returns the rejection reason or None when accepted. A measurement
        is identified by its stamp: one with the stamp of an applied measurement is not applied again."""
        if self.integrator.last_t_ns is None:   # before any accepted joint sample (discrepancy/duty.py alike)
            return self.rejected.reject(STRAIGHTNESS_WITHOUT_TIME_BASE)
        times = self.estimator.measurement_t_ns
        reason = check_straightness_sample(t_ns, straightness_m, times[-1] if times else None, self.limits)
        if reason is not None:
            return self.rejected.reject(reason)
        offset = self.thermal_offset_at_k(t_ns)
        if offset is None:
            return self.rejected.reject(STRAIGHTNESS_WITHOUT_TEMPERATURE)
        correction = self.effects.thermal_drift_m_per_k * offset if self._thermal() else 0.0   # c_T (T - T_ref)
        self.thermal_correction_m = correction
        self.estimator.add(t_ns, straightness_m - correction, self.loss_per_k_m(), self.work_nm())
        if self.effect_wear is not None:
            self.effect_wear.on_measurement(offset)
        return None

    # --- the wear effects (models/wear/effect_wear.py) ---------------------------------------------
    def _attach_effects(self) -> None:
        if self.effects is not None:
            self.effect_wear = EffectWear(self.effects, self.integrator.duty_bucket_s, DUTY_BUCKETS)
            self.integrator.segment_sink = self.effect_wear.add_segments

    def work_nm(self) -> float:
        """The work K multiplies: Archard's sum W ds, or with effects sum W ds m [N m]."""
        return self.integrator.archard_work_nm if self.effect_wear is None else self.effect_wear.effective_work_nm

    def loss_per_k_m(self) -> float:
        """Straightness loss per unit K now [m] (with the effects: Eq. 7 over the effective work, and
        stroke_distribution's pass weighting: effects.straightness_wear_m)."""
        if self.effect_wear is None:
            return self.integrator.straightness_loss_per_k_m()
        return float(self._effect_losses_per_k_m(self.work_nm(), self.effect_wear.pass_work_now_n()))

    def _effect_losses_per_k_m(self, work_nm, pass_work_n):
        """Straightness per unit K [m] of effective work G and pass work P with the present stroke range:
        K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] / K (seed 000 Eq. 7 at w = 0), not below 0."""
        l_min, l_max = self.integrator.stroke_range_m()
        if not (l_min + l_max > 0):
            return math.nan * np.asarray(work_nm, dtype=float)
        loss = straightness_wear_m(1.0, self.geometry.hardness_pa, self.geometry.contact_width_m, work_nm,
                                   pass_work_n, l_min + l_max, self.effects.stroke_distribution_weight)
        return np.maximum(loss, 0.0)

    def measurement_pass_work_n(self) -> np.ndarray:
        """P at each measurement [N] (stroke_distribution). Measurements taken before the pass work was kept
        (a state saved before stop 12) take the present ratio P / G of their effective work."""
        ew, est = self.effect_wear, self.estimator
        kept = np.asarray(ew.measurement_pass_work_n, dtype=float)
        work = self.work_nm()
        estimate = np.asarray(est.measurement_work_nm, dtype=float) * (ew.pass_work_now_n() / work if work > 0 else 0.0)
        if kept.size != est.count:
            return estimate
        return np.where(np.isfinite(kept), kept, estimate)

    def effect_forecast(self) -> dict[str, float]:
        """Present duty with the effects: steady dA/dt per K [m/s] (running-in over), sliding speed [m/s],
        sliding distance on the present surface [m] (since the last regrind), the d ln(rate)/d(parameter) of
        rho, v_lift, n, g, f and b."""
        sums = self.effect_wear.window_sums(self.integrator.last_t_ns)
        rate_plain = self.integrator.straightness_rate_per_k_m_s()      # Archard work rate, Eq. 7
        work, eff, dist, passes = (sums[SUM_INDEX[n]] for n in ("work_nm", "effective_work_nm", "distance_m",
                                                                 "pass_work_n"))
        ratio = eff / work if work > 0 else 1.0
        duty = self.integrator.duty_work_rate_w()
        w = self.effects.stroke_distribution_weight
        # stroke_distribution: dP/dt per K over H b, dP/dt = (W v) x the window's pass work per work
        rate_pass = (duty * passes / work / (self.geometry.hardness_pa * self.geometry.contact_width_m)
                     if work > 0 and math.isfinite(duty) else 0.0)
        dln_rate = [v / eff if eff > 0 else 0.0 for v in sums[RATE_SUMS]]
        return {"steady_rate_per_k_m_s": (1.0 - w) * rate_plain * ratio + w * rate_pass,
                "rate_work_per_k_m_s": rate_plain * ratio, "rate_pass_per_k_m_s": rate_pass,
                "sliding_speed_m_s": duty * dist / work if work > 0 and math.isfinite(duty) else math.nan,
                "sliding_distance_m": self.integrator.sliding_distance_m - self.effect_wear.surface_start_m,
                "dln_rate": dln_rate, "lubrication": lubrication_schedule(
                    self.effects, self.effect_wear, self.integrator.last_t_ns,
                    dln_rate[RATE_NAMES.index("lubrication_wear_growth")])}

    def effect_life_interval_s(self, k: float):
        """(life, low, high) [s] with the effects (models/wear/effect_life.life_interval_s): K's online spread
        and the model file's covariance of K and the effect parameters."""
        f = self.effect_forecast()
        work = self.work_nm()
        est = self.estimator
        g = self.measurement_losses_per_k_m()
        _, k_sd, sigma = est.posterior(g)
        n = est.count
        n_phi = len(self.effect_wear.work_gradient)
        grads = np.asarray(self.effect_wear.measurement_gradients, dtype=float).reshape(-1, n_phi)
        l_min, l_max = self.integrator.stroke_range_m()
        loss_pass = 1.0 / (self.geometry.hardness_pa * self.geometry.contact_width_m)   # per unit K and P
        loss_work = 2.0 * loss_pass / (l_min + l_max)                                   # per unit K and G (Eq. 7)
        if grads.shape[0] == n > 0:
            # dg_j / dphi = g_j / G_j dG_j / dphi (g in proportion to the work, P moving with G), and
            # dg_j / dw = loss_pass P_j - loss_work G_j
            work_j = np.asarray(est.measurement_work_nm, dtype=float)
            per_work = np.divide(g, work_j, out=np.zeros(n), where=work_j > 0)
            dg = per_work[:, None] * grads
            w_row = PHI_INDEX["stroke_distribution_weight"]
            dg[:, w_row] = loss_pass * self.measurement_pass_work_n() - loss_work * work_j
            # A0 + dA0: every rise over A0 falls by dA0; thermal_drift: each reading corrected by
            # (c_T + dc) (T_j - T_ref) + de
            dy = np.zeros_like(dg)
            dy[:, PHI_INDEX["straightness_initial_m"]] = -1.0
            offsets = np.asarray(self.effect_wear.measurement_temperature_offset_k, dtype=float)
            if self._thermal() and offsets.size == n and np.all(np.isfinite(offsets)):
                dy[:, PHI_INDEX["thermal_drift_m_per_k"]] = -offsets
                dy[:, PHI_INDEX["thermal_gauge_offset_m"]] = -1.0
            k_sens = online_k_sensitivity(g, np.asarray(est.measurement_m) - est.straightness_initial_m,
                                          dg, k, k_sd, sigma, dy)
        else:                           # no measurement yet, or a state saved before the gradients were kept
            k_sens = np.zeros(n_phi)
        now = {"margin0": self.params["straightness_limit_m"] - self.params["straightness_initial_m"],
               "work": work, "pass_work": self.effect_wear.pass_work_now_n(),
               "loss_work": loss_work, "loss_pass": loss_pass,
               "work_gradient": np.asarray(self.effect_wear.work_gradient), "k_sensitivity": k_sens,
               "rate_work_per_k": f["rate_work_per_k_m_s"], "rate_pass_per_k": f["rate_pass_per_k_m_s"],
               "dln_rate": np.asarray(f["dln_rate"]), "s_now": f["sliding_distance_m"], "v_s": f["sliding_speed_m_s"],
               "lubrication": f["lubrication"],
               "a0_measured": self.params["straightness_initial_m"] != self.params.get(
                   "straightness_initial_configured_m", self.params["straightness_initial_m"])}
        z = float(stdtrit(n - 1, 0.95)) if n >= 3 else Z90
        return life_interval_s(k, k_sd, self.effects, now, z)

    def reject_input(self, stream: str, reason: str) -> str:
        """Count a message-level rejection of an input stream (the live node: a JointState without the
        joint, an undecodable message, ...); it counts in the stream's recent rejected share."""
        return self._record(stream, reason)

    def _record(self, stream: str, reason: str | None) -> str | None:
        window = self.recent.get(stream)
        if window is not None:
            window.append(reason)
        return None if reason is None else self.rejected.reject(reason)

    # --- offline, vectorised ----------------------------------------------------------------------
    def process_run(self, run, progress: Callable[[int, int], None] | None = None) -> None:
        """Feed a whole :class:`~guide_health.runs.MachineRun` with the same rules as the live callbacks.

        Samples are filtered with the input rules (vectorised), the latest load at each joint sample is
        found by binary search, and the integration is split at the measurement times so each
        measurement sees the wear state at its own time.
        """
        temp_t = np.asarray(getattr(run, "temperature_t_ns", np.zeros(0, np.int64)), dtype=np.int64)
        temp_c = np.asarray(getattr(run, "temperature_c", np.zeros(0)), dtype=float)
        plausible = plausible_temperature(temp_c)
        self.rejected.count(TEMPERATURE_IMPLAUSIBLE, int(temp_c.size - plausible.sum()))
        temp_t, temp_c = temp_t[plausible], temp_c[plausible]
        if self.rolling is not None and temp_t.size:
            self.rolling.add_temperatures(temp_t, temp_c)   # applied by stamp
        # the whole record's readings while its measurements are applied, then the last TEMPERATURE_HISTORY
        self._keep_temperatures(temp_t, temp_c, keep=2**62)
        accepted = accept_run(run, self.joint_base, self.load_base, self.load_n, self.limits)
        self.rejected.count_all(accepted.rejected)
        self.joint_base, self.load_base = accepted.joints.base, accepted.loads.base
        for stream, codes in (("joint_states", accepted.joints.codes), ("guide/load", accepted.loads.codes)):
            window = self.recent[stream]
            window.extend(REASON_CODES[c] for c in codes[-window.maxlen:].tolist())
        self.load_samples += int(accepted.load_t_ns.size)
        self.stream_gaps.joint.add_many(accepted.joint_t_ns)
        self.stream_gaps.load.add_many(accepted.load_t_ns)
        jt, jx, load_at_joint = accepted.joint_t_ns, accepted.joint_position_m, accepted.load_at_joint_n

        st = np.asarray(run.straightness_t_ns, dtype=np.int64)
        sm = np.asarray(run.straightness_m, dtype=float)
        total = int(jt.size)
        done = 0
        start = 0
        for t_meas, value in zip(st.tolist(), sm.tolist()):
            stop = int(np.searchsorted(jt, t_meas, side="right"))
            if stop > start:
                self._advance_many(jt[start:stop], jx[start:stop], load_at_joint[start:stop])
                done += stop - start
                if progress:
                    progress(done, total)
            start = max(start, stop)
            self.on_straightness(t_meas, value)
        if total > start:
            # chunks bound the temporaries of the vectorised profile update
            for lo in range(start, total, 500_000):
                hi = min(total, lo + 500_000)
                self._advance_many(jt[lo:hi], jx[lo:hi], load_at_joint[lo:hi])
                if progress:
                    progress(hi, total)
        if accepted.load_t_ns.size:
            self.load_t_ns = int(accepted.load_t_ns[-1])
            self.load_n = float(accepted.load_n[-1])
        del self.temperature_t_ns[:-TEMPERATURE_HISTORY], self.temperature_c[:-TEMPERATURE_HISTORY]

    def _advance_many(self, t_ns, position_m, load_n) -> None:
        self.integrator.advance_many(t_ns, position_m, main_way_load_n(load_n))
        if self.rolling is not None:
            self.rolling.advance_many(t_ns, position_m, load_n)

    def fatigue_report(self) -> dict[str, Any] | None:
        """The `<joint> fatigue` numbers, level and message (rolling guides; None for sliding)."""
        return None if self.rolling is None else self.rolling.fatigue_report()

    # --- results ------------------------------------------------------------------------------------
    def measurement_losses_per_k_m(self) -> np.ndarray:
        """g_j of each measurement: for Eq. 7 recomputed with the present stroke estimate."""
        est = self.estimator
        if self.effect_wear is not None:
            return self._effect_losses_per_k_m(np.asarray(est.measurement_work_nm, dtype=float),
                                               self.measurement_pass_work_n())
        if self.geometry.straightness_model == "eq7":
            l_min, l_max = self.integrator.stroke_range_m()
            volume = np.asarray(est.measurement_work_nm) / self.geometry.hardness_pa
            return straightness_from_wear_volume_m(volume, self.geometry.contact_width_m, l_min, l_max)
        return np.asarray(est.measurement_loss_per_k_m, dtype=float)

    def straightness_m(self, wear_coefficient: float, loss_per_k_m):
        """Straightness [m] = A0 + K g (seed 000 Eq. 11 with the initial straightness A0), for a loss per
        unit K ``g`` [m] (a number or an array, e.g. :meth:`measurement_losses_per_k_m`)."""
        return self.params["straightness_initial_m"] + wear_coefficient * loss_per_k_m

    def report(self) -> dict[str, Any]:
        """The numbers of the `<joint> precision` status (INTERFACES.md keys) plus level and message."""
        p = self.params
        g_meas = self.measurement_losses_per_k_m()
        k_low, k, k_high = self.estimator.interval90(g_meas)
        loss_per_k = self.loss_per_k_m()
        rate_per_k = self.integrator.straightness_rate_per_k_m_s()
        a0 = p["straightness_initial_m"]
        limit = p["straightness_limit_m"]
        straightness = self.straightness_m(k, loss_per_k) if math.isfinite(loss_per_k) else math.nan
        if self.effect_wear is not None and math.isfinite(loss_per_k) and math.isfinite(rate_per_k):
            life, life_low, life_high = self.effect_life_interval_s(k)
        else:
            life = remaining_life_s(limit, a0, loss_per_k, rate_per_k, k)
            life_low = remaining_life_s(limit, a0, loss_per_k, rate_per_k, k_high)
            life_high = remaining_life_s(limit, a0, loss_per_k, rate_per_k, k_low) if k_low > 0 else math.inf
        l_min, l_max = self.integrator.stroke_range_m()
        measured = self.estimator.measurement_m[-1] if self.estimator.count else math.nan
        result = {
            "straightness_um": straightness * 1e6,
            "straightness_measured_um": measured * 1e6,
            "straightness_limit_um": limit * 1e6,
            "remaining_life_h": life / 3600.0,
            "remaining_life_h_low": life_low / 3600.0,
            "remaining_life_h_high": life_high / 3600.0,
            "wear_volume_mm3": k * self.work_nm() / self.geometry.hardness_pa * 1e9,
            "sliding_distance_m": self.integrator.sliding_distance_m,
            "wear_coefficient": k,
            "wear_coefficient_low": k_low,
            "wear_coefficient_high": k_high,
            "wear_coefficient_configured": p["wear_coefficient"],
            "effects": p.get("effects", ""),
            "measurements": self.estimator.count,
            "duty_load_speed_w": self.integrator.duty_work_rate_w(),
            "stroke_min_m": l_min,
            "stroke_max_m": l_max,
            "strokes": self.integrator.strokes.stroke_count,
            "straightness_model": self.geometry.straightness_model,
            "samples": self.integrator.samples,
            "load_samples": self.load_samples,
            "rejected_samples": self.rejected.total,
            "rejected_recent_share": self.recent_rejected_share()[0],
            **{rejected_key(reason): n for reason, n in self.rejected.items()},
            **self.stream_gaps.values(),
        }
        if self._thermal():
            # straightness_measured_um is the corrected reading; this is what was taken off the last one
            result["straightness_thermal_correction_um"] = self.thermal_correction_m * 1e6
        result["level"], result["message"] = self._judge(result)
        gaps = self.stream_gaps.message()
        if gaps:
            result["message"] = f"{result['message']}; {gaps}"
        # the level with every threshold moved by the clear margin (models/levels.py hysteresis_level)
        margin = float(self.params.get("alarm_clear_margin", 0.0))
        result["level_clear"] = self._judge_inputs(*self._judge_precision(result, margin))[0]
        if self.rolling is not None:
            result.update(self.rolling.lubrication_values())
            level, text = self.rolling.lubrication_level()
            result["level_clear"] = max(result["level_clear"], level)
            if level > result["level"]:
                result["level"], result["message"] = level, f"{text}; {result['message']}"
            else:
                result["message"] = f"{result['message']}; {text}"
        return result

    def forecast(self, points: int = 60) -> dict[str, Any]:
        """Straightness from now to the limit at the present duty [um] over the horizon [h]: the point
        forecast (with the effects: running-in decaying on the way, effect_life.forecast_straightness_m) and
        the 90 % band, whose edges reach the limit at the interval's ends. {} without a finite life."""
        r = self.report()
        life, low, high = r["remaining_life_h"], r["remaining_life_h_low"], r["remaining_life_h_high"]
        a_now, limit = r["straightness_um"], r["straightness_limit_um"]
        if not (math.isfinite(life) and life > 0 and math.isfinite(a_now) and self.integrator.last_t_ns):
            return {}
        end = high if math.isfinite(high) else 3.0 * life
        h = np.linspace(0.0, end, points)
        mid = a_now + (limit - a_now) * h / life
        f = self.effect_forecast() if self.effect_wear is not None else {}
        if f and (self.effects.running_in_ratio > 0 or f["lubrication"] is not None):
            mid = forecast_straightness_m(h * 3600.0, a_now, r["wear_coefficient"] * f["steady_rate_per_k_m_s"] * 1e6,
                                          self.effects.running_in_ratio, self.effects.running_in_distance_m,
                                          f["sliding_distance_m"], f["sliding_speed_m_s"],
                                          schedule_tuple(f["lubrication"], self.effects.lubrication_wear_growth))
        band = [a_now + (limit - a_now) * h / x if x > 0 else np.full_like(h, limit) for x in (low, high)]
        return {"now_h": (self.integrator.last_t_ns - (self.integrator.first_t_ns or 0)) * 1e-9 / 3600.0,
                "now_ns": int(self.integrator.last_t_ns), "horizon_h": h, "mid_um": np.minimum(mid, limit),
                "fast_um": np.minimum(band[0], limit), "slow_um": np.minimum(band[1], limit), "limit_um": limit,
                "life_h": life, "life_low_h": low, "life_high_h": high}

    def recent_rejected_share(self) -> tuple[float, str, str]:
        """(share, stream, dominant reason) of the input stream with the largest share of rejected samples
        among its last rejected_window_samples; (0, '', '') before any sample."""
        best = (0.0, "", "")
        for stream, window in self.recent.items():
            reasons = Counter(r for r in window if r is not None)
            if window and reasons:
                share = sum(reasons.values()) / len(window)
                if share > best[0]:
                    best = (share, stream, reasons.most_common(1)[0][0])
        return best

    def _judge_inputs(self, level: Level, text: str) -> tuple[Level, str]:
        """WARN when most recent input of a stream was rejected (rejected_share_warn), naming the reason."""
        share, stream, reason = self.recent_rejected_share()
        if share <= self.params["rejected_share_warn"]:
            return level, text
        window = len(self.recent[stream])
        return max(level, Level.WARN), (f"{share:.0%} of the last {window} {stream} samples rejected "
                                        f"({reason}); {text}")

    def _judge(self, r: dict) -> tuple[Level, str]:
        return self._judge_inputs(*self._judge_precision(r))

    def _judge_precision(self, r: dict, margin: float = 0.0) -> tuple[Level, str]:
        """The precision level at the thresholds, or with each moved by ``margin`` towards the good side
        (the clearing test of the alarm hysteresis, guide_health.models.levels)."""
        p = self.params
        a = r["straightness_um"]
        limit = r["straightness_limit_um"]
        life = r["remaining_life_h"]
        if math.isnan(a):
            if self.integrator.samples == 0:
                return Level.WARN, (f"no wear estimate yet: no joint_states sample of joint "
                                    f"'{p['joint']}' accepted")
            return Level.WARN, "no wear estimate yet (waiting for motion and load)"
        level = Level.OK
        if exceeds(a, limit, margin, inclusive=True):
            return Level.ERROR, f"straightness {a:.1f} um exceeds the limit {limit:.1f} um: precision lost"
        if falls_below(life, p["life_error_h"], margin):
            level = Level.ERROR
        elif falls_below(life, p["life_warn_h"], margin) or exceeds(a, p["straightness_warn_fraction"] * limit,
                                                                      margin):
            level = Level.WARN
        if math.isfinite(life):
            text = f"remaining precision life {life:.0f} h at current duty (straightness {a:.1f} of {limit:.0f} um)"
        else:
            text = f"no wear at current duty (straightness {a:.1f} of {limit:.0f} um)"
        return level, text

    # --- persistence ----------------------------------------------------------------------------
    def state(self) -> dict:
        return {
            "version": self.STATE_VERSION,
            "integrator": self.integrator.state(),
            "estimator": self.estimator.state(),
            "load_n": self.load_n,
            "load_t_ns": self.load_t_ns,
            "load_samples": self.load_samples,
            "rolling": None if self.rolling is None else self.rolling.state(),
            **({} if self.effect_wear is None else {"effects": self.effect_wear.state()}),
            # thermal_drift: the readings a later measurement may take (by stamp)
            **({} if not self._thermal() else {"temperatures": {"reading_t_ns": list(self.temperature_t_ns),
                                                                 "reading_c": list(self.temperature_c)}}),
        }

    def restore(self, state: dict) -> None:
        if state.get("version") != self.STATE_VERSION:
            raise ValueError(f"unsupported state version {state.get('version')}")
        self.integrator = WearIntegrator.from_state(self.geometry, state["integrator"])
        self._attach_effects()
        if self.effect_wear is not None and state.get("effects"):
            self.effect_wear.restore(state["effects"])
            if "pass_work_n" not in state["effects"]:     # saved before the pass work was kept (stop 12)
                strokes = self.integrator.strokes
                self.effect_wear.estimate_pass_work(strokes.stroke_sum_m / strokes.stroke_count
                                                    if strokes.stroke_count else 0.0)
        temps = state.get("temperatures") or {"reading_t_ns": [], "reading_c": []}
        self.temperature_t_ns, self.temperature_c = [], []
        self._keep_temperatures(np.asarray(temps["reading_t_ns"], dtype=np.int64),
                                np.asarray(temps["reading_c"], dtype=float))
        est = state["estimator"]
        self.estimator = WearCoefficientEstimator.from_state(est)
        # parameters win over the saved prior (a user may re-tune them); measurements are kept
        self.estimator.prior_wear_coefficient = self.params["wear_coefficient"]
        self.estimator.prior_rel_sd = self.params["wear_coefficient_prior_rel_sd"]
        self.estimator.noise_sd_m = self.params["straightness_noise_m"]
        self.estimator.straightness_initial_m = self.params["straightness_initial_m"]
        if self._thermal() and self.effect_wear is not None and self.temperature_t_ns:   # a state before stop 12
            self.effect_wear.rebuild_temperature_offsets(self.estimator.measurement_t_ns, self.temperature_t_ns[0],
                                                         self.thermal_offset_at_k)
        self.load_n = state["load_n"]
        self.load_t_ns = state["load_t_ns"]
        self.load_samples = int(state.get("load_samples", 0))
        self.joint_base = StampBase(self.integrator.last_t_ns)
        self.load_base = StampBase(self.load_t_ns)
        if self.rolling is not None and state.get("rolling"):
            self.rolling.restore(state["rolling"])

