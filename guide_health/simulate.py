"""Synthetic machine runs (pure numpy): a sliding guide doing random feed strokes as on seed 000's bench.

The axis moves home -> home + L at the feed speed under the feed load, returns at the retract speed under
the retract load, and dwells; L is drawn from a normal distribution truncated to [low, high] (seed 000:
mean 200 mm, sd 47 mm, 100..300 mm) or a skew-normal one. The exact motion is piecewise linear (knots at
the turning points), so the true Archard work is exact; the bag samples it at the JointState rate.
The measured straightness is the truth (same model family as the monitor's, with the true K) plus
Gaussian noise, every ``measurement_interval_h``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from guide_health.errors import InputError
from guide_health.models.wear.archard import WearGeometry, WearIntegrator, straightness_from_wear_volume_m
from guide_health.models.wear.effects import (EFFECT_IDS, WearEffects, measured_straightness_m,
                                              pass_weight_per_m, running_in_factor_mean,
                                              straightness_wear_m, wear_rate_multiplier)
from guide_health.runs import MachineRun

EFFECTS = EFFECT_IDS
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


def draw_strokes_m(rng: np.random.Generator, count: int, sim: dict[str, Any]) -> np.ndarray:
    """Feed strokes: truncated normal (seed 000 bench) or, with ``stroke_skew`` != 0, truncated skew-normal."""
    low, high = sim["stroke_low_m"], sim["stroke_high_m"]
    mean, sd = sim["stroke_mean_m"], max(sim["stroke_std_m"], 1e-9)
    if sim["stroke_skew"] == 0.0:
        a, b = (low - mean) / sd, (high - mean) / sd
        return stats.truncnorm.rvs(a, b, loc=mean, scale=sd, size=count, random_state=rng)
    out = np.empty(0)
    while out.size < count:
        x = stats.skewnorm.rvs(sim["stroke_skew"], loc=mean, scale=sd, size=2 * count, random_state=rng)
        out = np.concatenate((out, x[(x >= low) & (x <= high)]))
    return out[:count]


@dataclass
class MachineKnots:
    """Piecewise-linear motion: knot times [s] and positions [m]; per segment (ending at knot i, i >= 1)
    the load [N], whether it is a retract, the length of its pass [m]; the feed strokes drawn; the jobs."""

    t_s: np.ndarray
    x_m: np.ndarray
    load_n: np.ndarray            # load of the segment ending at each knot (index 0: the first feed load)
    retract: np.ndarray           # bool, same indexing
    pass_length_m: np.ndarray     # same indexing
    strokes_m: np.ndarray
    jobs: list = field(default_factory=list)


def _job_list(rng: np.random.Generator, sim: dict[str, Any]) -> list[dict[str, float]]:
    """Jobs of the run: one job with the scenario's values when ``job_hours`` is 0, else jobs of
    0.5..1.5 x ``job_hours`` whose feed speed (log-uniform), feed and retract load, mean stroke and stroke skew are
    drawn between the scenario's value and its ``*_max`` (a machine does different work in each job)."""
    duration = sim["duration_h"] * 3600.0
    base = {"feed_speed_m_s": sim["feed_speed_m_s"], "feed_load_n": sim["feed_load_n"],
            "retract_load_n": sim["retract_load_n"],
            "stroke_mean_m": sim["stroke_mean_m"], "stroke_skew": sim["stroke_skew"]}
    if not sim["job_hours"] > 0:
        return [dict(base, start_s=0.0, end_s=duration)]
    jobs, t = [], 0.0
    while t < duration:
        length = sim["job_hours"] * 3600.0 * rng.uniform(0.5, 1.5)
        job = dict(base, start_s=t, end_s=min(t + length, duration))
        if sim["feed_speed_max_m_s"] > sim["feed_speed_m_s"]:
            job["feed_speed_m_s"] = float(np.exp(rng.uniform(np.log(sim["feed_speed_m_s"]),
                                                             np.log(sim["feed_speed_max_m_s"]))))
        if sim["feed_load_max_n"] > sim["feed_load_n"]:
            job["feed_load_n"] = float(rng.uniform(sim["feed_load_n"], sim["feed_load_max_n"]))
        if sim["retract_load_max_n"] > sim["retract_load_n"]:   # the table's load: fixture and work
            job["retract_load_n"] = float(rng.uniform(sim["retract_load_n"],
                                                      min(sim["retract_load_max_n"], job["feed_load_n"])))
        if sim["stroke_mean_max_m"] > sim["stroke_mean_m"]:
            job["stroke_mean_m"] = float(rng.uniform(sim["stroke_mean_m"], sim["stroke_mean_max_m"]))
        if sim["stroke_skew_max"] > 0:
            job["stroke_skew"] = float(sim["stroke_skew"] + rng.uniform(-1, 1) * sim["stroke_skew_max"])
        jobs.append(job)
        t += length
    return jobs


def _job_cycles(rng: np.random.Generator, sim: dict[str, Any], job: dict[str, float], margin: float):
    """Strokes, feed speed and feed load of the cycles of one job (enough to fill it, with margin)."""
    js = dict(sim, **{k: job[k] for k in ("feed_speed_m_s", "feed_load_n", "stroke_skew")})
    js["stroke_mean_m"] = min(max(job["stroke_mean_m"], sim["stroke_low_m"]), sim["stroke_high_m"])
    mean_cycle = (js["stroke_mean_m"] / js["feed_speed_m_s"] + js["stroke_mean_m"] / sim["retract_speed_m_s"]
                  + sim["dwell_s"])
    n = int((job["end_s"] - job["start_s"]) / mean_cycle * margin) + 10
    return draw_strokes_m(rng, n, js), js["feed_speed_m_s"], js["feed_load_n"], job["retract_load_n"]


def cycle_knots(rng: np.random.Generator, sim: dict[str, Any]) -> MachineKnots:
    """Knots of the feed / retract / dwell cycles of the scenario ``sim`` (see :func:`machine_knots`)."""
    duration = sim["duration_h"] * 3600.0
    jobs = _job_list(rng, sim)
    single = len(jobs) == 1
    strokes_l, feed_t_l, back_t_l, feed_w_l, back_w_l = [], [], [], [], []
    for job in jobs:
        strokes, feed_speed, feed_load, back_load = _job_cycles(rng, sim, job, 1.3 if single else 1.8)
        feed_t = strokes / feed_speed
        back_t = strokes / sim["retract_speed_m_s"]
        if not single:   # cycles that start within the job
            starts = np.concatenate(([0.0], np.cumsum(feed_t + back_t + sim["dwell_s"])[:-1]))
            keep = starts < job["end_s"] - job["start_s"]
            keep[0] = True
            strokes, feed_t, back_t = strokes[keep], feed_t[keep], back_t[keep]
        strokes_l.append(strokes)
        feed_t_l.append(feed_t)
        back_t_l.append(back_t)
        feed_w_l.append(np.full(strokes.size, feed_load))
        back_w_l.append(np.full(strokes.size, back_load))
    strokes = np.concatenate(strokes_l)
    feed_t, back_t = np.concatenate(feed_t_l), np.concatenate(back_t_l)
    feed_w, back_w = np.concatenate(feed_w_l), np.concatenate(back_w_l)
    n = strokes.size
    home = sim["home_position_m"]
    dwell = sim["dwell_s"]
    # per cycle: [start] -> feed end -> retract end -> dwell end
    seg_dt = np.column_stack((feed_t, back_t, np.full(n, dwell))).ravel()
    seg_x = np.column_stack((home + strokes, np.full(n, home), np.full(n, home))).ravel()
    seg_w = np.column_stack((feed_w, back_w, back_w)).ravel()
    seg_r = np.column_stack((np.zeros(n, bool), np.ones(n, bool), np.ones(n, bool))).ravel()
    seg_l = np.column_stack((strokes, strokes, strokes)).ravel()
    keep = seg_dt > 0
    seg_dt, seg_x, seg_w, seg_r, seg_l = seg_dt[keep], seg_x[keep], seg_w[keep], seg_r[keep], seg_l[keep]
    t = np.concatenate(([0.0], np.cumsum(seg_dt)))
    x = np.concatenate(([home], seg_x))
    w = np.concatenate(([feed_w[0]], seg_w))
    r = np.concatenate(([False], seg_r))
    pl = np.concatenate(([strokes[0]], seg_l))
    last = int(np.searchsorted(t, duration, side="right"))
    if last >= t.size:
        raise RuntimeError("stroke schedule too short")  # pragma: no cover (sized with margin)
    # cut at the duration
    x_end = np.interp(duration, t, x)
    t = np.concatenate((t[:last], [duration]))
    x = np.concatenate((x[:last], [x_end]))
    w = np.concatenate((w[:last], [w[last]]))
    r = np.concatenate((r[:last], [r[last]]))
    pl = np.concatenate((pl[:last], [pl[last]]))
    cycles_done = int(np.searchsorted(np.cumsum(feed_t + back_t + dwell), duration))
    return MachineKnots(t, x, w, r, pl, strokes[:max(cycles_done, 1)], jobs)


def machine_knots(rng: np.random.Generator, sim: dict[str, Any]):
    """Knots of the piecewise-linear motion: times [s], positions [m], load of the segment ending at each
    knot [N], and the strokes drawn."""
    k = cycle_knots(rng, sim)
    return k.t_s, k.x_m, k.load_n, k.strokes_m


def simulate_machine(params: dict[str, Any], sim: dict[str, Any], seed: int = 0,
                     effects: dict[str, float] | None = None) -> MachineRun:
    """A :class:`MachineRun` of the scenario ``sim`` for a guide with wear parameters ``params``."""
    effects = dict(effects or {})
    unknown = sorted(set(effects) - set(EFFECTS))
    if unknown:
        raise InputError(f"unknown effects {unknown}; known: {', '.join(EFFECTS)}")
    rng = np.random.default_rng(seed)
    knots = cycle_knots(rng, sim)
    knot_t, knot_x, knot_w, strokes = knots.t_s, knots.x_m, knots.load_n, knots.strokes_m
    duration = knot_t[-1]
    geometry = WearGeometry.from_params(params)
    if effects and geometry.straightness_model != "eq7":
        raise InputError("--effect needs straightness_model: eq7 (the baseline the effects are defined against)")
    wear_effects = WearEffects.from_values(effects, running_in_distance_m=sim["running_in_distance_m"],
                                           load_reference_n=sim["load_reference_n"])

    # JointState samples of the exact motion
    rate = sim["joint_state_rate_hz"]
    ts = np.arange(0.0, duration, 1.0 / rate)
    position = np.interp(ts, knot_t, knot_x)
    seg = np.clip(np.searchsorted(knot_t, ts, side="right"), 1, knot_t.size - 1)
    seg_speed = np.diff(knot_x) / np.diff(knot_t)
    velocity = seg_speed[seg - 1]

    # load samples, offset by half a period from the joint samples (no equal stamps across topics)
    lrate = sim["load_rate_hz"]
    lt = np.arange(0.5 / lrate, duration, 1.0 / lrate)
    lseg = np.clip(np.searchsorted(knot_t, lt, side="right"), 1, knot_t.size - 1)
    load = knot_w[lseg].astype(float)
    if sim["load_noise_n"] > 0:
        load = load + rng.normal(0.0, sim["load_noise_n"], load.size)

    # guide temperature (recorded when temperature_rate_hz > 0 or a thermal drift is simulated)
    temperature_rate = sim["temperature_rate_hz"]
    if "thermal_drift" in effects and not temperature_rate > 0:
        temperature_rate = 0.1
    tt = np.arange(0.25 / temperature_rate, duration, 1.0 / temperature_rate) if temperature_rate > 0 else None
    interval = sim["measurement_interval_h"] * 3600.0
    mt = np.arange(0.0, duration + 1e-9, interval)
    temperature_meas_c = None
    temperature_c = np.zeros(0)
    if tt is not None:
        grid = np.union1d(np.arange(0.0, duration, 10.0), np.concatenate((mt, [duration])))
        t_grid_c = guide_temperature_c(knots, sim, grid, rng)
        temperature_c = np.interp(tt, grid, t_grid_c) + rng.normal(0.0, sim["temperature_noise_k"], tt.size)
        temperature_meas_c = np.interp(mt, grid, t_grid_c)

    # measured straightness: truth at the measurement times + noise
    truth_k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    a0 = params["straightness_initial_m"]
    if geometry.straightness_model == "eq7":
        work, pass_work = effective_work_at(knots, mt, wear_effects, geometry.slider_length_m)
        wear = straightness_wear_m(truth_k, geometry.hardness_pa, geometry.contact_width_m, work, pass_work,
                                   float(strokes.min() + strokes.max()),
                                   wear_effects.stroke_distribution_weight)
    else:
        wear = truth_k * true_straightness_loss_per_k_m(params, knot_t, knot_x, knot_w, mt, strokes)
    d_temp = None if temperature_meas_c is None else temperature_meas_c - temperature_meas_c[0]
    truth = measured_straightness_m(wear, a0, d_temp, wear_effects)
    measured = truth + rng.normal(0.0, sim["straightness_noise_m"], mt.size)

    l_sum = strokes.min() + strokes.max() if geometry.straightness_model == "eq7" else math.nan
    total_work = float(np.sum(knot_w[1:] * np.abs(np.diff(knot_x))))
    to_ns = lambda s: START_TIME_NS + np.round(np.asarray(s) * 1e9).astype(np.int64)  # noqa: E731
    return MachineRun(
        joint_name=params["joint"],
        joint_t_ns=to_ns(ts),
        joint_position_m=position,
        joint_velocity_m_s=velocity,
        load_t_ns=to_ns(lt),
        load_n=load,
        straightness_t_ns=to_ns(mt),
        straightness_m=measured,
        temperature_t_ns=to_ns(tt) if tt is not None else np.zeros(0, np.int64),
        temperature_c=temperature_c,
        metadata={
            "generator": "guide_health.simulate",
            "seed": seed,
            "effects": effects,
            "effect_parameters": {k: v for k, v in vars(wear_effects).items() if math.isfinite(v)},
            "jobs": knots.jobs,
            "simulation": dict(sim),
            "truth": {
                "wear_coefficient": truth_k,
                "straightness_m": truth.tolist(),
                "straightness_t_s": mt.tolist(),
                "sliding_distance_m": float(np.sum(np.abs(np.diff(knot_x)))),
                "archard_work_nm": total_work,
                "stroke_min_m": float(strokes.min()),
                "stroke_max_m": float(strokes.max()),
                "stroke_sum_m": l_sum,
                "duration_s": float(duration),
            },
        },
    )


def true_straightness_loss_per_k_m(params: dict[str, Any], knot_t: np.ndarray, knot_x: np.ndarray,
                                   knot_w: np.ndarray, at_s: np.ndarray, strokes: np.ndarray) -> np.ndarray:
    """Straightness loss per unit K of the exact motion at times ``at_s`` (the monitor's model family:
    Eq. 7 with the true stroke range, or the wear profile integrated over the exact knots)."""
    geometry = WearGeometry.from_params(params)
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


def effective_work_at(knots: MachineKnots, at_s: np.ndarray, effects: WearEffects,
                      slider_length_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Effective Archard work G = sum W ds m [N m] and pass work P = sum W ds m / max(L, L_s) [N] of the
    exact motion at times ``at_s`` (models/wear/effects.py; m = 1 without effects)."""
    ds = np.abs(np.diff(knots.x_m))
    dt = np.diff(knots.t_s)
    s = np.concatenate(([0.0], np.cumsum(ds)))
    load = knots.load_n[1:]
    speed = np.divide(ds, dt, out=np.zeros_like(ds), where=dt > 0)
    running_in = running_in_factor_mean(s[:-1], s[1:], effects.running_in_ratio, effects.running_in_distance_m)
    m = wear_rate_multiplier(effects, speed, load, knots.retract[1:], running_in)
    work = load * ds * m
    pass_work = work * pass_weight_per_m(knots.pass_length_m[1:], slider_length_m)
    g = np.concatenate(([0.0], np.cumsum(work)))
    p = np.concatenate(([0.0], np.cumsum(pass_work)))
    return np.interp(at_s, knots.t_s, g), np.interp(at_s, knots.t_s, p)


def guide_temperature_c(knots: MachineKnots, sim: dict[str, Any], grid_s: np.ndarray,
                        rng: np.random.Generator) -> np.ndarray:
    """Guide temperature [degC] on the time grid: ambient (daily swing) plus frictional heating,
    a first-order lag of the friction power mu W v through a thermal resistance (exact per grid step
    for the step's mean power)."""
    ds = np.abs(np.diff(knots.x_m))
    friction_work = np.concatenate(([0.0], np.cumsum(sim["friction_coefficient"] * knots.load_n[1:] * ds)))
    f = np.interp(grid_s, knots.t_s, friction_work)
    dt = np.diff(grid_s)
    power_w = np.diff(f) / dt
    decay = np.exp(-dt / sim["thermal_time_constant_s"])
    rise = np.empty(grid_s.size)
    rise[0] = 0.0
    for i in range(dt.size):          # ~7000 steps for 20 h
        rise[i + 1] = rise[i] * decay[i] + sim["thermal_resistance_k_per_w"] * power_w[i] * (1.0 - decay[i])
    phase = rng.uniform(0.0, 2.0 * math.pi)
    ambient = sim["ambient_temperature_c"] + sim["ambient_swing_k"] * np.sin(2.0 * math.pi * grid_s / 86400.0 + phase)
    return ambient + rise
