"""Maintenance events of a guide and what each does to its model (pure: no ROS, no I/O).

What an event resets and what it keeps (docs/machine.md), for each guide it concerns (all guides of the
axis, or the one it names):

* ``regrind`` (regrind or scrape the way): the worn surface is machined flat again. Resets the wear: the
  Archard work and the wear profile start from zero and the straightness from the value measured after the
  regrind (``straightness_m``; none given: the configured new-guide value A0). Keeps K: the material pair
  and the lubrication are unchanged, so the posterior of K (mean and sd from every measurement so far)
  becomes the prior of the new surface; the measurements of the old surface are folded into it. Keeps the
  sliding distance, the strokes and the duty (they describe the machine's use, not the surface) and the
  rolling fatigue (a regrind does not touch the raceways' subsurface). With the running_in effect (model
  file) the new surface runs in again: the running-in distance counts from the regrind (a fresh scraped or
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
coming back on the topic, a replayed bag) is applied once.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass

import numpy as np

from guide_health.models.wear.calibration import WearCoefficientEstimator

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

    @property
    def key(self) -> tuple:
        return (int(self.t_ns), self.kind, self.axis, self.guide)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["straightness_um"] = self.straightness_m * 1e6
        del d["straightness_m"]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> MaintenanceEvent:
        return cls(int(d["t_ns"]), str(d["kind"]), str(d["axis"]), str(d.get("guide", "")),
                   float(d.get("straightness_um", math.nan)) * 1e-6, str(d.get("source", "")))


def relubrication_times_s(events, axis: str, t0_ns: int) -> np.ndarray | None:
    """The recorded relubrications of ``axis`` (of any of its guides) [s from ``t0_ns``], sorted; None when
    there are none (the lubrication_interval effect of the discrepancy workflow then fits an interval)."""
    times = sorted((e.t_ns - t0_ns) * 1e-9 for e in events if e.kind == "relubricate" and e.axis == axis)
    return np.asarray(times, dtype=float) if times else None


def check_event(event: MaintenanceEvent, guides, straightness_limit_m: float) -> str | None:
    """Why ``event`` cannot be applied to an axis with ``guides``, or None."""
    if event.kind not in KINDS:
        return f"unknown maintenance kind {event.kind!r} (one of {', '.join(KINDS)})"
    if event.guide and event.guide not in guides:
        return f"axis {event.axis} has no guide {event.guide!r} (guides: {', '.join(guides)})"
    a = event.straightness_m
    if event.kind == "measure" and not math.isfinite(a):
        return "a straightness measurement needs its value"
    if not math.isnan(a) and not (math.isfinite(a) and 0.0 <= a < 10.0 * straightness_limit_m):
        return f"straightness {a!r} m is not a plausible measurement"
    if event.kind in RESETS_WEAR and not math.isnan(a) and not a < straightness_limit_m:
        return f"straightness after {event.kind} {a * 1e6:.1f} um is not below the limit"
    return None


def baseline(monitor) -> dict:
    """What a wear reset changed in a guide's monitor (persisted, re-applied after a restart)."""
    est = monitor.estimator
    return {"straightness_initial_m": est.straightness_initial_m, "wear_coefficient": est.prior_wear_coefficient,
            "wear_coefficient_prior_rel_sd": est.prior_rel_sd}


def apply_baseline(monitor, values: dict) -> None:
    """Re-apply a :func:`baseline` (a restored monitor takes its prior and A0 from the parameters)."""
    monitor.params = dataclasses.replace(monitor.params, **values)
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
    lubrication_interval effect's time since relubrication restarts."""
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
