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
from typing import Any

import numpy as np
from scipy import stats

from guide_health.errors import InputError
from guide_health.models.wear import WearGeometry, WearIntegrator, straightness_from_wear_volume_m
from guide_health.runs import MachineRun

EFFECTS = ("running_in", "retract_asymmetry", "speed_dependent_wear", "load_exponent",
           "stroke_distribution", "thermal_drift", "initial_offset")
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


def machine_knots(rng: np.random.Generator, sim: dict[str, Any]):
    """Knots of the piecewise-linear motion: times [s], positions [m], load of the segment ending at each
    knot [N], and the strokes drawn."""
    duration = sim["duration_h"] * 3600.0
    mean_cycle = (sim["stroke_mean_m"] / sim["feed_speed_m_s"] + sim["stroke_mean_m"] / sim["retract_speed_m_s"]
                  + sim["dwell_s"])
    n = int(duration / mean_cycle * 1.3) + 10
    strokes = draw_strokes_m(rng, n, sim)
    home = sim["home_position_m"]
    feed_t = strokes / sim["feed_speed_m_s"]
    back_t = strokes / sim["retract_speed_m_s"]
    dwell = sim["dwell_s"]
    # per cycle: [start] -> feed end -> retract end -> dwell end
    seg_dt = np.column_stack((feed_t, back_t, np.full(n, dwell))).ravel()
    seg_x = np.column_stack((home + strokes, np.full(n, home), np.full(n, home))).ravel()
    seg_w = np.column_stack((np.full(n, sim["feed_load_n"]), np.full(n, sim["retract_load_n"]),
                             np.full(n, sim["retract_load_n"]))).ravel()
    keep = seg_dt > 0
    seg_dt, seg_x, seg_w = seg_dt[keep], seg_x[keep], seg_w[keep]
    t = np.concatenate(([0.0], np.cumsum(seg_dt)))
    x = np.concatenate(([home], seg_x))
    w = np.concatenate(([sim["feed_load_n"]], seg_w))
    last = int(np.searchsorted(t, duration, side="right"))
    if last >= t.size:
        raise RuntimeError("stroke schedule too short")  # pragma: no cover (sized with margin)
    # cut at the duration
    x_end = np.interp(duration, t, x)
    t = np.concatenate((t[:last], [duration]))
    x = np.concatenate((x[:last], [x_end]))
    w = np.concatenate((w[:last], [w[last]]))
    cycles_done = int(np.searchsorted(np.cumsum(feed_t + back_t + dwell), duration))
    return t, x, w, strokes[:max(cycles_done, 1)]


def simulate_machine(params: dict[str, Any], sim: dict[str, Any], seed: int = 0,
                     effects: dict[str, float] | None = None) -> MachineRun:
    """A :class:`MachineRun` of the scenario ``sim`` for a guide with wear parameters ``params``."""
    effects = dict(effects or {})
    if effects:
        raise InputError(f"effects {sorted(effects)} are reserved for the discrepancy workflow and not simulated yet")
    rng = np.random.default_rng(seed)
    knot_t, knot_x, knot_w, strokes = machine_knots(rng, sim)
    duration = knot_t[-1]

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

    # measured straightness: truth at the measurement times + noise
    interval = sim["measurement_interval_h"] * 3600.0
    mt = np.arange(0.0, duration + 1e-9, interval)
    truth_k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    loss_per_k = true_straightness_loss_per_k_m(params, knot_t, knot_x, knot_w, mt, strokes)
    a0 = params["straightness_initial_m"]
    truth = a0 + truth_k * loss_per_k
    measured = truth + rng.normal(0.0, sim["straightness_noise_m"], mt.size)

    geometry = WearGeometry.from_params(params)
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
        metadata={
            "generator": "guide_health.simulate",
            "seed": seed,
            "effects": effects,
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
