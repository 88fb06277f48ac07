"""Rolling linear guide: lubrication regime of the ball/groove contacts (seed 001) and fatigue life used
(seed 004 / ISO 14728-1) from the same joint and load samples as the wear model.

One object for the live node and the offline replay (fed by PrecisionMonitor with the samples it
accepted, the load already aligned by stamp):
- speed from |dx| / dt of the axis; carriage load = guide load / `carriages`;
- lubrication: LubricationRegimeEstimator (Hamrock-Dowson film of the most loaded ball under preload,
  lambda = h / composite RMS, JGP/Greenwood-Tripp asperity share); the share of recent travel run in
  boundary lubrication, with exponential forgetting over `boundary_window_m` of travel;
- fatigue: FatigueAccumulator (equivalent load = cubic (p-th power) mean over travel, Miner's rule,
  L = (fh ft fc C / (fw P))^p x rating_distance_km), per carriage. The load of each travel increment is the
  carriage load that gives the most loaded ball its real load under preload, 2 n sin(alpha) max(F_u, F_L)
  (:func:`~guide_health.models.rolling.carriage.equivalent_fatigue_load_n`), divided by
  ``reverse_load_rating_factor`` when the load is reversed (force.z < 0: lower rows).
"""
from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np

from guide_health.models.levels import ERROR, OK, WARN, Level
from guide_health.models.rolling.ball_contact import LubricationRegimeEstimator
from guide_health.models.rolling.lubrication import REGIMES
from guide_health.models.rolling.rating_life import FatigueAccumulator
from guide_health.models.wear.input_rules import reading_in_force_index


class RollingGuideMonitor:
    STATE_VERSION = 2       # 2: fatigue sums with preload and reverse loads; 1 had neither

    def __init__(self, params: Any):
        """``params``: the guide's GuideParams (guide_health.params.typed); the thresholds are read from it at
        each report (a run-time change replaces it)."""
        self.params = params
        self.carriages = int(params.carriages)
        if self.carriages < 1:
            raise ValueError("carriages must be >= 1")
        if not params.dynamic_load_rating_n > 0:
            raise ValueError("guide_type rolling needs dynamic_load_rating_n (C) > 0")
        self.regime_model = LubricationRegimeEstimator(params)
        self.window_m = float(params.boundary_window_m)
        self.reverse_factor = float(params.reverse_load_rating_factor)
        if not (math.isfinite(self.reverse_factor) and self.reverse_factor > 0):
            raise ValueError("reverse_load_rating_factor must be > 0")
        self.fatigue = FatigueAccumulator(params.dynamic_load_rating_n, params.rolling_element,
                                          params.rating_distance_km, params.life_factors,
                                          recent_window_m=self.window_m)
        self.last_t_ns: int | None = None
        self.last_position_m: float | None = None
        self.boundary_travel_m = 0.0          # exponentially forgotten travel in boundary lubrication
        self.window_travel_m = 0.0            # exponentially forgotten travel
        self.regime_travel_m = {r: 0.0 for r in REGIMES}     # whole-history travel per regime
        self.reverse_travel_m = 0.0           # travel under a reverse (lift-off) load
        self.last_regime = "unknown"
        self.last_lambda = math.nan
        self.last_asperity_share = math.nan
        self.last_speed_m_s = math.nan
        # guide/temperature readings not yet in force, by stamp (arrival order at a tie), and the stamp of the
        # reading in force (None: none yet)
        self._pending_t_ns: list[int] = []
        self._pending_c: list[float] = []
        self.oil_temperature_t_ns: int | None = None

    # --- oil temperature (Walther viscosity): applied by stamp, live and offline alike -----------------------
    MAX_PENDING_TEMPERATURES = 100_000

    def add_temperature(self, t_ns: int, temperature_c: float) -> None:
        """A guide/temperature reading [degC] stamped ``t_ns``: the oil viscosity of every travel segment
        ending at or after the stamp (no effect with a constant ``oil_viscosity_pa_s``). The reading in force
        at a segment's end is the last one stamped at or before it (input_rules.reading_in_force_index, the
        rule of the gauge's temperature correction): a reading arriving after a later-stamped one took force is
        superseded and dropped."""
        if not math.isfinite(temperature_c) or self.regime_model.guide.oil is None:
            return
        t = int(t_ns)
        if self.oil_temperature_t_ns is not None and t < self.oil_temperature_t_ns:
            return
        i = bisect.bisect_right(self._pending_t_ns, t)
        self._pending_t_ns.insert(i, t)
        self._pending_c.insert(i, float(temperature_c))
        if len(self._pending_t_ns) > self.MAX_PENDING_TEMPERATURES:     # no motion for a long time
            self._apply_temperatures(self._pending_t_ns[0])

    def add_temperatures(self, t_ns: np.ndarray, temperature_c: np.ndarray) -> None:
        for t, c in zip(np.asarray(t_ns, dtype=np.int64).tolist(), np.asarray(temperature_c, float).tolist()):
            self.add_temperature(t, c)

    def _apply_temperatures(self, t_ns: int) -> None:
        """The reading in force at ``t_ns`` sets the oil temperature; it and the earlier pending ones go."""
        i = reading_in_force_index(self._pending_t_ns, t_ns)
        if i >= 0:
            self.regime_model.set_oil_temperature(self._pending_c[i])
            self.oil_temperature_t_ns = self._pending_t_ns[i]
            del self._pending_t_ns[:i + 1], self._pending_c[:i + 1]

    # --- samples (accepted by PrecisionMonitor, load = latest load stamped before) -----------------
    def advance(self, t_ns: int, position_m: float, load_n: float) -> None:
        if self._pending_t_ns:
            self._apply_temperatures(t_ns)
        if self.last_t_ns is not None and math.isfinite(load_n):
            ds = abs(position_m - self.last_position_m)
            dt = (t_ns - self.last_t_ns) * 1e-9
            if ds > 0.0 and dt > 0.0:
                self._segment(ds, ds / dt, load_n)
        self.last_t_ns = int(t_ns)
        self.last_position_m = float(position_m)

    def advance_many(self, t_ns: np.ndarray, position_m: np.ndarray, load_n: np.ndarray) -> None:
        """The same as advance() per sample (the regime estimator is scalar; ~5 us per moving sample)."""
        if t_ns.size == 0:
            return
        t = np.asarray(t_ns, dtype=np.int64)
        x = np.asarray(position_m, dtype=float)
        w = np.asarray(load_n, dtype=float)
        t_prev = np.concatenate(([self.last_t_ns if self.last_t_ns is not None else t[0]], t[:-1]))
        x_prev = np.concatenate(([self.last_position_m if self.last_position_m is not None else x[0]], x[:-1]))
        ds = np.abs(x - x_prev)
        dt = (t - t_prev) * 1e-9
        if self.last_t_ns is None:
            ds[0] = 0.0
        move = (ds > 0) & (dt > 0) & np.isfinite(w)
        speed = np.divide(ds, dt, out=np.zeros_like(ds), where=dt > 0)
        segment = self._segment
        if self._pending_t_ns:
            for ti, d, v, f in zip(t[move].tolist(), ds[move].tolist(), speed[move].tolist(), w[move].tolist()):
                if self._pending_t_ns and self._pending_t_ns[0] <= ti:
                    self._apply_temperatures(ti)
                segment(d, v, f)
            self._apply_temperatures(int(t[-1]))
        else:
            for d, v, f in zip(ds[move].tolist(), speed[move].tolist(), w[move].tolist()):
                segment(d, v, f)
        self.last_t_ns = int(t[-1])
        self.last_position_m = float(x[-1])

    def _segment(self, ds: float, speed: float, load_n: float) -> None:
        fatigue_load = self.regime_model.fatigue_load_n(load_n)   # per carriage, ball loads under preload
        if load_n < 0.0:
            fatigue_load /= self.reverse_factor
            self.reverse_travel_m += ds
        sample = self.regime_model.sample(speed, abs(load_n))     # shares the guide load by carriages itself
        self.fatigue.add(ds, fatigue_load)
        forget = math.exp(-ds / self.window_m)
        boundary = ds if sample.regime == "boundary" else 0.0
        self.boundary_travel_m = self.boundary_travel_m * forget + boundary
        self.window_travel_m = self.window_travel_m * forget + ds
        self.regime_travel_m[sample.regime] += ds
        self.last_regime = sample.regime
        self.last_lambda = sample.lambda_ratio
        self.last_asperity_share = sample.asperity_load_share
        self.last_speed_m_s = speed

    # --- results --------------------------------------------------------------------------------
    @property
    def boundary_share(self) -> float:
        """Share of the recent travel (exponential window) run in boundary lubrication."""
        return self.boundary_travel_m / self.window_travel_m if self.window_travel_m > 0 else math.nan

    def lubrication_values(self) -> dict[str, Any]:
        total = sum(self.regime_travel_m.values())
        return {
            "lubrication_regime": self.last_regime,
            "lambda": self.last_lambda,
            "asperity_load_share": self.last_asperity_share,
            "boundary_share_recent": self.boundary_share,
            "boundary_share_total": self.regime_travel_m["boundary"] / total if total > 0 else math.nan,
            "mixed_share_total": self.regime_travel_m["mixed"] / total if total > 0 else math.nan,
            "full_film_share_total": self.regime_travel_m["full_film"] / total if total > 0 else math.nan,
            "oil_viscosity_pa_s": self.regime_model.viscosity_pa_s,
            "oil_temperature_c": self.regime_model.oil_temperature_c,
        }

    def lubrication_level(self) -> tuple[Level, str]:
        share = self.boundary_share
        limit = self.params.boundary_share_warn
        if math.isfinite(share) and share > limit:
            return WARN, (f"{share:.0%} of the recent travel in boundary lubrication > boundary_share_warn "
                          f"{limit:.0%}: too slow or too little oil for a film")
        return OK, f"lubrication {self.last_regime}"

    def fatigue_report(self) -> dict[str, Any]:
        values = self.fatigue.diagnostics()
        s = self.fatigue.summary()
        values["duty_load_n"] = s.duty_load_n
        values["equivalent_fatigue_load_n"] = s.equivalent_load_n     # preload and direction included
        values["preload_carriage_load_n"] = self.regime_model.fatigue_load_n(0.0) * self.carriages
        values["reverse_travel_km"] = self.reverse_travel_m / 1000.0
        values["carriages"] = self.carriages
        used = values["life_used_fraction"]
        p = self.params
        if not math.isfinite(used):
            level, message = OK, "no travel yet"
        elif used >= p.life_used_error:
            level, message = ERROR, (f"rating life used up: {used:.0%} of {values['rating_life_km']:.0f} km >= "
                                     f"life_used_error {p.life_used_error:.0%}")
        elif used >= p.life_used_warn:
            level, message = WARN, f"{used:.0%} of the rating life used >= life_used_warn {p.life_used_warn:.0%}"
        else:
            level = OK
            remaining = values["remaining_life_km"]
            message = (f"{used:.1%} of the rating life used, {remaining:,.0f} km left at the current duty"
                       if math.isfinite(remaining) else f"{used:.1%} of the rating life used")
        values["level"], values["message"] = level, message
        return values

    # --- persistence --------------------------------------------------------------------------
    def state(self) -> dict:
        return {"version": self.STATE_VERSION, "fatigue": self.fatigue.state(), "last_t_ns": self.last_t_ns,
                "last_position_m": self.last_position_m, "boundary_travel_m": self.boundary_travel_m,
                "window_travel_m": self.window_travel_m, "regime_travel_m": dict(self.regime_travel_m),
                "reverse_travel_m": self.reverse_travel_m,
                "last_regime": self.last_regime, "last_lambda": self.last_lambda,
                "last_asperity_share": self.last_asperity_share, "last_speed_m_s": self.last_speed_m_s,
                "oil_temperature_c": self.regime_model.oil_temperature_c,
                "oil_temperature_t_ns": self.oil_temperature_t_ns}

    def restore(self, state: dict) -> None:
        if state.get("version") != self.STATE_VERSION:
            raise ValueError(f"unsupported rolling-guide state version {state.get('version')} (version 1 "
                             "summed fatigue without preload and reverse loads: start a new state)")
        p = self.params
        self.fatigue = FatigueAccumulator.from_state(
            state["fatigue"], dynamic_load_rating_n=p.dynamic_load_rating_n,
            rating_distance_km=p.rating_distance_km, life_factors=p.life_factors)
        for key in ("last_t_ns", "last_position_m", "boundary_travel_m", "window_travel_m", "reverse_travel_m",
                    "last_regime",
                    "last_lambda", "last_asperity_share", "last_speed_m_s"):
            setattr(self, key, state[key])
        self.regime_travel_m = {r: float(state["regime_travel_m"].get(r, 0.0)) for r in REGIMES}
        self.regime_model.set_oil_temperature(float(state.get("oil_temperature_c", math.nan)))
        stamp = state.get("oil_temperature_t_ns")
        self.oil_temperature_t_ns = None if stamp is None else int(stamp)
