"""Oscillating slewing duties (yaw, pitch) with their axis angle and tilting-clearance measurements.

* yaw: long dwell (``yaw_dwell_min_s`` + exponential, mean ``yaw_dwell_mean_s``), then a rotation of
  U(``yaw_rotation_min_rad``, ``yaw_rotation_max_rad``) in either sense at ``slew_speed_rad_s``;
* pitch: constant oscillations about 0, each half period to +-A, A ~ U(``pitch_amplitude_min_rad``,
  ``pitch_amplitude_max_rad``) per swing.

Time-compressed: one load sample per motion (F_a = ``dead_weight_n`` x (1 + 0.05 N), M_T = ``dead_moment_nm`` x
a lognormal of coefficient of variation ``moment_cv``; the load in force while the axis moves) and axis samples
every ``axis_sample_step_rad`` of a motion plus one at its end; nothing is written during a dwell. A 2-year
yaw duty is ~17 000 motions.

Truth: the clearance c(t) = c_0 + k g(t), g the clearance per unit k of models/slewing/raceway_wear.py (the
monitor's physics, with the true k) over the travel of each motion; ``clearance_measurements`` readings at
evenly spaced times (moved to the end of a motion in progress: the tilting test is made at standstill) with
noise ``tilting_clearance_noise_m``. The same random duty continued past the end gives the true remaining life
to ``tilting_clearance_limit_m`` (metadata ``truth_remaining_life_h``; inf when not reached within 50 x the
duration).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from guide_health.models.slewing.raceway_wear import clearance_rate_per_k, sliding_weight_table
from guide_health.models.slewing.row_loads import axial_row_roller_load_distributions
from guide_health.runs import SlewingLoadRun
from guide_health.sim.machine import START_TIME_NS

CONTINUATION_FACTOR = 50.0      # the truth's duty is continued at most this many durations


class _Duty:
    """Motions one after another: (start time [s], load (F_a, M_T), angle path [rad], duration [s])."""

    def __init__(self, p: Any, rng: np.random.Generator) -> None:
        self.p, self.rng = p, rng
        self.t_s, self.angle = 0.0, 0.0
        self.sign = 1.0
        sd_ln = math.sqrt(math.log1p(p.moment_cv ** 2))
        self.moment_mu, self.moment_sd = math.log(max(p.dead_moment_nm, 1e-9)) - 0.5 * sd_ln ** 2, sd_ln

    def next(self) -> tuple[float, float, float, float, float]:
        """(start [s], F_a [N], M_T [N m], angle at the end [rad], motion duration [s])."""
        p, rng = self.p, self.rng
        axial = p.dead_weight_n * (1.0 + 0.05 * rng.standard_normal())
        moment = math.exp(self.moment_mu + self.moment_sd * rng.standard_normal()) if p.dead_moment_nm > 0 else 0.0
        if p.duty == "yaw":
            self.t_s += p.yaw_dwell_min_s + rng.exponential(p.yaw_dwell_mean_s - p.yaw_dwell_min_s)
            rotation = rng.uniform(p.yaw_rotation_min_rad, p.yaw_rotation_max_rad) * rng.choice((-1.0, 1.0))
            duration = abs(rotation) / p.slew_speed_rad_s
            end = self.angle + rotation
        else:
            self.sign = -self.sign
            end = self.sign * rng.uniform(p.pitch_amplitude_min_rad, p.pitch_amplitude_max_rad)
            duration = 0.5 * p.pitch_period_s
        start = self.t_s
        self.t_s += duration
        return start, axial, moment, end, duration


def simulate_oscillating_duty(p: Any, bearing: Any, seed: int, metadata: dict) -> SlewingLoadRun:
    """The yaw or pitch duty of the typed simulation parameters ``p`` on the bearing ``bearing`` (typed
    slewing_monitor parameters: its geometry gives the truth's wear); see the module doc."""
    rng = np.random.default_rng(seed)
    chi = sliding_weight_table(bearing.roller_length_m, bearing.roller_diameter_m, bearing.youngs_modulus_pa,
                               bearing.poisson)
    duty = _Duty(p, rng)
    end_s = p.duration_h * 3600.0
    load_t, axial, moment = [], [], []
    axis_t, axis_angle = [0.0], [0.0]
    g_events = []                  # (start, duration, g at start, g rate per s) of every motion
    g = 0.0
    limit_g = (p.tilting_clearance_limit_m - p.tilting_clearance_initial_m) / p.true_raceway_wear_coefficient_m2_n
    truth_s = math.inf
    while True:
        start, fa, mt, target, duration = duty.next()
        if start >= end_s and (g >= limit_g or start > end_s * CONTINUATION_FACTOR):
            break
        upper, lower = axial_row_roller_load_distributions(fa, mt, bearing.roller_count, bearing.raceway_diameter_m)
        rate_rad = (clearance_rate_per_k(upper, chi, bearing.raceway_diameter_m)
                    + clearance_rate_per_k(lower, chi, bearing.raceway_diameter_m))
        travel = abs(target - duty.angle)
        if start + duration <= end_s:
            steps = max(1, math.ceil(travel / p.axis_sample_step_rad))
            u = np.arange(1, steps + 1) / steps
            load_t.append(start)
            axial.append(fa)
            moment.append(mt)
            axis_t.extend([start, *(start + u * duration)])
            axis_angle.extend([duty.angle, *(duty.angle + u * (target - duty.angle))])
        if g < limit_g <= g + rate_rad * travel and math.isinf(truth_s):
            truth_s = start + duration * (limit_g - g) / (rate_rad * travel) - end_s
        g_events.append((start, duration, g, rate_rad * travel / duration))
        g += rate_rad * travel
        duty.angle = target
    axis_t.append(end_s)
    axis_angle.append(axis_angle[-1])
    clearance_t, clearance = _measurements(p, rng, g_events, end_s)
    ns = lambda t: START_TIME_NS + np.round(np.asarray(t, dtype=float) * 1e9).astype(np.int64)  # noqa: E731
    meta = {**metadata, "scenario": f"{p.duty} duty", "seed": seed,
            "truth_remaining_life_h": truth_s / 3600.0 if truth_s >= 0 else 0.0}
    return SlewingLoadRun(t_ns=ns(load_t), axial_n=np.asarray(axial), radial_n=0.02 * np.asarray(axial),
                          moment_nm=np.asarray(moment), metadata=meta, axis_t_ns=ns(axis_t),
                          axis_angle_rad=np.asarray(axis_angle), clearance_t_ns=ns(clearance_t),
                          clearance_m=np.asarray(clearance))


def _measurements(p: Any, rng: np.random.Generator, g_events: list, end_s: float) -> tuple[list, list]:
    """``clearance_measurements`` noisy readings of c_0 + k g(t) at evenly spaced standstill times."""
    times, values = [], []
    starts = np.asarray([e[0] for e in g_events])
    for j in range(p.clearance_measurements):
        t = end_s * (j + 1) / (p.clearance_measurements + 1)
        i = int(np.searchsorted(starts, t, side="right")) - 1         # the motion started last before t
        g = 0.0
        if i >= 0:
            start, duration, g_start, rate = g_events[i]
            t = max(t, start + duration + 1.0)                         # at standstill
            g = g_start + rate * duration
        times.append(t)
        values.append(p.tilting_clearance_initial_m + p.true_raceway_wear_coefficient_m2_n * g
                      + p.tilting_clearance_noise_m * rng.standard_normal())
    return times, values
