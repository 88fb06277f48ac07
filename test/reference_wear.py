"""An independent reference for the discrepancy acceptance: the straightness a guide with hidden wear
effects would show, written from the physics (docs/discrepancy.md's table, seed 000 Eq. 5-7/10) without
importing anything from guide_health.analysis.discrepancy or guide_health.models.wear.

Two pieces:
- closed forms of each effect at constant duty (constant speed, load and stroke), used to check the
  integrator below;
- :func:`reference_straightness_m`, a sample-by-sample integration over the bag's own JointState and
  load samples (what a perfect sensor-based model could know), giving the noise-free measurement at the
  straightness stamps.

The formulas deliberately use other but equivalent forms than the package (running-in through the
antiderivative of K(s), pass lengths from the sign changes of dx, the load by zero-order hold of the
load topic), so a wrong term in the package's candidates is not in this truth too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# lambda ~ v^0.7: the film-speed exponent of the Hamrock-Dowson formula (seed 001 Eq. for h_min: u^0.68,
# docs/discrepancy.md rounds it to 0.7); the asperity share is 1 / (1 + lambda^2)
FILM_SPEED_EXPONENT = 0.7


@dataclass
class Hidden:
    """Hidden effect parameters (no effect by default)."""

    running_in_ratio: float = 0.0
    running_in_distance_m: float = 500.0
    retract_wear_factor: float = 1.0
    lift_speed_m_s: float = math.inf
    load_exponent: float = 1.0
    load_reference_n: float = 5000.0
    stroke_distribution_weight: float = 0.0
    thermal_drift_m_per_k: float = 0.0
    initial_offset_m: float = 0.0


def hidden_from_effects(effects: dict[str, float], running_in_distance_m: float,
                        load_reference_n: float) -> Hidden:
    """The ``--effect NAME=VALUE`` dict as :class:`Hidden` (names from docs/discrepancy.md)."""
    names = {"running_in": "running_in_ratio", "retract_asymmetry": "retract_wear_factor",
             "speed_dependent_wear": "lift_speed_m_s", "load_exponent": "load_exponent",
             "stroke_distribution": "stroke_distribution_weight", "thermal_drift": "thermal_drift_m_per_k",
             "initial_offset": "initial_offset_m"}
    h = Hidden(running_in_distance_m=running_in_distance_m, load_reference_n=load_reference_n)
    for name, value in effects.items():
        setattr(h, names[name], float(value))
    return h


# --- closed forms at constant duty -------------------------------------------------------------


def effective_distance_running_in(s_m, r, s0_m):
    """int_0^s (1 + r e^(-u/s0)) du = s + r s0 (1 - e^(-s/s0))."""
    s = np.asarray(s_m, dtype=float)
    return s + r * s0_m * (1.0 - np.exp(-s / s0_m))


def asperity_share(v_m_s, lift_speed_m_s):
    """1 / (1 + (v / v_lift)^(2 * 0.7))."""
    if not math.isfinite(lift_speed_m_s):
        return np.ones_like(np.asarray(v_m_s, dtype=float))
    return 1.0 / (1.0 + (np.abs(v_m_s) / lift_speed_m_s) ** (2 * FILM_SPEED_EXPONENT))


def constant_duty_wear_m(h: Hidden, k, hardness_pa, width_m, stroke_m, cycles, feed_load_n, retract_load_n,
                         feed_speed_m_s, retract_speed_m_s, slider_length_m):
    """A_wear [m] after ``cycles`` feed + retract strokes of one length L (so l_min + l_max = 2 L):
    K/(H b) [(1-w) G/L + w P], with G the effective work, P = G / max(L, L_s)."""
    n = np.asarray(cycles, dtype=float)
    feed_m = asperity_share(feed_speed_m_s, h.lift_speed_m_s) * (feed_load_n / h.load_reference_n) ** (
        h.load_exponent - 1.0)
    back_m = h.retract_wear_factor * asperity_share(retract_speed_m_s, h.lift_speed_m_s) * (
        retract_load_n / h.load_reference_n) ** (h.load_exponent - 1.0)
    if h.running_in_ratio:
        # running-in acts on the sliding distance, alternating feed and retract strokes of L each: the
        # effective distance of cycle c's feed is S(2cL + L) - S(2cL), its retract S(2cL + 2L) - S(2cL + L)
        c = np.arange(int(n.max()) + 1)
        f = (effective_distance_running_in((2 * c + 1) * stroke_m, h.running_in_ratio, h.running_in_distance_m)
             - effective_distance_running_in(2 * c * stroke_m, h.running_in_ratio, h.running_in_distance_m))
        b = (effective_distance_running_in((2 * c + 2) * stroke_m, h.running_in_ratio, h.running_in_distance_m)
             - effective_distance_running_in((2 * c + 1) * stroke_m, h.running_in_ratio, h.running_in_distance_m))
        per_cycle = feed_load_n * feed_m * f + retract_load_n * back_m * b
        g = np.concatenate(([0.0], np.cumsum(per_cycle)))[n.astype(int)]
    else:
        g = n * stroke_m * (feed_load_n * feed_m + retract_load_n * back_m)
    w = h.stroke_distribution_weight
    return k / (hardness_pa * width_m) * ((1 - w) * g / stroke_m + w * g / max(stroke_m, slider_length_m))


# --- sample-by-sample integration over a bag's samples --------------------------------------------


def pass_lengths_m(dx: np.ndarray) -> np.ndarray:
    """For each sample interval, the length of the pass (same direction of motion, dwells skipped) it
    belongs to [m]; 0 for intervals without motion."""
    moving = dx != 0.0
    sign = np.sign(dx)
    # carry the last direction through dwells, then start a new pass at every change of direction
    idx = np.where(moving, np.arange(dx.size), 0)
    np.maximum.accumulate(idx, out=idx)
    carried = sign[idx]
    new_pass = np.concatenate(([True], carried[1:] != carried[:-1]))
    pass_id = np.cumsum(new_pass) - 1
    lengths = np.bincount(pass_id, weights=np.abs(dx))
    return np.where(moving, lengths[pass_id], 0.0)


def reference_straightness_m(run, h: Hidden, *, wear_coefficient, hardness_pa, contact_width_m,
                             slider_length_m, straightness_initial_m, stroke_sum_m) -> np.ndarray:
    """Noise-free straightness [m] at ``run.straightness_t_ns`` of a guide with the hidden effects ``h``,
    integrated over the bag's JointState samples (feed = +x, retract = -x) with the load topic held from
    its last sample, and the temperature interpolated from ``guide/temperature``."""
    t_ns = np.asarray(run.joint_t_ns, dtype=np.int64)
    x = np.asarray(run.joint_position_m, dtype=float)
    dx = np.diff(x)
    ds = np.abs(dx)
    dt = np.diff(t_ns) * 1e-9
    v = ds / dt
    held = np.searchsorted(run.load_t_ns, t_ns[1:], side="right") - 1
    load = np.asarray(run.load_n, dtype=float)[np.clip(held, 0, None)]
    load = np.where(held >= 0, load, 0.0)
    s = np.concatenate(([0.0], np.cumsum(ds)))
    if h.running_in_ratio:
        eff = effective_distance_running_in(s, h.running_in_ratio, h.running_in_distance_m)
        ds_eff = np.diff(eff)
    else:
        ds_eff = ds
    m = asperity_share(v, h.lift_speed_m_s)
    if h.load_exponent != 1.0:
        m = m * (np.maximum(load, 1e-9) / h.load_reference_n) ** (h.load_exponent - 1.0)
    m = m * np.where(dx < 0, h.retract_wear_factor, 1.0)
    work = load * ds_eff * m
    pass_work = work / np.maximum(pass_lengths_m(dx), slider_length_m)
    g = np.concatenate(([0.0], np.cumsum(work)))
    p = np.concatenate(([0.0], np.cumsum(pass_work)))
    at = np.asarray(run.straightness_t_ns, dtype=np.int64)
    # the work done up to each measurement stamp (the sample interval containing it pro rata)
    tj = (t_ns - t_ns[0]) * 1e-9
    ta = (at - t_ns[0]) * 1e-9
    g_at, p_at = np.interp(ta, tj, g), np.interp(ta, tj, p)
    w = h.stroke_distribution_weight
    wear = wear_coefficient / (hardness_pa * contact_width_m) * ((1 - w) * 2 * g_at / stroke_sum_m + w * p_at)
    y = straightness_initial_m + h.initial_offset_m + wear
    if h.thermal_drift_m_per_k and run.temperature_t_ns.size:
        temp = np.interp(at.astype(float), np.asarray(run.temperature_t_ns, dtype=float), run.temperature_c)
        y = y + h.thermal_drift_m_per_k * (temp - temp[0])
    return y
