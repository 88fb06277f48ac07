"""``lubrication_interval`` (T [s], a [-]; or b [1/s] with recorded relubrications): a duty effect. Wear grows with
the time since the last relubrication (the lubricant film thins and is contaminated between services). When
the bag records the relubrications (``relubricate`` maintenance events, models/wear/maintenance.py) tau is the
time since the last recorded one (the record's start before the first) and m = 1 + b tau; else they are assumed
every interval T from the start of the record (relubricated at t = 0, T, 2T, ...): m = 1 + a tau / T,
tau = t mod T. Live: m = max(1 + b tau, 0) (recorded form) or 1 + a ((t - t_ref) mod T) / T (interval form)."""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    SimulateValue,
)

#: a fitted relubrication interval needs this many cycles in the fit span to be a period the record shows
MIN_LUBRICATION_CYCLES = 2.0


class LubricationInterval(Effect):
    """A duty factor of the time since relubrication, and the relubrication schedule of the life forecast."""

    def plausible_strong_size(self, c):
        if c.relubrication_gap_s is not None:
            return {"lubrication_wear_growth_per_s": 0.3 / 3600.0}, "b [1/h]", 0.3
        return ({"lubrication_interval_s": min(8.0 * 3600.0, 0.5 * c.fit_end_s), "lubrication_wear_growth": 2.0},
                "a (T = 8 h or half the fit span)", 2.0)

    def own_consistency_check(self, record):
        """Its period must be observed: relubrications recorded, or the fitted interval repeating at least
        ``MIN_LUBRICATION_CYCLES`` times in the fit span (a sawtooth that does not repeat is no evidence)."""
        relubrications, fit_span_s, values = record.relubrications, record.fit_span_s, record.values
        if relubrications is not None:
            return {"passed": True, "reason": f"{relubrications} relubrications recorded"}
        t_fit_h = fit_span_s / 3600.0
        period_h = values["lubrication_interval_s"] / 3600.0
        cycles = t_fit_h / period_h if period_h > 0 else 0.0
        passed = cycles >= MIN_LUBRICATION_CYCLES
        return {"passed": bool(passed), "interval_h": period_h, "fit_span_h": t_fit_h, "cycles_in_fit_span": cycles,
                "reason": (f"no relubrication recorded; the fitted interval {period_h:.1f} h repeats {cycles:.1f} "
                           f"times in the {t_fit_h:.1f} h fit span" + ("" if passed else
                                                                    f" (fewer than {MIN_LUBRICATION_CYCLES:g}: no "
                                                                    "period the record shows)"))}

    def live_values(self, p, named):
        return {"lubrication_wear_growth": float(p["lubrication_wear_growth"]) if named else 0.0,
                "lubrication_interval_s": float(p["lubrication_interval_s"]),
                "lubrication_reference_stamp_s": float(p["lubrication_reference_stamp_s"]),
                "lubrication_forecast_interval_s": float(p["lubrication_forecast_interval_s"])}

    def live_duty_factor(self, e, t_s, x_m, last_relubrication_s):
        return live_factor(self.live_tau_s(e, t_s, last_relubrication_s), e.lubrication_wear_growth,
                           e.lubrication_interval_s)

    def simulation_fields(self, sim, run):
        return {"relubrication_t_s": tuple(float(t) for t in run["relubrication_t_s"])}

    def truth_duty_factor(self, e, t_a_s, t_b_s, x_a_m, x_b_m):
        """m at each move's mid-time (the time since the last relubrication before it)."""
        if e.lubrication_wear_growth == 0.0:
            return None
        return relubrication_growth_factor(0.5 * (t_a_s + t_b_s), np.asarray(e.relubrication_t_s, dtype=float),
                                           e.lubrication_wear_growth)

    def fit_duty_factor(self, values, problem):
        """m at each cell's time: the recorded form (b) or the interval form (T, a), whichever the fit frees."""
        m = None
        if "lubrication_wear_growth_per_s" in values:
            m = relubrication_growth_factor(problem.cells.time_s, problem.relubrication_t_s,
                                            values["lubrication_wear_growth_per_s"])
        if "lubrication_interval_s" in values:
            f = lubrication_interval_factor(problem.cells.time_s, values["lubrication_interval_s"],
                                            values["lubrication_wear_growth"])
            m = f if m is None else m * f
        return m

    def file_values(self, problem, values, t0_s):
        """The growth, interval and reference of the fit's form: the record's start for a fitted interval; the
        last recorded relubrication otherwise, with the record's mean gap between recorded ones as the interval of
        the future ones the remaining life assumes (fewer than two: none expected, the pessimistic side)."""
        if "lubrication_wear_growth_per_s" in values:            # the recorded relubrications were the time base
            relube = problem.relubrication_t_s
            gaps = np.diff(relube) if relube is not None else np.zeros(0)
            return dict(lubrication_wear_growth=float(values["lubrication_wear_growth_per_s"]),
                        lubrication_interval_s=0.0,
                        lubrication_reference_stamp_s=float(t0_s + (relube[-1] if relube is not None else 0.0)),
                        lubrication_forecast_interval_s=float(np.mean(gaps)) if gaps.size else 0.0)
        return dict(lubrication_wear_growth=float(values["lubrication_wear_growth"]),
                    lubrication_interval_s=float(values["lubrication_interval_s"]),
                    lubrication_reference_stamp_s=float(t0_s))

    def live_tau_s(self, e, t_s, last_relubrication_s):
        """The live tau [s] at times t [s since the stamps' epoch] (:func:`live_time_since_relubrication_s`
        with the parameters of ``e``)."""
        return live_time_since_relubrication_s(t_s, e.lubrication_interval_s, e.lubrication_reference_stamp_s,
                                               last_relubrication_s)

    def reference_stamp_s(self, e) -> float:
        """t_ref [s since the stamps' epoch]: the first assumed relubrication, or the last recorded one."""
        return e.lubrication_reference_stamp_s

    def growth(self, e) -> float:
        """The model's b (recorded form, 1/s) or a (interval form, -)."""
        return e.lubrication_wear_growth

    def forecast_schedule(self, e, tau_now_s: float, dln_b: float) -> dict | None:
        """The schedule the remaining life follows from now (effect_life.wear_time_s): the time since the last
        relubrication ``tau_now_s``, the interval of the next ones (the fitted T; recorded events: the forecast
        interval, 0 = none expected), the growth per unit of the file's b (1, or 1 / T) and the duty window's
        mean multiplier m_w = 1 / (1 - b dln_b), dln_b = d ln(window rate) / d b (the window's effective work
        without the multiplier is eff (1 - b dln_b)). None without the effect (not named, or no growth)."""
        if self.id not in e.effects or e.lubrication_wear_growth == 0.0:
            return None
        if e.lubrication_interval_s > 0:
            interval, per_unit = e.lubrication_interval_s, 1.0 / e.lubrication_interval_s
        else:
            interval, per_unit = e.lubrication_forecast_interval_s, 1.0
        lubfree_share = 1.0 - e.lubrication_wear_growth * dln_b
        if not (math.isfinite(lubfree_share) and lubfree_share > 0.05 and math.isfinite(tau_now_s)):
            return None
        return {"growth_per_unit": per_unit, "tau_now_s": tau_now_s, "interval_s": interval,
                "window_mean": 1.0 / lubfree_share}

    def scenario_schedule(self, schedule: dict, relubrication_interval_s: float) -> dict:
        """The forecast schedule (:meth:`forecast_schedule`) with a planning scenario's relubrication interval."""
        return dict(schedule, interval_s=float(relubrication_interval_s))


EFFECT = LubricationInterval(
    id="lubrication_interval",
    term=("recorded relubrications: m = 1 + b tau, tau the time since the last `relubricate` event (the "
          "record's start before the first); else m = 1 + a (t mod T) / T"),
    meaning="lubrication interval: wear grows with the time since the last relubrication",
    separating_duty="relubrication at recorded times (maintenance events) at another interval",
    # b per second of the time since the last relubricate event (simulation relubrication_interval_h, or
    # --maintenance relubricate events)
    simulate=SimulateValue("lubrication_wear_growth_per_s", "1/s", 0.0, "[0, 0.01]", field="lubrication_wear_growth",
                           note="relubrications every relubrication_interval_h and the --maintenance relubricate "
                                "events"),
    duty=True,
    parameters=(
        EffectParameter("lubrication_wear_growth", 0.0, "-", "[-1, 1e3]",
                        "lubrication_interval growth: b [1/s] in m = max(1 + b tau, 0) (tau since the last "
                        "relubricate event, lubrication_interval_s = 0), or a [-] in m = 1 + a ((t - t_ref) mod T) / "
                        "T; diagnose fits it down to -0.9 per interval (wear falling after a relubrication)"),
        EffectParameter("lubrication_interval_s", 0.0, "s", "[0, 1e9]",
                        "lubrication_interval T: relubricated every T from lubrication_reference_stamp_s; 0 = the "
                        "recorded relubricate maintenance events are the time base"),
        EffectParameter("lubrication_reference_stamp_s", 0.0, "s", "[0, 1e11]",
                        "lubrication_interval t_ref [s since the stamps' epoch]: the first assumed relubrication "
                        "(interval), or the last recorded one of the diagnosed record (events)"),
        EffectParameter("lubrication_forecast_interval_s", 0.0, "s", "[0, 1e9]",
                        "lubrication_interval with recorded relubrications: the interval of the future ones the "
                        "remaining life assumes (diagnose: the record's mean gap); 0 = none expected (the time since "
                        "the last keeps growing)"),
    ),
    # the model file's growth, interval and reference come from the fit's form (file_values)
    fitted_aliases=(("lubrication_wear_growth_per_s", "lubrication_wear_growth"),),
    covariance_rows=(CovarianceRow("lubrication_wear_growth", 8, 2, rate=True),),
    simulation=(EffectParameter("relubrication_interval_h", 0.0, "h", "[0, inf)",
                                "relubricate every this (recorded as maintenance events; the lubrication_interval "
                                "effect's time base); 0 = only --maintenance relubricate events"),),
    fields=(("lubrication_wear_growth", 0.0, "b [1/s] or a [-]"),
            ("lubrication_interval_s", 0.0, "T (0: the recorded relubrications are the time base)"),
            ("lubrication_reference_stamp_s", 0.0, "live t_ref"),
            ("lubrication_forecast_interval_s", 0.0, "live, recorded form: the future relubrications' interval"),
            ("relubrication_t_s", (), "offline: recorded relubrications [s from the start]")),
    # a growth after each relubrication against a smooth trend in time or K growing with the worn volume
    consistency_alternatives=("k_trend_in_time", "k_growth_with_wear"),
    recorded=("lubrication_wear_growth_per_s",),
)


def lubrication_interval_factor(time_s: np.ndarray, interval_s: float, growth: float) -> np.ndarray:
    """m of ``lubrication_interval``: 1 + a (t mod T) / T [-] (relubricated at t = 0, T, 2T, ...)."""
    t = np.asarray(time_s, dtype=float)
    return 1.0 + growth * np.mod(t, interval_s) / interval_s


def time_since_relubrication_s(time_s: np.ndarray, relubrication_t_s: np.ndarray) -> np.ndarray:
    """tau = t - (the last relubrication at or before t; the record's start t = 0 before the first) [s]."""
    t = np.asarray(time_s, dtype=float)
    events = np.sort(np.asarray(relubrication_t_s, dtype=float))
    i = np.searchsorted(events, t, side="right") - 1
    last = np.where(i >= 0, events[np.clip(i, 0, None)] if events.size else 0.0, 0.0)
    return t - np.minimum(last, t)


def relubrication_growth_factor(time_s: np.ndarray, relubrication_t_s: np.ndarray, growth_per_s: float) -> np.ndarray:
    """m of ``lubrication_interval`` with recorded relubrications: 1 + b tau [-] (tau: time since the last)."""
    return 1.0 + growth_per_s * time_since_relubrication_s(time_s, relubrication_t_s)


def live_time_since_relubrication_s(t_s, interval_s: float, reference_s: float, last_relubrication_s):
    """The live tau [s] at times t [s since the stamps' epoch]: (t - t_ref) mod T in the interval form
    (``interval_s`` > 0), t - the last relubrication (``last_relubrication_s``, EffectWear.relubrication_base_s)
    in the recorded form; 0 before the reference."""
    if interval_s > 0:
        return np.mod(np.maximum(t_s - reference_s, 0.0), interval_s)
    return np.maximum(t_s - last_relubrication_s, 0.0)


def live_factor(tau_s: np.ndarray, growth: float, interval_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(m, dm/db) at the times since relubrication tau [s]: m = max(1 + b tau', 0), tau' = tau / T (interval
    form) or tau (recorded form); dm/db = tau', 0 where m is clipped (a negative growth past the fitted gap:
    no negative wear)."""
    d_b = tau_s / interval_s if interval_s > 0 else tau_s
    lube = 1.0 + growth * d_b
    return np.maximum(lube, 0.0), np.where(lube > 0, d_b, 0.0)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """Recorded relubrications: b of m = 1 + b tau (m >= 0.1 over the longest gap); else an interval T from the
    record's start and a."""
    if c.relubrication_gap_s is not None:
        gap = c.relubrication_gap_s
        return [FitParameter("lubrication_wear_growth_per_s", "1/s", -0.9 / gap, 20.0 / gap, False, (0.5 / gap,))]
    t_fit = c.fit_end_s
    return [FitParameter("lubrication_interval_s", "s", 1800.0, max(t_fit, 3600.0), True,
                         tuple(h * 3600.0 for h in (1.5, 2.0, 3.0, 4.0, 5.5, 7.0, 9.0, 12.0, 16.0)
                               if h * 3600.0 < t_fit) or (t_fit / 2,)),
            FitParameter("lubrication_wear_growth", "-", -0.9, 20.0, False, (1.0,))]
