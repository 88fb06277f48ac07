"""How often to measure straightness: the 90 % interval of the remaining precision life that regular
measurements buy, from the model's own interval (models/wear/calibration.py's K posterior, Student-t from
three measurements on; models/wear/life.py's Eq. 12 life at K and at its interval's ends).

At a constant duty the straightness grows linearly in running time, A(t) = A0 + K g(t) with
g(t) = (A_max - A0) t / (K_0 L_0) per unit K (L_0: the precision life of a new guide at this duty with the
configured K_0). A measurement every ``interval_h`` running hours up to ``at_h`` (readings on the model,
scatter at the gauge noise ``straightness_noise_m``) gives K's interval and with it the remaining life's;
:func:`life_interval_half_width` is its larger half-width relative to the life, and
:func:`longest_measurement_interval_h` the longest whole-hour spacing that keeps it under a target.
"""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.wear.calibration import WearCoefficientEstimator
from guide_health.models.wear.life import LifeNow, remaining_life_interval_s


def life_interval_half_width(params, life_new_h: float, interval_h: float, at_h: float) -> float:
    """max(life - low, high - life) / life of the remaining life at ``at_h`` running hours, with straightness
    measured every ``interval_h`` running hours (none: the prior's interval); ``params``: the axis's typed
    parameters (params.typed.WearAxisParams): its wear_coefficient, wear_coefficient_prior_rel_sd,
    straightness_noise_m, straightness_initial_m and straightness_limit_m."""
    k0, a0, a_max = params.wear_coefficient, params.straightness_initial_m, params.straightness_limit_m
    per_k_per_h = (a_max - a0) / (k0 * life_new_h)            # dg/dt [m per unit K per running hour]
    est = WearCoefficientEstimator(k0, params.wear_coefficient_prior_rel_sd, params.straightness_noise_m, a0)
    for i, t_h in enumerate(np.arange(interval_h, at_h + 1e-9, interval_h)):
        g = per_k_per_h * t_h
        est.add(i, a0 + k0 * g, g, 0.0)
    k_low, k, k_high = est.interval90()
    now = LifeNow(a0, a_max, per_k_per_h * at_h, per_k_per_h / 3600.0, k, k_low, k_high)
    life, low, high = remaining_life_interval_s(now)
    return max(life - low, high - life) / life


def longest_measurement_interval_h(params: dict, life_new_h: float, at_h: float, target: float) -> int:
    """The longest whole number of running hours between measurements that keeps
    :func:`life_interval_half_width` at ``at_h`` at or below ``target`` (0: even hourly measurements do
    not)."""
    best = 0
    for n in range(1, int(math.floor(at_h)) + 1):
        if life_interval_half_width(params, life_new_h, n, at_h) <= target:
            best = n
    return best
