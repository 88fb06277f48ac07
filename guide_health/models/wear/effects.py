"""Wear physics that seed 000's baseline lacks: the terms of the discrepancy workflow (pure numpy, SI).

The baseline (seed 000) is Archard wear with one constant K (Eq. 10), mapped to straightness through
Eq. 7 with Eq. 5's j = 1/2, starting from a known A0:

    A(t) = A0 + 2 K G(t) / (H b (l_min + l_max)),        G(t) = sum_i W_i ds_i   [N m]

Each effect below is a physical term with physical parameters. The simulator's truth
(``guide_health.sim.machine``) and the candidates of ``guide_health.analysis.discrepancy`` evaluate the
*same* functions, so a hidden effect and the candidate that should find it are one model, not a fitted
curve.

Wear-rate multipliers m_i (dV_i = K W_i ds_i m_i / H):

``running_in`` (r [-], s0 [m])
    K decays from (1 + r) K to K over the sliding distance s: K(s) = K (1 + r exp(-s / s0)).
    Seed 000 Fig. 9 shows it: fast straightness loss first, then the steady stage the model describes.
``retract_asymmetry`` (rho [-])
    The retract (return) stroke wears rho times as much per unit Archard work as the feed stroke (chips,
    cutting forces and the loaded contact act on the feed only: seed 000, end of section 2.2).
``speed_dependent_wear`` (v_lift [m/s])
    Mixed lubrication: the film grows with speed, lambda = (v / v_lift)^0.7 (the speed exponent of
    Hamrock-Dowson film formulas, seed 001), and the asperities carry the share 1 / (1 + lambda^2) of
    the load, so m = 1 / (1 + (v / v_lift)^1.4). v_lift is the speed at which film and asperities
    share the load equally (the seed's boundary-to-mixed transition).
``load_exponent`` (n [-])
    Wear rate proportional to W^n instead of W (seed 000 Table 2 tests this): m = (W / W_ref)^(n - 1).
    W_ref only scales K; the simulator uses ``load_reference_n``, the workflow the work-weighted
    geometric mean load of the run, so its fitted K stays comparable with the baseline's.

``wear_rate_change`` (t_c [s], f [-])
    The wear coefficient changes by the factor f at an unknown time t_c (contamination, a chipped wiper, a
    new lubricant batch): m = 1 before, f after. Over a cell of duration d centred at t the share of the
    work after t_c is clip((t + d/2 - t_c) / d, 0, 1) (uniform work within the cell).
``lubrication_interval`` (T [s], a [-]; or b [1/s] with recorded relubrications)
    Wear grows with the time since the last relubrication (the lubricant film thins and is contaminated
    between services). When the bag records the relubrications (``relubricate`` maintenance events,
    models/wear/maintenance.py) tau is the time since the last recorded one (the record's start before the
    first) and m = 1 + b tau; else they are assumed every interval T from the start of the record
    (relubricated at t = 0, T, 2T, ...): m = 1 + a tau / T, tau = t mod T.
``load_along_rail`` (g [1/m])
    The load varies along the rail (a misaligned rail or a non-uniform foundation): W(x) = W (1 + g (x -
    x_ref)), x_ref the work-weighted mean position of the run (so K stays the mean): m = max(1 + g (x -
    x_ref), 0).

Straightness mapping:

``stroke_distribution`` (w [-])
    Eq. 5 replaces the stroke-length coefficient j of every stroke by its mean 1/2. The exact depth of
    the always-travelled zone (Eq. 6) is K/(H b) per unit load per pass over it, whatever the stroke
    length: P(t) = sum_i W_i ds_i m_i / max(L_i, L_s) (L_i the length of the pass containing segment
    i, L_s the slider length: a pass shorter than the slider covers the point for L_i only). With a
    weight w: A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P]; w = 1 is the observed stroke
    distribution, w = 0 Eq. 7. Equal for every w when each job's mean stroke is (l_min + l_max) / 2.

Measurement terms:

``thermal_drift`` (c_T [m/K], dT_ref [K])
    The straightness measurement bends with the guide temperature: y = A + c_T (T - T_ref), T_ref =
    T_0 + dT_ref the temperature at which the guide is straight to A0 (T_0 that of the first measurement).
    dT_ref is fitted when A0 is given (otherwise it is one with A0). Reversible, unlike wear.
``initial_offset`` (delta [m])
    The initial straightness is A0 + delta, not the A0 of the parameters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

EFFECT_IDS = ("running_in", "retract_asymmetry", "speed_dependent_wear", "load_exponent",
              "stroke_distribution", "thermal_drift", "initial_offset")
# duty effects: multipliers of the work by when and where it is done (the simulator hides them too, with a
# recorded relubrication plan for lubrication_interval)
DUTY_EFFECT_IDS = ("wear_rate_change", "lubrication_interval", "load_along_rail")
CANDIDATE_IDS = EFFECT_IDS + DUTY_EFFECT_IDS

# what `guide-health simulate --effect NAME=VALUE` sets, its unit, and the no-effect value
EFFECT_VALUE = {
    "running_in": ("running_in_ratio", "-", 0.0),          # r; s0 = simulation running_in_distance_m
    "retract_asymmetry": ("retract_wear_factor", "-", 1.0),
    "speed_dependent_wear": ("lift_speed_m_s", "m/s", math.inf),
    "load_exponent": ("load_exponent", "-", 1.0),
    "stroke_distribution": ("stroke_distribution_weight", "-", 0.0),
    "thermal_drift": ("thermal_drift_m_per_k", "m/K", 0.0),
    "initial_offset": ("initial_offset_m", "m", 0.0),
    # t_c = simulation wear_rate_change_h; b per second of the time since the last relubricate event
    # (simulation relubrication_interval_h, or --maintenance relubricate events); x_ref the run's work-weighted
    # mean position
    "wear_rate_change": ("wear_rate_change_factor", "-", 1.0),
    "lubrication_interval": ("lubrication_wear_growth_per_s", "1/s", 0.0),
    "load_along_rail": ("load_gradient_per_m", "1/m", 0.0),
}

LUBRICATION_SPEED_EXPONENT = 0.7     # lambda ~ v^0.7 (Hamrock-Dowson film thickness, seed 001)


@dataclass
class WearEffects:
    """Parameter values of every effect; the defaults are the baseline (no effect)."""

    running_in_ratio: float = 0.0            # r: K(s=0) = (1 + r) K
    running_in_distance_m: float = 100.0     # s0
    retract_wear_factor: float = 1.0         # rho
    lift_speed_m_s: float = math.inf         # v_lift
    load_exponent: float = 1.0               # n
    load_reference_n: float = 1000.0         # W_ref
    stroke_distribution_weight: float = 0.0  # w
    thermal_drift_m_per_k: float = 0.0       # c_T
    initial_offset_m: float = 0.0            # delta
    wear_rate_change_factor: float = 1.0     # f
    wear_rate_change_time_s: float = math.inf  # t_c [s from the start]
    lubrication_wear_growth_per_s: float = 0.0  # b
    relubrication_t_s: tuple = ()            # recorded relubrications [s from the start]
    load_gradient_per_m: float = 0.0         # g
    load_reference_position_m: float = 0.0   # x_ref

    @classmethod
    def from_values(cls, values: dict[str, float], **extra) -> WearEffects:
        """From ``{effect id: value}`` (the ``--effect`` values) plus field overrides."""
        fields = {EFFECT_VALUE[name][0]: float(v) for name, v in values.items()}
        fields.update(extra)
        return cls(**fields)


def running_in_factor(sliding_distance_m: np.ndarray, ratio: float, distance_m: float) -> np.ndarray:
    """K(s) / K = 1 + r exp(-s / s0) at the sliding distance s [m]."""
    if ratio == 0.0:
        return np.ones_like(np.asarray(sliding_distance_m, dtype=float))
    return 1.0 + ratio * np.exp(-np.asarray(sliding_distance_m, dtype=float) / distance_m)


def running_in_factor_mean(s_start_m: np.ndarray, s_end_m: np.ndarray, ratio: float,
                           distance_m: float) -> np.ndarray:
    """Mean of K(s)/K over [s_start, s_end] (exact integral of the exponential over a segment)."""
    s_a = np.asarray(s_start_m, dtype=float)
    s_b = np.asarray(s_end_m, dtype=float)
    if ratio == 0.0:
        return np.ones_like(s_a)
    ds = s_b - s_a
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_exp = distance_m * (np.exp(-s_a / distance_m) - np.exp(-s_b / distance_m)) / ds
    mean_exp = np.where(ds > 0, mean_exp, np.exp(-s_a / distance_m))
    return 1.0 + ratio * mean_exp


def running_in_factor_spread(mean_distance_m: np.ndarray, distance_var_m2: np.ndarray, ratio: float,
                             distance_m: float) -> np.ndarray:
    """Mean of K(s)/K over sliding distances spread uniformly with the given mean and variance:
    1 + r exp(-s_mean / s0) sinh(h) / h, h = sqrt(3 var) / s0 (half-width of the uniform over s0)."""
    if ratio == 0.0:
        return np.ones_like(np.asarray(mean_distance_m, dtype=float))
    h = np.sqrt(3.0 * np.asarray(distance_var_m2, dtype=float)) / distance_m
    shape = np.where(h > 1e-6, np.sinh(h) / np.where(h > 1e-6, h, 1.0), 1.0 + h * h / 6.0)
    return 1.0 + ratio * np.exp(-np.asarray(mean_distance_m, dtype=float) / distance_m) * shape


def asperity_load_share(speed_m_s: np.ndarray, lift_speed_m_s: float) -> np.ndarray:
    """Share of the load on asperities, 1 / (1 + lambda^2), lambda = (v / v_lift)^0.7 [-]."""
    v = np.abs(np.asarray(speed_m_s, dtype=float))
    if not math.isfinite(lift_speed_m_s):
        return np.ones_like(v)
    return 1.0 / (1.0 + (v / lift_speed_m_s) ** (2.0 * LUBRICATION_SPEED_EXPONENT))


def load_exponent_factor(load_n: np.ndarray, exponent: float, reference_load_n: float) -> np.ndarray:
    """(W / W_ref)^(n - 1): wear rate proportional to W^n [-]."""
    w = np.asarray(load_n, dtype=float)
    if exponent == 1.0:
        return np.ones_like(w)
    return (np.maximum(w, 1e-12) / reference_load_n) ** (exponent - 1.0)


def wear_rate_multiplier(effects: WearEffects, speed_m_s: np.ndarray, load_n: np.ndarray,
                         retract: np.ndarray, running_in: np.ndarray | None = None) -> np.ndarray:
    """m = K_effective / K for segments (or cells) with the given speed, load and direction.

    ``running_in`` is K(s)/K of each segment (from :func:`running_in_factor_mean` or
    :func:`running_in_factor`); None means none.
    """
    m = asperity_load_share(speed_m_s, effects.lift_speed_m_s)
    m = m * load_exponent_factor(load_n, effects.load_exponent, effects.load_reference_n)
    if effects.retract_wear_factor != 1.0:
        m = m * np.where(np.asarray(retract, dtype=bool), effects.retract_wear_factor, 1.0)
    if running_in is not None:
        m = m * running_in
    return m


def pass_weight_per_m(pass_length_m: np.ndarray, slider_length_m: float) -> np.ndarray:
    """1 / max(L, L_s) [1/m]: a pass deposits W per unit (W ds) / max(L, L_s) at the always-travelled
    zone (Eq. 6's severe-wear zone), so a full pass adds K W / (H b) of depth whatever its length."""
    return 1.0 / np.maximum(np.asarray(pass_length_m, dtype=float), slider_length_m)


def straightness_wear_m(wear_coefficient: float, hardness_pa: float, contact_width_m: float,
                        effective_work_nm: np.ndarray, effective_pass_work_n: np.ndarray,
                        stroke_sum_m: float, stroke_distribution_weight: float = 0.0) -> np.ndarray:
    """A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] [m].  # seed 000 Eq. 7/10 (w = 0)"""
    g = np.asarray(effective_work_nm, dtype=float)
    p = np.asarray(effective_pass_work_n, dtype=float)
    w = stroke_distribution_weight
    return wear_coefficient / (hardness_pa * contact_width_m) * ((1.0 - w) * 2.0 * g / stroke_sum_m + w * p)


def measured_straightness_m(wear_straightness_m: np.ndarray, straightness_initial_m: float,
                            temperature_change_k: np.ndarray | None, effects: WearEffects) -> np.ndarray:
    """y = A0 + delta + c_T (T - T_0) + A_wear [m] (what a straightness measurement reads)."""
    y = straightness_initial_m + effects.initial_offset_m + np.asarray(wear_straightness_m, dtype=float)
    if effects.thermal_drift_m_per_k != 0.0 and temperature_change_k is not None:
        y = y + effects.thermal_drift_m_per_k * np.asarray(temperature_change_k, dtype=float)
    return y


def wear_rate_change_factor(time_s: np.ndarray, duration_s: np.ndarray, change_time_s: float,
                            factor: float) -> np.ndarray:
    """m of ``wear_rate_change`` for cells of the given duration centred at ``time_s``: 1 + (f - 1) x the
    share of the cell's work after t_c [-]."""
    t = np.asarray(time_s, dtype=float)
    d = np.maximum(np.asarray(duration_s, dtype=float), 1e-9)
    after = np.clip((t + 0.5 * d - change_time_s) / d, 0.0, 1.0)
    return 1.0 + (factor - 1.0) * after


def lubrication_interval_factor(time_s: np.ndarray, interval_s: float, growth: float) -> np.ndarray:
    """m of ``lubrication_interval``: 1 + a (t mod T) / T [-] (relubricated at t = 0, T, 2T, ...)."""
    t = np.asarray(time_s, dtype=float)
    return 1.0 + growth * np.mod(t, interval_s) / interval_s


def time_since_relubrication_s(time_s: np.ndarray, relubrication_t_s: np.ndarray) -> np.ndarray:
    """tau = t - (the last relubrication at or before t; the record's start t = 0 before the first) [s]."""
    t = np.asarray(time_s, dtype=float)
    events = np.sort(np.asarray(relubrication_t_s, dtype=float))
    i = np.searchsorted(events, t, side="right") - 1
    last = np.where(i >= 0, events[np.clip(i, 0, None)] if events.size else 0.0, 0.0)
    return t - np.minimum(last, t)


def relubrication_growth_factor(time_s: np.ndarray, relubrication_t_s: np.ndarray, growth_per_s: float) -> np.ndarray:
    """m of ``lubrication_interval`` with recorded relubrications: 1 + b tau [-] (tau: time since the last)."""
    return 1.0 + growth_per_s * time_since_relubrication_s(time_s, relubrication_t_s)


def load_along_rail_factor(position_m: np.ndarray, gradient_per_m: float, reference_m: float) -> np.ndarray:
    """m of ``load_along_rail``: max(1 + g (x - x_ref), 0) [-]."""
    return np.maximum(1.0 + gradient_per_m * (np.asarray(position_m, dtype=float) - reference_m), 0.0)
