"""The precision-retention physics of one guide: Archard work, the wear effects, K from measurements.

A guide holds physics state only: the integrator of the Archard work
(:class:`~guide_health.models.wear.archard.WearIntegrator`), the live wear effects
(:class:`~guide_health.models.wear.effect_wear.EffectWear`), the K estimator
(:class:`~guide_health.models.wear.calibration.WearCoefficientEstimator`), the rolling-guide models and the
temperature readings the gauge's temperature correction takes. It sees only samples its axis's input gate
(models/wear/gate.py) accepted, with its own share of the axis load; straightness, wear and the numbers of
the remaining life (models/wear/life.py) come from here (seed 000 Eqs. 7, 10, 11, 12).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from guide_health.models.rolling.rolling_guide import RollingGuideMonitor
from guide_health.models.wear.archard import (
    DUTY_BUCKETS,
    WearGeometry,
    WearIntegrator,
    straightness_from_wear_volume_m,
)
from guide_health.models.wear.calibration import WearCoefficientEstimator, z90_for_measurements
from guide_health.models.wear.effect_life import (
    B_RATE_INDEX,
    W_INDEX,
    EffectLifeNow,
    life_interval_s,
    lubrication_schedule,
    online_k_sensitivity,
    schedule_tuple,
)
from guide_health.models.wear.effect_wear import EffectWear
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import (
    COVARIANCE_INDEX,
    GAUGE_TEMPERATURE,
    PASS_WEIGHTING,
    PHI_INDEX,
    RATE_SUMS,
    RELUBRICATION,
    SLIDING_DECAY,
    SUM_INDEX,
)
from guide_health.models.wear.fit_watch import FitWatch, model_key, predict, thermal_sd_m
from guide_health.models.wear.input_rules import (
    MEASUREMENT_ALREADY_APPLIED,
    STRAIGHTNESS_TIME_BACKWARDS,
    STRAIGHTNESS_WITHOUT_TEMPERATURE,
    main_way_load_n,
    reading_in_force_index,
)
from guide_health.models.wear.life import RunningIn

#: guide/temperature readings kept for the gauge's temperature correction (by stamp; a measurement takes the one in
#: force at its stamp, so a reading may arrive after the measurement it precedes)
TEMPERATURE_HISTORY = 4096


class GuideWear:
    """The physics of one sliding or rolling guide (``params``: the frozen wear parameters of its axis,
    guide_health.params.typed.WearAxisParams; a change is a new object, :meth:`set_params`)."""

    STATE_VERSION = 1

    def __init__(self, params: Any):
        self.params = params
        self.geometry = WearGeometry.from_params(params)
        self.integrator = WearIntegrator(self.geometry)
        # the effects diagnose learnt (DIR/model.yaml): K stays linear over the effective work
        self.effects = EffectParameters.from_params(params)
        self.effect_wear = None
        self._attach_effects()
        self.estimator = WearCoefficientEstimator(
            prior_wear_coefficient=params.wear_coefficient,
            prior_rel_sd=params.wear_coefficient_prior_rel_sd,
            noise_sd_m=params.straightness_noise_m,
            straightness_initial_m=params.straightness_initial_m,
        )
        # the configured A0 while a wear reset's measured A0 is in force (models/wear/maintenance.reset_wear)
        self.straightness_initial_configured_m: float | None = None
        # guide/temperature readings by stamp (the last TEMPERATURE_HISTORY): the gauge's temperature correction
        # takes the one in force at a measurement's stamp
        self.temperature_t_ns: list[int] = []
        self.temperature_c: list[float] = []
        self.thermal_correction_m = 0.0   # the last correction applied (c_T (T - T_ref)) [m]
        # the model-fit test on the innovations of the measurements (models/wear/fit_watch.py)
        self.fit_watch = FitWatch(model_key=model_key(params, self.effects))
        self.rolling = None
        if params.guide_type == "rolling":
            self.rolling = RollingGuideMonitor(params)

    def set_params(self, params: Any) -> None:
        """Parameters changed at run time (a new frozen object); the rolling models take them too."""
        self.params = params
        if self.rolling is not None:
            self.rolling.params = params

    # --- accepted samples ------------------------------------------------------------------------
    def advance(self, t_ns: int, position_m: float, load_n: float) -> None:
        """One accepted axis sample with this guide's load [N] (main-way load: a lifting load is 0)."""
        self.integrator.advance(t_ns, position_m, main_way_load_n(load_n))
        if self.rolling is not None:
            self.rolling.advance(t_ns, position_m, load_n)

    def advance_many(self, t_ns, position_m, load_n) -> None:
        """Accepted axis samples in stamp order with this guide's loads [N] (vectorised)."""
        self.integrator.advance_many(t_ns, position_m, main_way_load_n(load_n))
        if self.rolling is not None:
            self.rolling.advance_many(t_ns, position_m, load_n)

    def add_temperature(self, t_ns: int, temperature_c: float) -> None:
        """A plausible guide/temperature reading: the rolling guide's oil viscosity from its stamp on (Walther
        oil), kept by stamp for the gauge's temperature correction."""
        if self.rolling is not None:
            self.rolling.add_temperature(t_ns, temperature_c)
        self._keep_temperatures(np.array([t_ns], dtype=np.int64), np.array([temperature_c], dtype=float))

    def add_temperatures(self, t_ns: np.ndarray, temperature_c: np.ndarray) -> None:
        """:meth:`add_temperature` of arrays (a record's readings); every one kept while its measurements are
        applied (:meth:`trim_temperatures` after)."""
        if self.rolling is not None and t_ns.size:
            self.rolling.add_temperatures(t_ns, temperature_c)   # applied by stamp
        self._keep_temperatures(t_ns, temperature_c, keep=2**62)

    def trim_temperatures(self) -> None:
        del self.temperature_t_ns[:-TEMPERATURE_HISTORY], self.temperature_c[:-TEMPERATURE_HISTORY]

    @property
    def temperature_corrected(self) -> bool:
        """The gauge's temperature term is on (registry.GAUGE_TEMPERATURE: readings kept, measurements
        corrected)."""
        return GAUGE_TEMPERATURE.is_on(self.effects)

    def _keep_temperatures(self, t_ns: np.ndarray, temperature_c: np.ndarray, keep: int = TEMPERATURE_HISTORY) -> None:
        """Add readings (non-finite ones dropped), sorted by stamp, keeping the last ``keep``."""
        if not self.temperature_corrected or t_ns.size == 0:
            return
        ok = np.isfinite(temperature_c)
        t = np.concatenate((np.asarray(self.temperature_t_ns, dtype=np.int64), t_ns[ok]))
        c = np.concatenate((np.asarray(self.temperature_c, dtype=float), temperature_c[ok]))
        order = np.argsort(t, kind="stable")[-keep:]
        self.temperature_t_ns, self.temperature_c = t[order].tolist(), c[order].tolist()

    def thermal_offset_at_k(self, t_ns: int) -> float | None:
        """T - T_ref [K] of the temperature reading in force at ``t_ns`` (0 without the gauge's temperature
        term); None when no reading is stamped at or before it."""
        if not self.temperature_corrected:
            return 0.0
        i = reading_in_force_index(self.temperature_t_ns, int(t_ns))
        if i < 0:
            return None
        return GAUGE_TEMPERATURE.temperature_offset_k(self.effects, self.temperature_c[i])

    @property
    def last_measurement_t_ns(self) -> int | None:
        times = self.estimator.measurement_t_ns
        return times[-1] if times else None

    def measure(self, t_ns: int, straightness_m: float) -> str | None:
        """An accepted straightness measurement [m] (gate.InputGate.straightness): K updated with the reading
        corrected for the gauge's temperature term. Returns why it cannot be applied to this guide (no
        temperature reading at its stamp; a guide takes measurements in stamp order, once each), else None."""
        last = self.last_measurement_t_ns
        if last is not None and t_ns <= last:
            return MEASUREMENT_ALREADY_APPLIED if t_ns == last else STRAIGHTNESS_TIME_BACKWARDS
        offset = self.thermal_offset_at_k(t_ns)
        if offset is None:
            return STRAIGHTNESS_WITHOUT_TEMPERATURE
        correction = (GAUGE_TEMPERATURE.correction_m(self.effects, offset) if self.temperature_corrected
                      else 0.0)    # c_T (T - T_ref)
        self.thermal_correction_m = correction
        self._watch_fit(t_ns, straightness_m - correction, offset)
        self.estimator.add(t_ns, straightness_m - correction, self.loss_per_k_m(), self.work_nm())
        if self.effect_wear is not None:
            self.effect_wear.on_measurement(offset)
        return None

    def _watch_fit(self, t_ns: int, corrected_m: float, offset_k: float) -> None:
        """The fit test's innovation of a measurement (temperature-corrected) before K takes it: the
        posterior of the measurements so far predicts it (fit_watch.predict)."""
        g = self.loss_per_k_m()
        if not math.isfinite(g):
            return                      # no prediction before the stroke range is known
        k, k_sd, _ = self.estimator.posterior(self.measurement_losses_per_k_m())
        thermal = 0.0
        if self.temperature_corrected:
            rows = [COVARIANCE_INDEX[n] for n in GAUGE_TEMPERATURE.row_names]
            thermal = thermal_sd_m(offset_k, self.effects.covariance_matrix()[np.ix_(rows, rows)])
        z = predict(corrected_m, self.params.straightness_initial_m, g, k, k_sd, self.estimator.noise_sd_m,
                    thermal).sigma
        if math.isfinite(z):
            self.fit_watch.update(t_ns, z)

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
        the pass weighting: effects.straightness_wear_m)."""
        if self.effect_wear is None:
            return self.integrator.straightness_loss_per_k_m()
        return float(self._effect_losses_per_k_m(self.work_nm(), self.effect_wear.pass_work_now_n()))

    def _effect_losses_per_k_m(self, work_nm, pass_work_n):
        """Straightness per unit K [m] of effective work G and pass work P with the present stroke range:
        K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] / K (seed 000 Eq. 7 at w = 0), not below 0."""
        l_min, l_max = self.integrator.stroke_range_m()
        if not (l_min + l_max > 0):
            return math.nan * np.asarray(work_nm, dtype=float)
        loss = PASS_WEIGHTING.straightness_wear_m(1.0, self.geometry.hardness_pa, self.geometry.contact_width_m,
                                                  work_nm, pass_work_n, l_min + l_max, self.effects)
        return np.maximum(loss, 0.0)

    def measurement_pass_work_n(self) -> np.ndarray:
        """P at each measurement [N] (the pass work). Measurements taken before the pass work was kept
        (a state saved by a version that did not keep it) take the present ratio P / G of their effective work."""
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
        sums = self.effect_wear.window_sums(self.integrator.clock.running_now_t_ns)   # idle: as it was
        rate_plain = self.integrator.straightness_rate_per_k_m_s()      # Archard work rate, Eq. 7
        work, eff, dist, passes = (sums[SUM_INDEX[n]] for n in ("work_nm", "effective_work_nm", "distance_m",
                                                                 "pass_work_n"))
        ratio = eff / work if work > 0 else 1.0
        duty = self.integrator.duty_work_rate_w()
        w = PASS_WEIGHTING.weight(self.effects)
        # the pass work: dP/dt per K over H b, dP/dt = (W v) x the window's pass work per work
        rate_pass = (duty * passes / work / (self.geometry.hardness_pa * self.geometry.contact_width_m)
                     if work > 0 and math.isfinite(duty) else 0.0)
        dln_rate = [v / eff if eff > 0 else 0.0 for v in sums[RATE_SUMS]]
        return {"steady_rate_per_k_m_s": (1.0 - w) * rate_plain * ratio + w * rate_pass,
                "rate_work_per_k_m_s": rate_plain * ratio, "rate_pass_per_k_m_s": rate_pass,
                "sliding_speed_m_s": duty * dist / work if work > 0 and math.isfinite(duty) else math.nan,
                "sliding_distance_m": self.integrator.sliding_distance_m - self.effect_wear.surface_start_m,
                "dln_rate": dln_rate, "lubrication": lubrication_schedule(self.effects, self.effect_wear,
                                                                         self.integrator.last_t_ns,
                                                                         dln_rate[B_RATE_INDEX])}

    def effect_life_interval_s(self, k: float):
        """(life, low, high) [s] with the effects (models/wear/effect_life.life_interval_s): K's online spread
        and the model file's covariance of K and the effect parameters."""
        return life_interval_s(*self.effect_life_inputs(k))

    def effect_life_inputs(self, k: float) -> tuple:
        """The arguments (k, k_sd, effects, EffectLifeNow, z) of effect_life.life_interval_s now."""
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
            w_row = W_INDEX
            dg[:, w_row] = loss_pass * self.measurement_pass_work_n() - loss_work * work_j
            # A0 + dA0: every rise over A0 falls by dA0; the gauge's temperature term: each reading corrected
            # by (c_T + dc) (T_j - T_ref) + de
            dy = np.zeros_like(dg)
            dy[:, PHI_INDEX["straightness_initial_m"]] = -1.0
            offsets = np.asarray(self.effect_wear.measurement_temperature_offset_k, dtype=float)
            if self.temperature_corrected and offsets.size == n and np.all(np.isfinite(offsets)):
                for name, rise in GAUGE_TEMPERATURE.rise_gradients(offsets).items():
                    dy[:, PHI_INDEX[name]] = rise
            k_sens = online_k_sensitivity(g, np.asarray(est.measurement_m) - est.straightness_initial_m,
                                          dg, k, k_sd, sigma, dy)
        else:                           # no measurement yet, or a state saved before the gradients were kept
            k_sens = np.zeros(n_phi)
        now = EffectLifeNow(
            margin0=self.params.straightness_limit_m - self.params.straightness_initial_m,
            work=work, pass_work=self.effect_wear.pass_work_now_n(), loss_work=loss_work, loss_pass=loss_pass,
            work_gradient=np.asarray(self.effect_wear.work_gradient), k_sensitivity=k_sens,
            rate_work_per_k=f["rate_work_per_k_m_s"], rate_pass_per_k=f["rate_pass_per_k_m_s"],
            dln_rate=np.asarray(f["dln_rate"]), s_now=f["sliding_distance_m"], v_s=f["sliding_speed_m_s"],
            lubrication=f["lubrication"],
            a0_measured=(self.straightness_initial_configured_m is not None
                         and self.params.straightness_initial_m != self.straightness_initial_configured_m))
        return k, k_sd, self.effects, now, self.life_z()

    def life_z(self) -> float:
        """The 90 % interval's half-width in sd: Student-t with the measurements' count - 1 dof (normal below 3)."""
        return z90_for_measurements(self.estimator.count)

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
        return self.params.straightness_initial_m + wear_coefficient * loss_per_k_m

    def forecast_terms(self, wear_coefficient: float) -> RunningIn | None:
        """The effect-aware forecast's inputs (running-in or the relubrication schedule), None without them."""
        f = self.effect_forecast() if self.effect_wear is not None else {}
        if not (f and (SLIDING_DECAY.is_on(self.effects) or f["lubrication"] is not None)):
            return None
        ratio, distance_m = SLIDING_DECAY.decay(self.effects)
        return RunningIn(wear_coefficient * f["steady_rate_per_k_m_s"] * 1e6, ratio, distance_m,
                         f["sliding_distance_m"], f["sliding_speed_m_s"],
                         schedule_tuple(f["lubrication"], RELUBRICATION.growth(self.effects)))

    def fatigue_report(self) -> dict[str, Any] | None:
        """The `<joint> fatigue` numbers, level and message (rolling guides; None for sliding)."""
        return None if self.rolling is None else self.rolling.fatigue_report()

    # --- persistence (the load entries are the axis gate's: its latest load, this guide's share) -----------
    def state(self, load_n: float, load_t_ns: int | None, load_samples: int) -> dict:
        return {
            "version": self.STATE_VERSION,
            "integrator": self.integrator.state(),
            "estimator": self.estimator.state(),
            "load_n": load_n,
            "load_t_ns": load_t_ns,
            "load_samples": load_samples,
            "rolling": None if self.rolling is None else self.rolling.state(),
            "fit_watch": self.fit_watch.state(),
            **({} if self.effect_wear is None else {"effects": self.effect_wear.state()}),
            # the gauge's temperature term: the readings a later measurement may take (by stamp)
            **({} if not self.temperature_corrected else {"temperatures": {"reading_t_ns": list(self.temperature_t_ns),
                                                                 "reading_c": list(self.temperature_c)}}),
        }

    def restore(self, state: dict) -> None:
        """The physics of a :meth:`state` (the gate takes its load entries)."""
        if state.get("version") != self.STATE_VERSION:
            raise ValueError(f"unsupported state version {state.get('version')}")
        self.integrator = WearIntegrator.from_state(self.geometry, state["integrator"])
        self._attach_effects()
        if self.effect_wear is not None and state.get("effects"):
            self.effect_wear.restore(state["effects"])
            if "pass_work_n" not in state["effects"]:     # saved before the pass work was kept
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
        self.estimator.prior_wear_coefficient = self.params.wear_coefficient
        self.estimator.prior_rel_sd = self.params.wear_coefficient_prior_rel_sd
        self.estimator.noise_sd_m = self.params.straightness_noise_m
        self.estimator.straightness_initial_m = self.params.straightness_initial_m
        if self.temperature_corrected and self.effect_wear is not None and self.temperature_t_ns:
            # a state saved without T - T_ref per measurement
            self.effect_wear.rebuild_temperature_offsets(self.estimator.measurement_t_ns, self.temperature_t_ns[0],
                                                         self.thermal_offset_at_k)
        if self.rolling is not None and state.get("rolling"):
            self.rolling.restore(state["rolling"])
        # the fit test goes on; another model than the saved one's (a new model file) starts it anew
        self.fit_watch = FitWatch.from_state(state.get("fit_watch"))
        key = model_key(self.params, self.effects)
        if self.fit_watch.model_key != key:
            self.fit_watch.clear(self.last_measurement_t_ns, key)
