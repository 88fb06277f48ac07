"""Motion of a simulated machine axis: feed / retract / dwell cycles of random strokes, grouped in jobs.

The axis moves home -> home + L at the feed speed under the feed load, returns at the retract speed under
the retract load, and dwells; L is drawn from a normal distribution truncated to [low, high] (seed 000:
mean 200 mm, sd 47 mm, 100..300 mm) or a skew-normal one. The exact motion is piecewise linear (knots at
the turning points), so the true Archard work is exact.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats


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
