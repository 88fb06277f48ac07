"""Maintenance planning: the calendar date an axis reaches its straightness limit at the observed utilisation,
and under what-if scenarios (pure numpy, SI units; docs/planning.md).

One code path: :func:`life_interval` is the remaining life (life, low, high) [running s] the live status
reports (models/wear/axis.py calls it); a :class:`Scenario` only transforms its inputs (:func:`scenario_inputs`)
and the same function computes the scenario's life. The no-change scenario leaves the inputs as they are.

The calendar date (running_time.py): t_limit = t_now + L / u, u the utilisation. Its 90 % band combines the
life's interval (K's and the effects' uncertainty, already in (low, high)) with the utilisation's variability
on ln: ln(L / u) = ln L - ln u, sd(ln u) = cv_d sqrt(1 / n + 1 / m), cv_d the coefficient of variation of the
daily utilisations of the window's n whole days (the error of the observed mean) and m the days the forecast
spans (the future mean over m days varies by cv_d / sqrt(m) about it); each side's half-width on ln is
sqrt(h_life^2 + (z sd(ln u))^2), h_life = ln(L / low) or ln(high / L). A shift pattern given by the planner
is a decision, not an observation: its utilisation carries no spread.
"""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from datetime import UTC, datetime

import numpy as np

from guide_health.models.wear.calibration import Z90
from guide_health.models.wear.effect_life import life_interval_s
from guide_health.models.wear.effects.registry import RATE_NAMES, RELUBRICATION, SCENARIO_FACTORS
from guide_health.models.wear.fit_watch import widened_life_interval_s
from guide_health.models.wear.form_average import form_averaged_interval_s
from guide_health.models.wear.life import LifeNow, remaining_life_interval_s
from guide_health.models.wear.running_time import NS_PER_S, RunningClock, utc_text

DAY_S = 86400.0
WEEK_H = 168.0
LIMIT_KEYS = ("limit_date_utc", "limit_date_utc_low", "limit_date_utc_high")
_LN_RATE = {name: i for i, name in enumerate(RATE_NAMES)}


@dataclass(frozen=True)
class LifeInputs:
    """What one guide's remaining life is computed from: ``now`` (life.LifeNow), ``effect`` (the arguments
    (k, k_sd, EffectParameters, EffectLifeNow, z) of effect_life.life_interval_s, None without the wear
    effects), ``widen_rms`` (the innovations' rms z while the model-fit test says broken, else None) and
    ``forms`` (the decay laws' forecasts: (ln-life offsets, BIC weights, z, ln-sd ratios, envelope) of
    form_average.form_averaged_interval_s, or None)."""

    now: LifeNow
    effect: tuple | None = None
    widen_rms: float | None = None
    forms: tuple | None = None


def life_interval(inputs: LifeInputs) -> tuple[float, float, float]:
    """(life, low, high) [running s]: effect_life.life_interval_s with the effects, else
    life.remaining_life_interval_s (seed 000 Eq. 12); the running-in forms averaged in; widened by fit_watch
    while the model is broken."""
    life = life_interval_s(*inputs.effect) if inputs.effect is not None else remaining_life_interval_s(inputs.now)
    if inputs.forms is not None:      # the running-in forms' forecasts averaged in (form_average.py)
        life = form_averaged_interval_s(life, *inputs.forms)
    if inputs.widen_rms is not None:
        life = widened_life_interval_s(life, inputs.widen_rms)
    return life


@dataclass(frozen=True)
class Scenario:
    """A what-if: scales of the future duty, a relubrication interval, a shift pattern, a regrind.

    load_scale / speed_scale / stroke_scale multiply the load, the feed speed and the stroke lengths of the
    present duty; relubrication_interval_s replaces the relubrication effect's interval (None: as observed);
    hours_per_day x days_per_week replace the observed utilisation (None: observed); regrind_t_ns restores the
    straightness to A0 at that stamp (None: no regrind)."""

    name: str = "as observed"
    load_scale: float = 1.0
    speed_scale: float = 1.0
    stroke_scale: float = 1.0
    relubrication_interval_s: float | None = None
    hours_per_day: float | None = None
    days_per_week: float | None = None
    regrind_t_ns: int | None = None


#: scenario keys of the text grammar and the YAML file -> (Scenario field, unit parser)
_DURATION_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0, "d": DAY_S, "w": 7 * DAY_S}


def duration_s(text: str) -> float:
    """'250h', '2w', '3600s', '90min', '10d' -> seconds (a bare number is hours)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(s|min|h|d|w)?\s*", str(text))
    if not m:
        raise ValueError(f"'{text}' is no duration (a number with s, min, h, d or w)")
    return float(m.group(1)) * _DURATION_UNITS[m.group(2) or "h"]


def date_ns(text: str) -> int:
    """'2027-03-01' or '2027-03-01T06:00:00Z' (UTC) -> ns since the epoch."""
    try:
        when = datetime.fromisoformat(str(text).strip().replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"'{text}' is no date (YYYY-MM-DD or YYYY-MM-DDTHH:MM:SSZ, UTC)") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return int(round(when.timestamp())) * NS_PER_S


def _positive(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"scenario {key}={text}: not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"scenario {key}={text}: must be a finite number > 0")
    return value


def _shift(text: str) -> tuple[float, float]:
    m = re.fullmatch(r"\s*([0-9.]+)\s*[xX*]\s*([0-9.]+)\s*", str(text))
    if not m:
        raise ValueError(f"scenario shift={text}: give HOURS_PER_DAYxDAYS_PER_WEEK, e.g. shift=8x5")
    hours, days = float(m.group(1)), float(m.group(2))
    if not (0 < hours <= 24 and 0 < days <= 7):
        raise ValueError(f"scenario shift={text}: hours per day in (0, 24], days per week in (0, 7]")
    return hours, days


def scenario_from_items(name: str, items: dict) -> Scenario:
    """A Scenario from key -> value text (the grammar of :func:`parse_scenario`; a YAML mapping)."""
    fields: dict = {"name": name}
    for key, value in items.items():
        key, text = str(key).strip(), str(value).strip()
        if key in ("load", "speed", "stroke"):
            fields[f"{key}_scale"] = _positive(key, text)
        elif key == "relube":
            fields["relubrication_interval_s"] = duration_s(text)
            if not fields["relubrication_interval_s"] > 0:
                raise ValueError(f"scenario relube={text}: the interval must be > 0")
        elif key == "shift":
            fields["hours_per_day"], fields["days_per_week"] = _shift(text)
        elif key == "regrind":
            fields["regrind_t_ns"] = date_ns(text)
        else:
            raise ValueError(f"scenario key '{key}' unknown (load, speed, stroke, relube, shift, regrind)")
    return Scenario(**fields)


def parse_scenario(text: str) -> Scenario:
    """``[NAME:] key=value[, key=value ...]``, keys load / speed / stroke (scales > 0), relube (an interval:
    250h, 2w), shift (HOURSxDAYS, 8x5), regrind (a UTC date, 2027-03-01); the name defaults to the text."""
    name, _, body = str(text).rpartition(":") if re.match(r"^[^=]*:", str(text)) else ("", "", str(text))
    items = {}
    for part in filter(None, (p.strip() for p in body.split(","))):
        key, eq, value = part.partition("=")
        if not eq or not key.strip() or not value.strip():
            raise ValueError(f"scenario '{text}': '{part}' is not key=value")
        items[key.strip()] = value.strip()
    if not items:
        raise ValueError(f"scenario '{text}': no key=value")
    return scenario_from_items(name.strip() or body.strip(), items)


# --- the scenario's life: the live inputs transformed ---------------------------------------------------
def _duty_rate_scale(s: Scenario, e, v_s: float) -> float:
    """The factor of the steady wear rate per running second: Archard's dV/dt = K W v / H (Eq. 3) with the load
    raised to the effect's exponent (W^n, the first of registry.SCENARIO_FACTORS that gives one; 1 without) times
    the factors' multipliers' change at the scaled duty (scenario_rate_factor), over the stroke scale (Eq. 7: A / V =
    2 / (b (l_min + l_max)), and per pass: passes per second scale as v / l)."""
    factors = SCENARIO_FACTORS if e is not None else ()
    n = next((n for f in factors if (n := f.scenario_load_exponent(e)) is not None), 1.0)
    factor = s.load_scale ** n * s.speed_scale / s.stroke_scale
    for f in factors:
        m = f.scenario_rate_factor(e, s, v_s)
        if m is not None:
            factor *= m
    return factor


def _effect_inputs(effect: tuple, s: Scenario, fresh: bool) -> tuple:
    k, k_sd, e, now, z = effect
    factor = _duty_rate_scale(s, e, now.v_s)
    dln = np.array(now.dln_rate, dtype=float)
    for f in SCENARIO_FACTORS:
        dln[_LN_RATE[f.rate_row]] = f.scenario_dln(e, s, now.v_s, dln[_LN_RATE[f.rate_row]])
    lub = now.lubrication
    if s.relubrication_interval_s is not None:
        lub = RELUBRICATION.scenario_schedule(lub, s.relubrication_interval_s)
    changes = dict(rate_work_per_k=now.rate_work_per_k * factor, rate_pass_per_k=now.rate_pass_per_k * factor,
                   v_s=now.v_s * s.speed_scale, dln_rate=dln, lubrication=lub)
    if fresh:    # a reground surface: no past wear, running-in from its start
        changes.update(work=0.0, pass_work=0.0, work_gradient=np.zeros_like(np.asarray(now.work_gradient)),
                       s_now=0.0)
    return k, k_sd, e, dataclasses.replace(now, **changes), z


def scenario_inputs(inputs: LifeInputs, s: Scenario, fresh: bool = False) -> LifeInputs:
    """The live inputs under a scenario's duty (``fresh``: on a reground surface, A = A0 now). Without the
    effects only the rate per K moves (and the straightness now when fresh)."""
    if s.relubrication_interval_s is not None and (inputs.effect is None or inputs.effect[3].lubrication is None):
        raise ValueError(f"scenario relube needs the {RELUBRICATION.id} effect named, with a growth, in the model")
    if inputs.effect is not None:
        effect = _effect_inputs(inputs.effect, s, fresh)
        return dataclasses.replace(inputs, effect=effect)
    now = inputs.now
    rate = now.rate_per_k_m_s * _duty_rate_scale(s, None, math.nan)
    return dataclasses.replace(inputs, now=dataclasses.replace(now, rate_per_k_m_s=rate,
                                                               loss_per_k_m=0.0 if fresh else now.loss_per_k_m))


# --- utilisation and the calendar ----------------------------------------------------------------------
@dataclass(frozen=True)
class Utilisation:
    """u (running share of calendar time) and its day-to-day coefficient of variation over n whole days."""

    mean: float
    cv_daily: float = 0.0
    days: int = 0

    def sd_ln(self, forecast_days: float) -> float:
        """sd(ln u) of the mean utilisation over the forecast (module text); 0 under two whole days."""
        if self.days < 2 or not math.isfinite(forecast_days):
            return 0.0
        return self.cv_daily * math.sqrt(1.0 / self.days + 1.0 / max(forecast_days, 1.0))


def observed_utilisation(clock: RunningClock) -> Utilisation:
    """The status's utilisation (RunningClock.utilisation) and the spread of its window's whole days, each day
    counted backwards from the latest sample: u_d = 1 - idle in the day / 1 day."""
    u = clock.utilisation()
    if clock.first_t_ns is None or not math.isfinite(u):
        return Utilisation(u)
    now = clock.last_t_ns
    day_ns = int(DAY_S * NS_PER_S)
    span = min(int(round(clock.utilisation_window_days * DAY_S * NS_PER_S)), now - clock.first_t_ns)
    days = span // day_ns
    pauses = clock.idle_pauses()
    daily = np.array([1.0 - sum(max(0, min(b, now - i * day_ns) - max(a, now - (i + 1) * day_ns))
                                for a, b in pauses) / day_ns for i in range(days)])
    if days < 2 or not daily.mean() > 0:
        return Utilisation(u, 0.0, int(days))
    return Utilisation(u, float(daily.std(ddof=1) / daily.mean()), int(days))


def shift_utilisation(hours_per_day: float, days_per_week: float) -> Utilisation:
    """u = hours per day x days per week / 168 h (a planned pattern: no spread)."""
    return Utilisation(hours_per_day * days_per_week / WEEK_H)


def calendar_band_s(life: tuple[float, float, float], u: Utilisation) -> tuple[float, float, float]:
    """Calendar seconds (L / u and its band, module text) of a running life (life, low, high) [s]."""
    mid, low, high = life
    if not (u.mean > 0 and math.isfinite(mid) and mid >= 0):
        return (mid / u.mean if u.mean > 0 else math.nan,) * 3
    spread = Z90 * u.sd_ln(mid / u.mean / DAY_S)
    if spread == 0.0 or mid == 0.0:
        return mid / u.mean, low / u.mean, high / u.mean
    h_low = math.log(mid / low) if low > 0 else math.inf
    h_high = math.log(high / mid) if mid > 0 and math.isfinite(high) else math.inf
    return (mid / u.mean, mid / u.mean * math.exp(-math.hypot(h_low, spread)),
            mid / u.mean * math.exp(math.hypot(h_high, spread)))


def _stamp(now_ns: int, calendar_s: float) -> float:
    return now_ns + calendar_s * NS_PER_S if math.isfinite(calendar_s) else math.inf


def status_calendar_keys(clock: RunningClock, life_s: tuple[float, float, float]) -> dict:
    """The status's calendar keys: ``utilisation``, ``limit_date_utc`` and its band ``_low`` / ``_high`` (the
    band of :func:`calendar_band_s`, the observed utilisation's daily spread included: the plan's 'as
    observed' dates) from the latest sample, '' where unknown or never; while idle, ``idle_since_utc``."""
    u, now = observed_utilisation(clock), clock.last_t_ns
    cal = calendar_band_s(life_s, u) if now is not None else (math.nan,) * 3
    out = {"utilisation": u.mean,
           **{key: utc_text(_stamp(now, c)) if now is not None else "" for key, c in zip(LIMIT_KEYS, cal)}}
    idle = clock.idle_since_ns()
    if idle is not None:
        out["idle_since_utc"] = utc_text(idle)
    return out


def plan_scenario(inputs: LifeInputs, observed: Utilisation, now_ns: int, s: Scenario | None = None) -> dict:
    """One scenario's limit date and band from now (``now_ns``: the latest sample, as the status): its life
    (life_h, _low, _high [running h]), utilisation and the stamps / UTC dates of the limit. A regrind at D
    after now: the limit of the present surface when it comes first (``regrind_late``), else D + the life of
    the fresh surface at the scenario's duty (the band's low end the present surface's when that falls
    before D)."""
    s = Scenario() if s is None else s
    u = observed if s.hours_per_day is None else shift_utilisation(s.hours_per_day, s.days_per_week)
    life = life_interval(scenario_inputs(inputs, s))
    cal = calendar_band_s(life, u)
    stamps = [_stamp(now_ns, c) for c in cal]
    out = {"scenario": s.name, "utilisation": u.mean, "utilisation_cv_daily": u.cv_daily,
           "utilisation_days": u.days, "life_h": life[0] / 3600.0, "life_h_low": life[1] / 3600.0,
           "life_h_high": life[2] / 3600.0}
    if s.regrind_t_ns is not None:
        if s.regrind_t_ns <= now_ns:
            raise ValueError(f"scenario regrind at {utc_text(s.regrind_t_ns)}: not after the data's present "
                             f"{utc_text(now_ns)}")
        out["regrind_utc"] = utc_text(s.regrind_t_ns)
        out["regrind_late"] = bool(stamps[0] <= s.regrind_t_ns)
        out["present_limit_t_ns"] = stamps[0]                                 # the present surface's
        if not out["regrind_late"]:
            fresh = life_interval(scenario_inputs(inputs, s, fresh=True))
            before = (s.regrind_t_ns - now_ns) / NS_PER_S * u.mean            # running s until the regrind
            after = [_stamp(s.regrind_t_ns, c) for c in calendar_band_s(fresh, u)]
            low = stamps[1] if stamps[1] < s.regrind_t_ns else after[1]
            stamps = [after[0], low, after[2]]
            out.update(life_h=(before + fresh[0]) / 3600.0, life_h_high=(before + fresh[2]) / 3600.0,
                       life_h_low=(life[1] if low < s.regrind_t_ns else before + fresh[1]) / 3600.0)
    out.update(limit_t_ns=stamps[0], limit_t_ns_low=stamps[1], limit_t_ns_high=stamps[2],
               limit_date_utc=utc_text(stamps[0]), limit_date_utc_low=utc_text(stamps[1]),
               limit_date_utc_high=utc_text(stamps[2]))
    return out
