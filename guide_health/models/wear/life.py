"""Remaining precision life, its 90 % interval, the forecast to the limit and the judgement of a guide,
as functions of typed inputs (frozen dataclasses; SI units unless the name says otherwise).

- :func:`remaining_life_interval_s`: seed 000 Eq. 12 (straightness rate from Eq. 7/10 at the present duty)
  at K and at the ends of K's 90 % interval (the higher K, the shorter life); with the wear effects the
  interval comes from :func:`guide_health.models.wear.effect_life.life_interval_s` (delta method).
- :func:`forecast`: straightness from now to the limit over the horizon, the point forecast (with
  running-in or the relubrication schedule: effect_life.forecast_straightness_m) and the band whose edges reach
  the limit at the interval's ends.
- :func:`judge_precision` / :func:`judge_inputs`: the level and message of the `<axis> precision` status
  (thresholds moved by the clear margin for the hysteresis test, guide_health.models.levels).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from guide_health.models.levels import Level, exceeds, falls_below
from guide_health.models.wear.calibration import remaining_life_s
from guide_health.models.wear.effect_life import forecast_straightness_m


@dataclass(frozen=True)
class LifeNow:
    """Straightness now per unit K and its rate, K's estimate and 90 % interval, the margin's ends."""

    straightness_initial_m: float      # A0
    straightness_limit_m: float        # A_max
    loss_per_k_m: float                # straightness per unit K now [m]
    rate_per_k_m_s: float              # its rate at the present duty [m/s]
    wear_coefficient: float            # K
    wear_coefficient_low: float
    wear_coefficient_high: float


def remaining_life_interval_s(now: LifeNow) -> tuple[float, float, float]:
    """(life, low, high) [s] without the effects: Eq. 12 at K, at the interval's high K (low life) and at
    its low K (high life; infinite when the low K is not positive)."""
    a_max, a0, g, rate = now.straightness_limit_m, now.straightness_initial_m, now.loss_per_k_m, now.rate_per_k_m_s
    life = remaining_life_s(a_max, a0, g, rate, now.wear_coefficient)
    low = remaining_life_s(a_max, a0, g, rate, now.wear_coefficient_high)
    k_low = now.wear_coefficient_low
    high = remaining_life_s(a_max, a0, g, rate, k_low) if k_low > 0 else math.inf
    return life, low, high


@dataclass(frozen=True)
class RunningIn:
    """What the effect-aware point forecast takes (effect_life.forecast_straightness_m)."""

    rate_um_s: float                   # K x steady dA/dt per K [um/s]
    decay_ratio: float                 # r of K(s) = K (1 + r exp(-s / s0)) (registry.SLIDING_DECAY)
    decay_distance_m: float            # s0
    sliding_distance_m: float          # on the present surface
    sliding_speed_m_s: float
    lubrication: tuple | None          # effect_life.schedule_tuple


@dataclass(frozen=True)
class ForecastNow:
    """The report's life and straightness, and the time base of the guide's samples."""

    life_h: float
    life_low_h: float
    life_high_h: float
    straightness_um: float
    straightness_limit_um: float
    last_t_ns: int | None              # the last integrated joint sample
    first_t_ns: int | None
    effect_terms: RunningIn | None = None


def forecast(now: ForecastNow, points: int = 60) -> dict:
    """Straightness from now to the limit at the present duty [um] over the horizon [h]: the point forecast
    and the 90 % band, whose edges reach the limit at the interval's ends. {} without a finite life."""
    life, low, high = now.life_h, now.life_low_h, now.life_high_h
    a_now, limit = now.straightness_um, now.straightness_limit_um
    if not (math.isfinite(life) and life > 0 and math.isfinite(a_now) and now.last_t_ns):
        return {}
    end = high if math.isfinite(high) else 3.0 * life
    h = np.linspace(0.0, end, points)
    mid = a_now + (limit - a_now) * h / life
    r = now.effect_terms
    if r is not None:
        mid = forecast_straightness_m(h * 3600.0, a_now, r.rate_um_s, r.decay_ratio, r.decay_distance_m,
                                      r.sliding_distance_m, r.sliding_speed_m_s, r.lubrication)
    band = [a_now + (limit - a_now) * h / x if x > 0 else np.full_like(h, limit) for x in (low, high)]
    return {"now_h": (now.last_t_ns - (now.first_t_ns or 0)) * 1e-9 / 3600.0,
            "now_ns": int(now.last_t_ns), "horizon_h": h, "mid_um": np.minimum(mid, limit),
            "fast_um": np.minimum(band[0], limit), "slow_um": np.minimum(band[1], limit), "limit_um": limit,
            "life_h": life, "life_low_h": low, "life_high_h": high}


@dataclass(frozen=True)
class Thresholds:
    """The judgement's thresholds (wear_monitor parameters)."""

    straightness_warn_fraction: float
    life_warn_h: float
    life_error_h: float
    rejected_share_warn: float
    alarm_clear_margin: float = 0.0

    @classmethod
    def from_params(cls, p: Any) -> Thresholds:
        """The thresholds of a guide's frozen wear_monitor parameters (guide_health.params.typed)."""
        return cls(p.straightness_warn_fraction, p.life_warn_h, p.life_error_h, p.rejected_share_warn,
                   float(p.alarm_clear_margin))


@dataclass(frozen=True)
class PrecisionNow:
    """The judged numbers of one guide."""

    straightness_um: float
    straightness_limit_um: float
    remaining_life_h: float
    samples: int                       # accepted joint samples integrated
    joint: str


@dataclass(frozen=True)
class RecentInputs:
    """The input stream with the largest recent rejected share (gate.InputGate.recent_rejected_share)."""

    share: float
    stream: str
    reason: str
    window: int                        # samples in that stream's window


def judge_precision(now: PrecisionNow, th: Thresholds, margin: float = 0.0) -> tuple[Level, str]:
    """The precision level at the thresholds, or with each moved by ``margin`` towards the good side (the
    clearing test of the alarm hysteresis, guide_health.models.levels). A WARN or ERROR message names each
    rule that fired with its value and threshold (``remaining precision life 23 h < life_error_h 50 h``)."""
    a, limit, life = now.straightness_um, now.straightness_limit_um, now.remaining_life_h
    if math.isnan(a):
        if now.samples == 0:
            return Level.WARN, f"no wear estimate yet: no joint_states sample of joint '{now.joint}' accepted"
        return Level.WARN, "no wear estimate yet (waiting for motion and load)"
    if exceeds(a, limit, margin, inclusive=True):
        return Level.ERROR, (f"straightness {a:.1f} um exceeds the limit (>= straightness_limit_m "
                             f"{limit:.1f} um): precision lost")
    fired = []                         # (level, rule) of each threshold crossed
    if falls_below(life, th.life_error_h, margin):
        fired.append((Level.ERROR, f"remaining precision life {life:.0f} h < life_error_h {th.life_error_h:g} h"))
    elif falls_below(life, th.life_warn_h, margin):
        fired.append((Level.WARN, f"remaining precision life {life:.0f} h < life_warn_h {th.life_warn_h:g} h"))
    warn_um = th.straightness_warn_fraction * limit
    if exceeds(a, warn_um, margin):
        fired.append((Level.WARN, f"straightness {a:.1f} um > straightness_warn_fraction "
                                  f"{th.straightness_warn_fraction:g} x limit {limit:g} um = {warn_um:.1f} um"))
    if math.isfinite(life):
        text = f"remaining precision life {life:.0f} h at current duty (straightness {a:.1f} of {limit:.0f} um)"
    else:
        text = f"no wear at current duty (straightness {a:.1f} of {limit:.0f} um)"
    if not fired:
        return Level.OK, text
    rules = "; ".join(rule for _, rule in fired)
    if "life" in fired[0][1]:          # the life rule says the life: the rest is the straightness
        return max(level for level, _ in fired), f"{rules} at current duty (straightness {a:.1f} of {limit:.0f} um)"
    return max(level for level, _ in fired), f"{rules}; {text}"


def judge_inputs(level: Level, text: str, recent: RecentInputs, th: Thresholds) -> tuple[Level, str]:
    """WARN when most recent input of a stream was rejected (rejected_share_warn), naming the reason."""
    if recent.share <= th.rejected_share_warn:
        return level, text
    return max(level, Level.WARN), (f"{recent.share:.0%} of the last {recent.window} {recent.stream} samples "
                                    f"rejected ({recent.reason}) > rejected_share_warn "
                                    f"{th.rejected_share_warn:.0%}; {text}")


def judge(now: PrecisionNow, recent: RecentInputs, th: Thresholds) -> tuple[Level, str, Level]:
    """(level, message, level with the thresholds moved by the clear margin)."""
    level, text = judge_inputs(*judge_precision(now, th), recent, th)
    clear = judge_inputs(*judge_precision(now, th, th.alarm_clear_margin), recent, th)[0]
    return level, text, clear


def judge_model_fit(level: Level, text: str, fit: dict) -> tuple[Level, str]:
    """WARN while the model-fit test says ``broken`` (models/wear/fit_watch.py; ``fit``: its status values),
    naming since when and what to do."""
    if fit["model_fit"] != "broken":
        return level, text
    return max(level, Level.WARN), (
        f"the model no longer fits since {fit['model_fit_since_utc']} ({fit['innovations_outside_99']} of the "
        f"last {fit['innovation_window']} measurements outside the 99 % band, innovation CUSUM "
        f"{fit['innovation_cusum']:.1f} of {fit['innovation_cusum_threshold']:.2f}): run `guide-health diagnose` "
        f"on the bags since then; {text}")
