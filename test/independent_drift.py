"""An independent writer of straightness records for the consistency checks of named effects: smooth change of
wear, a gauge that drifts with clock time, a step in K and a running-in, on a duty with idle periods.

Written from the physics in words (docs/discrepancy.md), importing nothing from guide_health.analysis.discrepancy
or guide_health.models.wear: Archard's law summed sample by sample over a run's JointState and load samples
(zero-order hold of the load), Eq. 7's straightness 2 K G / (H b (l_min + l_max)), and per form:

- ``k_ramp``: K (1 + a t / T), t the clock time from the record's start, T its duration (wear accelerating
  smoothly, e.g. debris or a lubricant degrading);
- ``gauge_creep``: plain wear plus a gauge zero creeping c per clock hour (idle hours included);
- ``k_step``: K x f from t_c on;
- ``running_in``: K (1 + r e^(-s/s0)) over the sliding distance s, integrated per sample as the change of
  s + r s0 (1 - e^(-s/s0)).

The motion and load are a run's (any generator); :func:`with_idle` makes the axis stand still in given windows
(the position held, the samples kept), so that wear stops while the clock runs.
"""
from __future__ import annotations

import math

import numpy as np


def with_idle(run, windows_h) -> None:
    """The axis stands still in each (start, end) window [h from the first joint sample]: the position is held
    at its value at the window's start (in place)."""
    t_h = (np.asarray(run.joint_t_ns, dtype=np.int64) - int(run.joint_t_ns[0])) * 1e-9 / 3600.0
    x = np.array(run.joint_position_m, dtype=float)
    for start, end in windows_h:
        inside = (t_h >= start) & (t_h < end)
        if inside.any():
            x[inside] = x[np.argmax(inside)]
    run.joint_position_m = x
    if getattr(run, "joint_velocity_m_s", None) is not None and np.size(run.joint_velocity_m_s):
        v = np.array(run.joint_velocity_m_s, dtype=float)
        for start, end in windows_h:
            v[(t_h >= start) & (t_h < end)] = 0.0
        run.joint_velocity_m_s = v


def independent_straightness_m(run, form: str, value: dict, *, wear_coefficient: float, hardness_pa: float,
                               contact_width_m: float, straightness_initial_m: float,
                               stroke_sum_m: float) -> np.ndarray:
    """Noise-free straightness [m] at the run's straightness stamps under ``form`` ('' = plain Archard) with
    its ``value`` (k_ramp: a; gauge_creep: m_per_h; k_step: factor, t_c_h; running_in: r, s0_m)."""
    t = np.asarray(run.joint_t_ns, dtype=np.int64)
    t_h = (t - t[0]) * 1e-9 / 3600.0
    x = np.asarray(run.joint_position_m, dtype=float)
    ds = np.abs(np.diff(x))
    held = np.searchsorted(run.load_t_ns, t[1:], side="right") - 1
    load = np.where(held >= 0, np.asarray(run.load_n, dtype=float)[np.clip(held, 0, None)], 0.0)
    mid_h = 0.5 * (t_h[1:] + t_h[:-1])
    if form == "running_in":
        s = np.concatenate(([0.0], np.cumsum(ds)))
        r, s0 = value["r"], value["s0_m"]
        ds = np.diff(s + r * s0 * (1.0 - np.exp(-s / s0)))
    work = load * ds
    if form == "k_ramp":
        work = work * (1.0 + value["a"] * mid_h / t_h[-1])
    elif form == "k_step":
        work = work * np.where(mid_h >= value["t_c_h"], value["factor"], 1.0)
    g = np.concatenate(([0.0], np.cumsum(work)))
    at_h = (np.asarray(run.straightness_t_ns, dtype=np.int64) - t[0]) * 1e-9 / 3600.0
    y = straightness_initial_m + wear_coefficient / (hardness_pa * contact_width_m) * 2.0 * np.interp(
        at_h, t_h, g) / stroke_sum_m
    if form == "gauge_creep":
        y = y + value["m_per_h"] * at_h
    return y


def idle_windows_h(hours: float, every_h: float = 8.0, idle_h: float = 3.0) -> list[tuple[float, float]]:
    """Idle windows of ``idle_h`` after every ``every_h`` of the record (a night shift off)."""
    starts = np.arange(every_h, hours - idle_h, every_h + idle_h)
    return [(float(s), float(s + idle_h)) for s in starts if math.isfinite(s)]
