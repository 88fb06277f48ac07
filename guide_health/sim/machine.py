"""Synthetic machine runs (pure numpy): a sliding guide doing random feed strokes as on seed 000's bench.

The motion is sim/motion.py's piecewise-linear feed / retract / dwell cycles; the bag samples it at the
JointState rate, the load at the load rate, the guide temperature (sim/thermal.py) when recorded.
The measured straightness is the truth (same model family as the monitor's, with the true K) plus
Gaussian noise, every ``measurement_interval_h``.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from guide_health.errors import InputError
from guide_health.models.wear.archard import WearGeometry, WearIntegrator, straightness_from_wear_volume_m
from guide_health.models.wear.effects.multiplier import effect_multiplier, measured_straightness_m
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import (
    BY_ID,
    CANDIDATE_IDS,
    DUTY_FACTORS,
    PASS_WEIGHTING,
    RECORDED_EFFECT_PARAMETERS,
    SLIDING_DECAY,
    SPEED_SHARE,
    simulate_field,
)
from guide_health.models.wear.maintenance import KINDS, MaintenanceEvent, check_event, straightness_from_text
from guide_health.params.schema import Param
from guide_health.params.typed import guide_params, wear_axis_params
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA
from guide_health.runs import MachineRun
from guide_health.sim.motion import (
    MachineKnots,
    cycle_knots,
    jerk_limited_knots,
    position_at,
    s_curve_mean,
    share_of_move_at,
)
from guide_health.sim.thermal import temperature_records

EFFECTS = CANDIDATE_IDS
START_TIME_NS = 1_700_000_000 * 10**9


def parse_effects(items: list[str] | None) -> dict[str, float]:
    """``NAME=VALUE`` strings to a dict, names checked against :data:`EFFECTS`."""
    effects: dict[str, float] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            raise InputError(f"--effect takes NAME=VALUE, got {item!r}")
        if name not in EFFECTS:
            raise InputError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        try:
            effects[name] = float(value)
        except ValueError:
            raise InputError(f"--effect {name}: value {value!r} is not a number") from None
        if not math.isfinite(effects[name]):
            raise InputError(f"--effect {name}: value must be finite")
    return effects


def simulate_machine(params: dict[str, Any], sim: dict[str, Any], seed: int = 0,
                     effects: dict[str, float] | None = None, new_surface_t_s=(),
                     relubrication_t_s=()) -> MachineRun:
    """A :class:`MachineRun` of the scenario ``sim`` for a guide with wear parameters ``params``.
    ``new_surface_t_s``: times [s from the start] of wear resets (regrind, new rail; see
    :func:`apply_maintenance_truth`), from which the new surface runs in again (registry SLIDING_DECAY).
    ``relubrication_t_s``: recorded relubrications [s from the start] besides the automatic ones every
    ``relubrication_interval_h`` (:func:`relubrication_times_s`; registry RELUBRICATION's time base)."""
    effects = checked_effects(effects)
    rng = np.random.default_rng(seed)
    knots = cycle_knots(rng, sim)
    if sim["motion_profile"] == "jerk_limited":
        knots = jerk_limited_knots(knots, sim)
    # encoder noise and the load clock's jitter come from streams of their own: a twin without them is the same run
    encoder_rng, load_clock_rng = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
    geometry = WearGeometry.from_params(guide_params(params))
    if effects and geometry.straightness_model != "eq7":
        raise InputError("--effect needs straightness_model: eq7 (the baseline the effects are defined against)")
    run_facts = {"relubrication_t_s": relubrication_times_s(sim, relubrication_t_s, float(knots.t_s[-1])),
                 "work_weighted_position_m": work_weighted_position_m(knots)}
    wear_effects = EffectParameters.from_values(
        effects, **{k: v for e in BY_ID.values() for k, v in e.simulation_fields(sim, run_facts).items()})
    # the random draws come in this order: strokes (above), load noise, temperature, straightness noise
    joint_t_s, position_m, velocity_m_s = joint_samples(knots, sim["joint_state_rate_hz"])
    if sim["encoder_noise_m"] > 0:
        position_m = position_m + encoder_rng.normal(0.0, sim["encoder_noise_m"], position_m.size)
    load_t_s, load_n = load_samples(knots, sim, rng, load_clock_rng)
    measurement_t_s = np.arange(0.0, knots.t_s[-1] + 1e-9, sim["measurement_interval_h"] * 3600.0)
    temperature_t_s, temperature_c, temperature_at_measurements_c = temperature_records(
        knots, sim, any(BY_ID[e].needs_temperature for e in effects), measurement_t_s, rng)
    truth_k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    resets = np.sort(np.asarray(new_surface_t_s, dtype=float))
    wear_all = true_straightness_wear_m(params, geometry, knots, wear_effects, truth_k,
                                        np.concatenate((measurement_t_s, resets)), resets)
    wear_m = wear_all[:measurement_t_s.size]
    d_temp = (None if temperature_at_measurements_c is None
              else temperature_at_measurements_c - temperature_at_measurements_c[0])
    truth_m = measured_straightness_m(wear_m, params["straightness_initial_m"], d_temp, wear_effects)
    measured_m = truth_m + rng.normal(0.0, sim["straightness_noise_m"], measurement_t_s.size)
    truth = true_run_values(knots, geometry, truth_k, truth_m, measurement_t_s)
    if resets.size:     # the noise-free straightness at each wear reset (apply_maintenance_truth's start)
        truth["straightness_at_resets"] = [[float(t), float(params["straightness_initial_m"] + w)]
                                           for t, w in zip(resets, wear_all[measurement_t_s.size:])]
    return MachineRun(
        joint_name=params["joint"],
        joint_t_ns=stamps_ns(joint_t_s),
        joint_position_m=position_m,
        joint_velocity_m_s=velocity_m_s,
        load_t_ns=stamps_ns(load_t_s),
        load_n=load_n,
        straightness_t_ns=stamps_ns(measurement_t_s),
        straightness_m=measured_m,
        temperature_t_ns=stamps_ns(temperature_t_s) if temperature_t_s is not None else np.zeros(0, np.int64),
        temperature_c=temperature_c,
        metadata={
            "generator": "guide_health.simulate",    # the name bags record (kept when simulate.py became sim/)
            "seed": seed,
            "effects": effects,
            "effect_parameters": recorded_effect_parameters(wear_effects),
            "relubrication_t_s": list(wear_effects.relubrication_t_s),
            "jobs": knots.jobs,
            "simulation": dict(sim),
            "truth": truth,
        },
    )


def recorded_effect_parameters(effects: EffectParameters) -> dict[str, float]:
    """{name: value} of the registry's RECORDED_EFFECT_PARAMETERS that are finite (the bag metadata's record)."""
    values = {name: getattr(effects, simulate_field(name)) for name in RECORDED_EFFECT_PARAMETERS}
    return {k: v for k, v in values.items() if isinstance(v, float) and math.isfinite(v)}


def effect_value_range(name: str):
    """The Param whose range an --effect value must be in (``name``: the effect id)."""
    value = BY_ID[name].simulate
    if value.range_text or value.name not in WEAR_MONITOR_SCHEMA.by_name:
        return Param(value.name, 0.0, value.unit, value.range_text, "")
    return WEAR_MONITOR_SCHEMA[value.name]


def checked_effects(effects: dict[str, float] | None) -> dict[str, float]:
    """A copy of ``effects``; InputError (one line) for a name not in :data:`EFFECTS` or a value outside its
    physical range (a negative wear factor would make negative wear, silently)."""
    effects = dict(effects or {})
    unknown = sorted(set(effects) - set(EFFECTS))
    if unknown:
        raise InputError(f"unknown effects {unknown}; known: {', '.join(EFFECTS)}")
    for name, value in effects.items():
        allowed = effect_value_range(name)
        if not allowed.accepts(value):
            raise InputError(f"--effect {name}={value!r}: must be in {allowed.range_text}{allowed.unit_suffix}")
    return effects


def stamps_ns(t_s) -> np.ndarray:
    """Header stamps [ns] of run times [s] (the run starts at :data:`START_TIME_NS`)."""
    return START_TIME_NS + np.round(np.asarray(t_s) * 1e9).astype(np.int64)


def joint_samples(knots: MachineKnots, rate_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """JointState samples of the exact motion: times [s] from 0 at ``rate_hz``, position [m] and
    velocity [m/s] (sim/motion.py :func:`position_at`: the segment's speed, or the double-S profile's)."""
    ts = np.arange(0.0, knots.t_s[-1], 1.0 / rate_hz)
    position, velocity = position_at(knots, ts)
    return ts, position, velocity


def load_samples(knots: MachineKnots, sim: dict[str, Any], rng: np.random.Generator,
                 sensor_rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Guide load samples at ``load_rate_hz`` on the sensor's own clock: times [s] offset by half a
    period (plus ``load_clock_offset_s``) from the joint samples, the period stretched by
    ``load_clock_drift_ppm``, each instant jittered by ``load_stamp_jitter_s`` (kept increasing, moved 1 us
    off a joint stamp); the load of the enclosing segment at that instant [N] plus Gaussian noise."""
    rate = sim["load_rate_hz"]
    period = (1.0 + sim["load_clock_drift_ppm"] * 1e-6) / rate
    lt = (0.5 / rate + sim["load_clock_offset_s"]) + period * np.arange(int(knots.t_s[-1] * rate) + 2)
    if sim["load_stamp_jitter_s"] > 0 and sensor_rng is not None:
        jitter = np.clip(sensor_rng.normal(0.0, sim["load_stamp_jitter_s"], lt.size), -0.45 * period, 0.45 * period)
        lt = lt + jitter
        grid = lt * sim["joint_state_rate_hz"]           # no load stamp on a joint stamp (to the ns)
        lt = np.where(np.abs(grid - np.round(grid)) * 1e9 < 2.0 * sim["joint_state_rate_hz"], lt + 1e-6, lt)
    lt = lt[lt < knots.t_s[-1]]
    lseg = np.clip(np.searchsorted(knots.t_s, lt, side="right"), 1, knots.t_s.size - 1)
    load = knots.load_n[lseg].astype(float)
    if sim["load_noise_n"] > 0:
        load = load + rng.normal(0.0, sim["load_noise_n"], load.size)
    return lt, load


def true_straightness_wear_m(params: dict[str, Any], geometry: WearGeometry, knots: MachineKnots,
                             effects: EffectParameters, truth_k: float, at_s: np.ndarray,
                             new_surface_t_s=()) -> np.ndarray:
    """True straightness loss by wear [m] at times ``at_s``: Eq. 7 with the effects' work, or (other
    straightness models, no effects) the true K times the monitor's loss per unit K of the exact motion."""
    if geometry.straightness_model == "eq7":
        work, pass_work = effective_work_at(knots, at_s, effects, geometry.slider_length_m, new_surface_t_s)
        return PASS_WEIGHTING.straightness_wear_m(truth_k, geometry.hardness_pa, geometry.contact_width_m, work,
                                                  pass_work, float(knots.strokes_m.min() + knots.strokes_m.max()),
                                                  effects)
    return truth_k * true_straightness_loss_per_k_m(params, knots.t_s, knots.x_m, knots.load_n, at_s,
                                                    knots.strokes_m)


def true_run_values(knots: MachineKnots, geometry: WearGeometry, truth_k: float, truth_m: np.ndarray,
                    measurement_t_s: np.ndarray) -> dict[str, Any]:
    """The run's hidden truth for the bag metadata: K, noise-free straightness [m] at the measurement
    times [s], sliding distance [m], Archard work [N m], stroke range [m] and duration [s]."""
    strokes = knots.strokes_m
    return {
        "wear_coefficient": truth_k,
        "straightness_m": truth_m.tolist(),
        "straightness_t_s": measurement_t_s.tolist(),
        "sliding_distance_m": float(np.sum(np.abs(np.diff(knots.x_m)))),
        "archard_work_nm": float(np.sum(knots.load_n[1:] * np.abs(np.diff(knots.x_m)))),
        "stroke_min_m": float(strokes.min()),
        "stroke_max_m": float(strokes.max()),
        "stroke_sum_m": strokes.min() + strokes.max() if geometry.straightness_model == "eq7" else math.nan,
        "duration_s": float(knots.t_s[-1]),
    }


def true_straightness_loss_per_k_m(params: dict[str, Any], knot_t: np.ndarray, knot_x: np.ndarray,
                                   knot_w: np.ndarray, at_s: np.ndarray, strokes: np.ndarray) -> np.ndarray:
    """Straightness loss per unit K of the exact motion at times ``at_s`` (the monitor's model family:
    Eq. 7 with the true stroke range, or the wear profile integrated over the exact knots)."""
    geometry = WearGeometry.from_params(guide_params(params))
    # insert the evaluation times as knots (position interpolated, load of the enclosing segment)
    seg = np.clip(np.searchsorted(knot_t, at_s, side="right"), 1, knot_t.size - 1)
    all_t = np.concatenate((knot_t, at_s))
    all_x = np.concatenate((knot_x, np.interp(at_s, knot_t, knot_x)))
    all_w = np.concatenate((knot_w, knot_w[seg]))
    order = np.argsort(all_t, kind="stable")
    all_t, all_x, all_w = all_t[order], all_x[order], all_w[order]
    integ = WearIntegrator(geometry)
    out = np.empty(at_s.size)
    start = 0
    for j, t in enumerate(at_s):
        stop = int(np.searchsorted(all_t, t, side="right"))
        if stop > start:
            integ.advance_many((all_t[start:stop] * 1e9).astype(np.int64), all_x[start:stop],
                               all_w[start:stop])
            start = stop
        if geometry.straightness_model == "eq7":
            out[j] = straightness_from_wear_volume_m(integ.wear_volume_per_k_m3(), geometry.contact_width_m,
                                                     float(strokes.min()), float(strokes.max()))
        else:
            out[j] = integ.straightness_loss_per_k_m()
    return out


def effective_work_at(knots: MachineKnots, at_s: np.ndarray, effects: EffectParameters,
                      slider_length_m: float, new_surface_t_s=()) -> tuple[np.ndarray, np.ndarray]:
    """Effective Archard work G = sum W ds m [N m] and pass work P = sum W ds m / max(L, L_s) [N] of the
    exact motion at times ``at_s`` (models/wear/effects/; m = 1 without effects). Running-in counts the
    sliding distance from the last of ``new_surface_t_s`` [s] before each segment (a reground surface runs
    in again)."""
    ds = np.abs(np.diff(knots.x_m))
    dt = np.diff(knots.t_s)
    s = np.concatenate(([0.0], np.cumsum(ds)))
    load = knots.load_n[1:]
    speed = np.divide(ds, dt, out=np.zeros_like(ds), where=dt > 0)
    resets = np.sort(np.asarray(new_surface_t_s, dtype=float))
    last = np.searchsorted(resets, knots.t_s[:-1], side="right") - 1
    reset_s = np.interp(resets, knots.t_s, s) if resets.size else np.zeros(1)     # sliding distance at each
    start = np.where(last >= 0, reset_s[np.clip(last, 0, None)], 0.0)
    decay = SLIDING_DECAY.live_factor_mean(effects, s[:-1] - start, s[1:] - start)
    speed_factor = SPEED_SHARE.speed_factor(effects)
    if knots.curve is not None and speed_factor is not None:
        # the speed's factor varies along a double-S move: its distance-weighted mean (Gauss-Legendre, 1e-9)
        share = s_curve_mean(knots.curve, speed_factor)[1:]
        m = share * effect_multiplier(SPEED_SHARE.without(effects), speed, load,
                                      knots.retract[1:], decay, duty_factor(effects, knots))
    else:
        m = effect_multiplier(effects, speed, load, knots.retract[1:], decay, duty_factor(effects, knots))
    work = load * ds * m
    pass_work = work * PASS_WEIGHTING.pass_weight_per_m(knots.pass_length_m[1:], slider_length_m)
    g = np.concatenate(([0.0], np.cumsum(work)))
    p = np.concatenate(([0.0], np.cumsum(pass_work)))
    seg, share_of_move = share_of_move_at(knots, at_s)        # within a move: its share of the distance
    return (g[seg - 1] + (g[seg] - g[seg - 1]) * share_of_move,
            p[seg - 1] + (p[seg] - p[seg - 1]) * share_of_move)


def duty_factor(effects: EffectParameters, knots: MachineKnots) -> np.ndarray | float:
    """The duty effects' multiplier of each move: the product of their exact forms (Effect.truth_duty_factor,
    registry DUTY_FACTORS order)."""
    m = 1.0
    for effect in DUTY_FACTORS:
        f = effect.truth_duty_factor(effects, knots.t_s[:-1], knots.t_s[1:], knots.x_m[:-1], knots.x_m[1:])
        if f is not None:
            m = m * f
    return m


def work_weighted_position_m(knots: MachineKnots) -> float:
    """x_ref of the load's gradient along the rail: the Archard-work-weighted mean mid-position of the moves [m]
    (the workflow's definition, analysis/discrepancy/model.py position_ref_m)."""
    work = knots.load_n[1:] * np.abs(np.diff(knots.x_m))
    mid = 0.5 * (knots.x_m[:-1] + knots.x_m[1:])
    return float(np.sum(work * mid) / max(float(work.sum()), 1e-300))


def relubrication_times_s(sim: dict[str, Any], recorded_t_s, duration_s: float) -> np.ndarray:
    """Relubrications [s from the start]: every relubrication_interval_h (0: none) and the recorded ones."""
    interval = sim["relubrication_interval_h"] * 3600.0
    auto = np.arange(interval, duration_s, interval) if interval > 0 else np.zeros(0)
    return np.unique(np.concatenate((auto, np.asarray(recorded_t_s, dtype=float))))


def simulate_axes(axes: dict[str, dict[str, Any]], sims: dict[str, dict[str, Any]], seed: int = 0,
                  effects: dict[str, dict[str, float]] | None = None,
                  new_surface_t_s: dict[str, list] | None = None) -> dict[str, MachineRun]:
    """One :class:`MachineRun` per axis of a machine (``axes``: guide_health.params.machine.axes_params,
    ``sims``: simulation_axes), each with its own duty and random strokes (seed ``seed`` + 1000 x the axis
    index), cut to the common duration so that one JointState per stamp carries every joint. ``effects`` and
    ``new_surface_t_s``: per axis, as :func:`simulate_machine` takes them."""
    runs = {}
    for index, (axis, params) in enumerate(axes.items()):
        # the measured straightness is the most loaded guide's (the one the axis reports): its wear is the
        # Archard wear of share x W, i.e. that of the full load with K x share (no effects: linear in W)
        share = max(params.get("guide_load_shares", [1.0]))
        scenario = dict(sims[axis], wear_coefficient_factor=sims[axis]["wear_coefficient_factor"] * share)
        run = simulate_machine(params, scenario, seed=seed + 1000 * index, effects=(effects or {}).get(axis),
                               new_surface_t_s=(new_surface_t_s or {}).get(axis, ()))
        run.metadata["truth"]["wear_coefficient"] /= share
        run.metadata["truth"]["guide_load_share"] = share
        runs[axis] = run
    end_ns = min(int(run.joint_t_ns[-1]) for run in runs.values()) + 1
    return {axis: _cut_run(run, end_ns) for axis, run in runs.items()}


def _cut_run(run: MachineRun, end_ns: int) -> MachineRun:
    """``run`` without the samples stamped at or after ``end_ns``."""
    def keep(t):
        return int(np.searchsorted(t, end_ns, side="left"))

    j, ld, s, tp = (keep(run.joint_t_ns), keep(run.load_t_ns), keep(run.straightness_t_ns),
                    keep(run.temperature_t_ns))
    velocity = run.joint_velocity_m_s[:j] if run.joint_velocity_m_s.size else run.joint_velocity_m_s
    return MachineRun(joint_name=run.joint_name, joint_t_ns=run.joint_t_ns[:j],
                      joint_position_m=run.joint_position_m[:j], joint_velocity_m_s=velocity,
                      load_t_ns=run.load_t_ns[:ld], load_n=run.load_n[:ld],
                      straightness_t_ns=run.straightness_t_ns[:s], straightness_m=run.straightness_m[:s],
                      temperature_t_ns=run.temperature_t_ns[:tp], temperature_c=run.temperature_c[:tp],
                      metadata=run.metadata)


def parse_maintenance(items: list[str] | None, axes: dict[str, dict], start_ns: int = START_TIME_NS) -> list:
    """``KIND:AXIS[.GUIDE]@TIME[=VALUE]`` strings (``regrind:x@10h``, ``measure:z@2.5h=8.2um``,
    ``replace_carriage:y.front@90min``) to MaintenanceEvents; TIME in h (default), min or s from the start
    of the run, VALUE a straightness with its unit (um or m). InputError (one line) for anything else."""
    events = []
    for item in items or []:
        kind, sep, rest = item.partition(":")
        where, at, when = rest.partition("@")
        if not (sep and at) or kind not in KINDS:
            raise InputError(f"--maintenance takes KIND:AXIS[.GUIDE]@TIME[=VALUE] with KIND one of "
                             f"{', '.join(KINDS)}, got {item!r}")
        axis, _, guide = where.partition(".")
        if axis not in axes:
            raise InputError(f"--maintenance {item!r}: no axis {axis!r} (axes: {', '.join(axes)})")
        when, _, value = when.partition("=")
        event = MaintenanceEvent(start_ns + int(round(_duration_s(item, when) * 1e9)), kind, axis, guide,
                                 _straightness_m(item, value), "simulate")
        axis_params = wear_axis_params(axes[axis])
        reason = check_event(event, list(axis_params.guides), axis_params.straightness_limit_m)
        if reason is not None:
            raise InputError(f"--maintenance {item!r}: {reason}")
        events.append(event)
    return sorted(events, key=lambda e: e.t_ns)


def _duration_s(item: str, text: str) -> float:
    for suffix, scale in (("min", 60.0), ("h", 3600.0), ("s", 1.0)):
        if text.endswith(suffix):
            text, factor = text[:-len(suffix)], scale
            break
    else:
        factor = 3600.0
    try:
        value = float(text) * factor
    except ValueError:
        raise InputError(f"--maintenance {item!r}: time {text!r} is not a number (e.g. 10h, 90min, 600s)") from None
    if not (math.isfinite(value) and value >= 0):
        raise InputError(f"--maintenance {item!r}: time must be >= 0")
    return value


def _straightness_m(item: str, text: str) -> float:
    if not text:
        return math.nan
    try:
        return straightness_from_text(text)
    except InputError as exc:
        raise InputError(f"--maintenance {item!r}: {exc}") from None


def apply_maintenance_truth(run: MachineRun, events: list, params: dict[str, Any]) -> None:
    """The measured straightness of ``run`` after each wear reset (regrind, rail replacement) of its axis:
    from then on the truth grows from the straightness after the event (given, else A0) by the wear since
    it. The truth at the event: simulate_machine's value when the event was among its ``new_surface_t_s``
    (then the new surface also runs in again), else interpolated between the truth's measurement times."""
    truth = run.metadata["truth"]
    t_s = np.asarray(truth["straightness_t_s"], dtype=float)
    true_m = np.asarray(truth["straightness_m"], dtype=float)
    measured_t_s = (run.straightness_t_ns - START_TIME_NS) * 1e-9
    exact = {round(t, 6): a for t, a in truth.get("straightness_at_resets", [])}   # simulate_machine's new_surface_t_s
    shifted = 0.0
    for event in sorted(events, key=lambda e: e.t_ns):
        if event.kind not in ("regrind", "replace_rail"):
            continue
        t_e = (event.t_ns - START_TIME_NS) * 1e-9
        after = event.straightness_m if math.isfinite(event.straightness_m) else params["straightness_initial_m"]
        at_event = exact[round(t_e, 6)] + shifted if round(t_e, 6) in exact else float(np.interp(t_e, t_s, true_m))
        shift = after - at_event
        shifted += shift
        true_m = np.where(t_s > t_e, true_m + shift, true_m)
        run.straightness_m = np.where(measured_t_s > t_e, run.straightness_m + shift, run.straightness_m)
    truth["straightness_m"] = true_m.tolist()
