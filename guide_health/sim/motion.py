"""Motion of a simulated machine axis: feed / retract / dwell cycles of random strokes, grouped in jobs.

The axis moves home -> home + L at the feed speed under the feed load, returns at the retract speed under
the retract load, and dwells; L is drawn from a normal distribution truncated to [low, high] (seed 000:
mean 200 mm, sd 47 mm, 100..300 mm) or a skew-normal one. The exact motion is piecewise linear (knots at
the turning points), or with ``motion_profile: jerk_limited`` a double-S move between knots (the axis
stops at every knot); each move is monotonic under one load, so the true Archard work is exact either way.
"""
from __future__ import annotations

import math
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
    curve: Any = None             # SCurve of the moves (jerk-limited motion), None: constant speed between knots


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


# ---------------------------------------------------------------------------------------------
# Jerk-limited motion (``motion_profile: jerk_limited``): every move between two knots is a double-S
# (7-phase) profile with jerk, acceleration and speed limits; the axis stops at every knot.
# ---------------------------------------------------------------------------------------------

@dataclass
class SCurve:
    """Double-S profiles of the moves ending at each knot (index as MachineKnots; 0 for dwells):
    jerk phase ``tj_s``, acceleration phase ``ta_s`` (both jerk phases included), cruise ``tv_s``,
    peak speed ``v_m_s`` and jerk ``jerk_m_s3`` (the acceleration peaks at jerk x tj)."""

    tj_s: np.ndarray
    ta_s: np.ndarray
    tv_s: np.ndarray
    v_m_s: np.ndarray
    jerk_m_s3: float

    @property
    def duration_s(self) -> np.ndarray:
        return 2.0 * self.ta_s + self.tv_s


def s_curve(length_m: np.ndarray, speed_m_s: np.ndarray, accel_m_s2: float, jerk_m_s3: float) -> SCurve:
    """The time-optimal symmetric double-S move of ``length_m`` under the limits (speed, acceleration, jerk):
    the acceleration phase lasts Ta = a/j + v/a when v >= a^2/j, else 2 sqrt(v/j), and covers v Ta / 2;
    a move too short to reach v runs at the peak speed v' with v' Ta(v') = L (Biagiotti & Melchiorri,
    Trajectory Planning for Automatic Machines, 2008, sec. 3.4)."""
    length = np.abs(np.asarray(length_m, dtype=float))
    v = np.asarray(speed_m_s, dtype=float).copy()
    a, j = float(accel_m_s2), float(jerk_m_s3)

    def accel_time(vv):
        return np.where(vv >= a * a / j, a / j + vv / np.where(vv > 0, a, 1.0), 2.0 * np.sqrt(vv / j))

    short = v * accel_time(v) > length
    # peak speed of a short move: v'^2 / a + v' a / j = L (trapezoidal acceleration), else 2 v' sqrt(v'/j) = L
    v_trap = 0.5 * a * (-a / j + np.sqrt((a / j) ** 2 + 4.0 * length / a))
    v_tri = (0.5 * length * math.sqrt(j)) ** (2.0 / 3.0)
    v = np.where(short, np.where(v_trap >= a * a / j, v_trap, v_tri), v)
    v = np.where(length > 0, v, 0.0)
    ta = np.where(v > 0, accel_time(v), 0.0)
    tj = np.where(v >= a * a / j, a / j, np.sqrt(v / j))
    tj = np.where(v > 0, tj, 0.0)
    tv = np.where(v > 0, np.maximum(length / np.where(v > 0, v, 1.0) - ta, 0.0), 0.0)
    return SCurve(tj, ta, tv, v, j)


def _accel_phase(tau, tj, ta, v, j):
    """Distance and speed after ``tau`` in [0, ta] of the acceleration phase (0 -> v)."""
    tc = ta - 2.0 * tj
    amax = j * tj
    s1, v1 = j * tj ** 3 / 6.0, 0.5 * j * tj ** 2
    u = tau - tj
    w = ta - tau
    s = np.where(tau < tj, j * tau ** 3 / 6.0,
                 np.where(tau < tj + tc, s1 + v1 * u + 0.5 * amax * u * u, 0.5 * v * ta - (v * w - j * w ** 3 / 6.0)))
    sp = np.where(tau < tj, 0.5 * j * tau * tau, np.where(tau < tj + tc, v1 + amax * u, v - 0.5 * j * w * w))
    return s, sp


def s_curve_progress(curve: SCurve, seg: np.ndarray, tau_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance covered [m] and speed [m/s] ``tau_s`` after the start of the moves ``seg``."""
    tj, ta, tv, v = curve.tj_s[seg], curve.ta_s[seg], curve.tv_s[seg], curve.v_m_s[seg]
    total = 2.0 * ta + tv
    tau = np.clip(tau_s, 0.0, total)
    length = v * (ta + tv)
    s_a, v_a = _accel_phase(np.minimum(tau, ta), tj, ta, v, curve.jerk_m_s3)
    s_d, v_d = _accel_phase(np.clip(total - tau, 0.0, ta), tj, ta, v, curve.jerk_m_s3)
    cruise = (tau > ta) & (tau < ta + tv)
    s = np.where(tau <= ta, s_a, np.where(cruise, 0.5 * v * ta + v * (tau - ta), length - s_d))
    sp = np.where(tau <= ta, v_a, np.where(cruise, v, v_d))
    return s, sp


def jerk_limited_knots(knots: MachineKnots, sim: dict[str, Any]) -> MachineKnots:
    """The knots of ``knots`` retimed so that every move is a double-S profile at its nominal speed (the
    moves take longer than L / v: the schedule is cut at the duration, ending at rest at the last knot
    reached; the jobs' start and end follow the retiming). The result carries ``curve`` (:class:`SCurve`)."""
    dx = np.diff(knots.x_m)
    dt = np.diff(knots.t_s)
    moving = dx != 0.0
    speed = np.divide(np.abs(dx), dt, out=np.zeros_like(dx), where=moving)
    curve = s_curve(dx, speed, sim["max_acceleration_m_s2"], sim["max_jerk_m_s3"])
    new_dt = np.where(moving, curve.duration_s, dt)
    t = np.concatenate(([0.0], np.cumsum(new_dt)))
    duration = float(knots.t_s[-1])
    last = int(np.searchsorted(t, duration, side="right"))     # knots t[:last] lie within the duration
    keep = slice(0, last)
    t_new = np.concatenate((t[keep], [duration])) if t[last - 1] < duration else t[keep]
    extra = t_new.size - last                                   # 1: a standstill to the end
    x = np.concatenate((knots.x_m[keep], knots.x_m[last - 1:last].repeat(extra)))
    w = np.concatenate((knots.load_n[keep], knots.load_n[last - 1:last].repeat(extra)))
    r = np.concatenate((knots.retract[keep], knots.retract[last - 1:last].repeat(extra)))
    pl = np.concatenate((knots.pass_length_m[keep], knots.pass_length_m[last - 1:last].repeat(extra)))

    def cut(a):
        return np.concatenate(([0.0], a[:last - 1], np.zeros(extra)))

    curve = SCurve(cut(curve.tj_s), cut(curve.ta_s), cut(curve.tv_s), cut(curve.v_m_s), curve.jerk_m_s3)
    jobs = [dict(job, start_s=float(np.interp(job["start_s"], knots.t_s, t)),
                 end_s=min(float(np.interp(job["end_s"], knots.t_s, t)), duration)) for job in knots.jobs]
    jobs = [job for job in jobs if job["start_s"] < duration]
    return MachineKnots(t_new, x, w, r, pl, knots.strokes_m, jobs, curve)


def position_at(knots: MachineKnots, t_s: np.ndarray, chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Exact position [m] and signed velocity [m/s] of the motion at times ``t_s``: linear between the knots,
    or the double-S profile of each move (``knots.curve``); evaluated in chunks (bounded temporaries)."""
    t_s = np.asarray(t_s, dtype=float)
    dx = np.diff(knots.x_m)
    if knots.curve is None:
        seg = np.clip(np.searchsorted(knots.t_s, t_s, side="right"), 1, knots.t_s.size - 1)
        return np.interp(t_s, knots.t_s, knots.x_m), (dx / np.diff(knots.t_s))[seg - 1]
    x, v = np.empty(t_s.size), np.empty(t_s.size)
    for lo in range(0, t_s.size, chunk):
        t = t_s[lo:lo + chunk]
        seg = np.clip(np.searchsorted(knots.t_s, t, side="right"), 1, knots.t_s.size - 1)
        s, sp = s_curve_progress(knots.curve, seg, t - knots.t_s[seg - 1])
        sign = np.sign(dx[seg - 1])
        x[lo:lo + chunk] = knots.x_m[seg - 1] + sign * s
        v[lo:lo + chunk] = sign * sp
    return x, v


def share_of_move_at(knots: MachineKnots, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For times ``t_s``: the index of the knot ending the enclosing move and the share of that move's
    distance covered at ``t_s`` (of its duration for a dwell), exact for either profile."""
    t_s = np.asarray(t_s, dtype=float)
    seg = np.clip(np.searchsorted(knots.t_s, t_s, side="right"), 1, knots.t_s.size - 1)
    dt = np.diff(knots.t_s)[seg - 1]
    share = np.clip((t_s - knots.t_s[seg - 1]) / np.where(dt > 0, dt, 1.0), 0.0, 1.0)
    if knots.curve is not None:
        dx = np.abs(np.diff(knots.x_m))[seg - 1]
        s, _ = s_curve_progress(knots.curve, seg, t_s - knots.t_s[seg - 1])
        share = np.where(dx > 0, np.clip(s / np.where(dx > 0, dx, 1.0), 0.0, 1.0), share)
    return seg, share


# 16-point Gauss-Legendre nodes and weights on [0, 1]
_GL_X, _GL_W = (0.5 * (np.polynomial.legendre.leggauss(16)[0] + 1.0), 0.5 * np.polynomial.legendre.leggauss(16)[1])


def s_curve_mean(curve: SCurve, func) -> np.ndarray:
    """Distance-weighted mean of ``func(speed)`` over each move, (1/L) int f(v) v dt, by 16-point
    Gauss-Legendre per phase (v is a polynomial of degree <= 2 in each; relative error < 1e-9 for smooth f).
    The deceleration is the acceleration reversed in time, so it counts twice; moves of length 0 give 1."""
    tj, ta, v = curve.tj_s[:, None], curve.ta_s[:, None], curve.v_m_s[:, None]
    total = np.zeros(curve.v_m_s.size)
    for lo, hi in ((0.0 * tj, tj), (tj, ta - tj), (ta - tj, ta)):
        tau = lo + (hi - lo) * _GL_X
        _, sp = _accel_phase(tau, tj, ta, v, curve.jerk_m_s3)
        total += 2.0 * ((hi - lo)[:, 0] * np.sum(_GL_W * func(sp) * sp, axis=1))
    cruise = curve.v_m_s * curve.tv_s
    dist = curve.v_m_s * (curve.ta_s + curve.tv_s)
    mean = (total + cruise * func(curve.v_m_s)) / np.where(dist > 0, dist, 1.0)
    return np.where(dist > 0, mean, 1.0)
