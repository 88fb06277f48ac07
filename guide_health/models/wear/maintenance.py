"""Maintenance events of a guide and what each does to its model (pure: no ROS, no I/O).

What an event resets and what it keeps (docs/machine.md), for each guide it concerns (all guides of the
axis, or the one it names):

* ``regrind`` (regrind or scrape the way): the worn surface is machined flat again. Resets the wear: the
  Archard work and the wear profile start from zero and the straightness from the value measured after the
  regrind (``straightness_m``; none given: the configured new-guide value A0). Keeps K: the material pair
  and the lubrication are unchanged, so the posterior of K (mean and sd from every measurement so far)
  becomes the prior of the new surface; the measurements of the old surface are folded into it. Keeps the
  sliding distance, the strokes and the duty (they describe the machine's use, not the surface) and the
  rolling fatigue (a regrind does not touch the raceways' subsurface). With running-in (registry.SLIDING_DECAY,
  model file) the new surface runs in again: the running-in distance counts from the regrind (a fresh scraped or
  ground surface), the effect model is then that of a new guide.
* ``replace_rail``: a new rail (way). Resets the wear as a regrind does (straightness: the measured value
  of the new rail or A0) and, for rolling guides, the fatigue life used (new raceways). Keeps K (same
  material pair and lubrication).
* ``replace_carriage``: new carriages (rolling: new balls and carriage raceways): resets the fatigue life
  used; keeps the rail's wear and straightness (the rail is the worn part) and K. Sliding guides: the
  slider is the harder part (the softer way wears, seed 000), so nothing of the model changes; logged.
* ``relubricate``: fresh lubricant. Rolling guides: the recent boundary-lubrication share restarts (its
  forgetting window), the whole-history shares are kept; nothing else changes. Sliding guides: K is fitted
  under the guide's normal lubrication, so nothing changes; logged (a wear rate that changes after it shows
  in the following measurements).
* ``measure``: a manual straightness measurement [m] with its own time: a measurement like those of the
  straightness topic (it updates K), dated by the event's stamp.

An event is identified by (stamp, kind, axis, guide): the same event seen twice (the node's own event
coming back on the topic, a replayed bag) is applied once. The same action (axis, guide, kind and value)
stamped again within ``maintenance_repeat_window_s`` of an applied or pending one is a repeat (a second
click, a retried script): refused, never applied twice. An event that cannot be applied is counted under one
reason of models/wear/input_rules.py (``rejected: maintenance event <reason>``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from datetime import UTC, datetime

import numpy as np

from guide_health.errors import InputError
from guide_health.models.wear.calibration import WearCoefficientEstimator
from guide_health.models.wear.input_rules import (
    MAINTENANCE_MEASURE_WITHOUT_VALUE,
    MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE,
    MAINTENANCE_STRAIGHTNESS_NOT_BELOW_LIMIT,
    MAINTENANCE_UNKNOWN_GUIDE,
    MAINTENANCE_UNKNOWN_KIND,
)

KINDS = ("regrind", "replace_rail", "replace_carriage", "relubricate", "measure")
#: kinds whose ``straightness_m`` is the straightness after the event (NaN: A0)
RESETS_WEAR = ("regrind", "replace_rail")
RESETS_FATIGUE = ("replace_rail", "replace_carriage")


@dataclass(frozen=True)
class MaintenanceEvent:
    t_ns: int                       # when it happened, in the machine's time base (header stamps)
    kind: str                       # one of KINDS
    axis: str
    guide: str = ""                 # '' = every guide of the axis
    straightness_m: float = math.nan  # after a regrind/rail replacement, or the manual reading (measure)
    source: str = ""                # e.g. service, topic, simulate
    note: str = ""                  # free text entered with it (who, what)

    @property
    def key(self) -> tuple:
        return (int(self.t_ns), self.kind, self.axis, self.guide)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["straightness_um"] = self.straightness_m * 1e6
        del d["straightness_m"]
        if not self.note:
            del d["note"]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> MaintenanceEvent:
        return cls(int(d["t_ns"]), str(d["kind"]), str(d["axis"]), str(d.get("guide", "")),
                   float(d.get("straightness_um", math.nan)) * 1e-6, str(d.get("source", "")), str(d.get("note", "")))


#: the length units a straightness is entered in (longest suffix first: 'mm' before 'm')
LENGTH_UNITS_M = (("um", 1e-6), ("\u00b5m", 1e-6), ("mm", 1e-3), ("m", 1.0))


def straightness_from_text(text: str) -> float:
    """A straightness entered with its unit (``4um``, ``4 um``, ``4e-6m``, ``0.004mm``) in m; InputError (one
    line) for a missing or unknown unit, a value that is not a finite number >= 0."""
    body = str(text).strip()
    for suffix, scale in LENGTH_UNITS_M:
        if body.endswith(suffix):
            number = body[:-len(suffix)].strip()
            try:
                value = float(number) * scale
            except ValueError:
                break
            if not (math.isfinite(value) and value >= 0.0):
                raise InputError(f"straightness {clip(text)} must be a finite number >= 0 with its unit")
            return value
    raise InputError(f"straightness {clip(text)} needs a number and its unit (um, mm or m), e.g. 4um")


def relubrication_times_s(events, axis: str, t0_ns: int) -> np.ndarray | None:
    """The recorded relubrications of ``axis`` (of any of its guides) [s from ``t0_ns``], sorted; None when
    there are none (the discrepancy workflow's relubrication effect then fits an interval)."""
    times = sorted((e.t_ns - t0_ns) * 1e-9 for e in events if e.kind == "relubricate" and e.axis == axis)
    return np.asarray(times, dtype=float) if times else None


def event_rejection(event: MaintenanceEvent, guides, straightness_limit_m: float) -> tuple[str, str] | None:
    """(the counted reason, input_rules.MAINTENANCE_*, and the details) why ``event`` cannot be applied to an
    axis with ``guides``, or None."""
    if event.kind not in KINDS:
        return MAINTENANCE_UNKNOWN_KIND, f"unknown maintenance kind {clip(event.kind)} (one of {', '.join(KINDS)})"
    if event.guide and event.guide not in guides:
        return MAINTENANCE_UNKNOWN_GUIDE, (f"axis {event.axis} has no guide {clip(event.guide)} "
                                           f"(guides: {', '.join(guides)})")
    a = event.straightness_m
    if event.kind == "measure" and math.isnan(a):
        return MAINTENANCE_MEASURE_WITHOUT_VALUE, "a straightness measurement needs its value"
    if not math.isnan(a) and not (math.isfinite(a) and 0.0 <= a < 10.0 * straightness_limit_m):
        return MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE, (f"straightness {a!r} m is not a plausible measurement "
                                                      f"(0 to 10 x straightness_limit_m)")
    if event.kind in RESETS_WEAR and not math.isnan(a) and not a < straightness_limit_m:
        return MAINTENANCE_STRAIGHTNESS_NOT_BELOW_LIMIT, (f"straightness after {event.kind} {a * 1e6:.1f} um is "
                                                          f"not below the limit {straightness_limit_m * 1e6:g} um")
    return None


def check_event(event: MaintenanceEvent, guides, straightness_limit_m: float) -> str | None:
    """Why ``event`` cannot be applied to an axis with ``guides`` (:func:`event_rejection`'s details), or None."""
    rejection = event_rejection(event, guides, straightness_limit_m)
    return None if rejection is None else rejection[1]


def clip(value, chars: int = 40) -> str:
    """A value from outside quoted for a message, at most ``chars`` characters of it."""
    text = repr(value)
    return text if len(text) <= chars else text[:chars] + "...'"


def same_action(a: MaintenanceEvent, b: MaintenanceEvent) -> bool:
    """The same maintenance: axis, guide, kind and value (NaN = no value equals NaN)."""
    if (a.axis, a.guide, a.kind) != (b.axis, b.guide, b.kind):
        return False
    x, y = a.straightness_m, b.straightness_m
    return (math.isnan(x) and math.isnan(y)) or x == y


def repeat_of(event: MaintenanceEvent, seen, window_s: float) -> MaintenanceEvent | None:
    """The event of ``seen`` that ``event`` repeats: the same action (:func:`same_action`) stamped within
    ``window_s`` of it (machine time base, so live and offline agree), else None. A second call of the same
    regrind or measurement (a double click, a retried script) is then refused instead of applied twice."""
    window_ns = window_s * 1e9
    for earlier in reversed(list(seen)):
        if same_action(event, earlier) and abs(int(event.t_ns) - int(earlier.t_ns)) <= window_ns:
            return earlier
    return None


def stamp_text(t_ns: int) -> str:
    """A machine stamp [ns since the epoch] as UTC date and time, with the stamp itself."""
    when = datetime.fromtimestamp(int(t_ns) // 1_000_000_000, tz=UTC)
    return f"{when:%Y-%m-%d %H:%M:%S} UTC ({int(t_ns)} ns)"


def baseline(monitor) -> dict:
    """What a wear reset changed in a guide's monitor (persisted, re-applied after a restart)."""
    est = monitor.estimator
    return {"straightness_initial_m": est.straightness_initial_m, "wear_coefficient": est.prior_wear_coefficient,
            "wear_coefficient_prior_rel_sd": est.prior_rel_sd}


#: the parameters a wear reset changes (:func:`baseline`)
BASELINE_KEYS = ("straightness_initial_m", "wear_coefficient", "wear_coefficient_prior_rel_sd")


def apply_baseline(monitor, values: dict) -> None:
    """Re-apply a :func:`baseline` (a restored monitor takes its prior and A0 from the parameters)."""
    monitor.params = dataclasses.replace(monitor.params, **{key: values[key] for key in BASELINE_KEYS})
    est = monitor.estimator
    est.straightness_initial_m = float(values["straightness_initial_m"])
    est.prior_wear_coefficient = float(values["wear_coefficient"])
    est.prior_rel_sd = float(values["wear_coefficient_prior_rel_sd"])


def reset_wear(monitor, straightness_after_m: float) -> None:
    """The worn surface made new (regrind, rail replacement): module text. ``straightness_after_m`` NaN:
    the configured A0."""
    a_after = straightness_after_m
    if math.isnan(a_after):
        a_after = monitor.straightness_initial_configured_m
        if a_after is None:
            a_after = monitor.params.straightness_initial_m
    if monitor.straightness_initial_configured_m is None:
        monitor.straightness_initial_configured_m = monitor.params.straightness_initial_m
    k, k_sd, _ = monitor.estimator.posterior(monitor.measurement_losses_per_k_m())
    integ = monitor.integrator
    integ.archard_work_nm = 0.0
    integ.profile_work_n = np.zeros_like(integ.profile_work_n)
    if getattr(monitor, "effect_wear", None) is not None:     # running-in restarts on the new surface
        monitor.effect_wear.new_surface(integ.sliding_distance_m)
    old = monitor.estimator
    monitor.estimator = WearCoefficientEstimator(prior_wear_coefficient=k, prior_rel_sd=k_sd / k if k > 0 else
                                                 old.prior_rel_sd, noise_sd_m=old.noise_sd_m,
                                                 straightness_initial_m=float(a_after))
    apply_baseline(monitor, baseline(monitor))


def reset_fatigue(monitor) -> None:
    """New rolling elements and raceways: the fatigue life used starts from zero (rolling guides)."""
    rolling = monitor.rolling
    if rolling is None:
        return
    from guide_health.models.rolling.rolling_guide import RollingGuideMonitor

    fresh = RollingGuideMonitor(rolling.params)
    rolling.fatigue = fresh.fatigue


def relubricate(monitor, t_ns: int) -> None:
    """Fresh lubricant: the recent boundary-lubrication share restarts (rolling guides); the live
    relubrication factor's time since relubrication restarts (registry.RELUBRICATION)."""
    if getattr(monitor, "effect_wear", None) is not None:
        monitor.effect_wear.relubricated(t_ns)
    if monitor.rolling is not None:
        monitor.rolling.boundary_travel_m = 0.0
        monitor.rolling.window_travel_m = 0.0


def apply_event(monitor, event: MaintenanceEvent) -> None:
    """Apply a regrind, rail or carriage replacement or relubrication ``event`` to one guide's physics at its
    present time (a ``measure`` is a straightness measurement: AxisMonitor sends it through its input gate)."""
    if event.kind in RESETS_WEAR:
        reset_wear(monitor, event.straightness_m)
    if event.kind in RESETS_FATIGUE:
        reset_fatigue(monitor)
    if event.kind == "relubricate":
        relubricate(monitor, int(event.t_ns))


def wear_resets(events, axis: str) -> list[tuple[int, float]]:
    """The wear resets (regrind, rail replacement) of ``axis`` as (t_ns, straightness after [m]; NaN: A0), in
    stamp order: where the discrepancy workflow starts a new surface."""
    return sorted((int(e.t_ns), float(e.straightness_m)) for e in events if e.kind in RESETS_WEAR and e.axis == axis)
