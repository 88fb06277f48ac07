"""The effects together: the wear-rate multiplier of a segment (or cell) and the measured straightness.

m = K_effective / K = asperity share (speed_dependent_wear) x (W / W_ref)^(n - 1) (load_exponent) x rho on
retract strokes (retract_asymmetry) x K(s)/K (running_in) x the duty effects' factors of when and where the
work is done (their modules give the live and the offline forms). :func:`combined_multiplier` is the one place
these are combined (live monitor, simulator, discrepancy fit). y = A0 + delta + c_T (T - T_0) + A_wear
(initial_offset, thermal_drift).
"""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.load_exponent import load_exponent_factor
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.retract_asymmetry import retract_factor
from guide_health.models.wear.effects.speed_dependent_wear import asperity_load_share
from guide_health.models.wear.effects.thermal_drift import gauge_term_m


def wear_rate_multiplier(effects: EffectParameters, speed_m_s: np.ndarray, load_n: np.ndarray,
                         retract: np.ndarray, running_in: np.ndarray | None = None) -> np.ndarray:
    """m = K_effective / K for segments (or cells) with the given speed, load and direction.

    ``running_in`` is K(s)/K of each segment (from running_in.running_in_factor_mean or running_in_factor);
    None means none.
    """
    m = asperity_load_share(speed_m_s, effects.lift_speed_m_s)
    m = m * load_exponent_factor(load_n, effects.load_exponent, effects.load_reference_n)
    if effects.retract_wear_factor != 1.0:
        m = m * retract_factor(retract, effects.retract_wear_factor)
    return combined_multiplier(m, running_in)


def combined_multiplier(material: np.ndarray, running_in: np.ndarray | None = None,
                        duty: np.ndarray | float = 1.0) -> np.ndarray:
    """m = (material factors x K(s)/K) x duty factors [-]: the one product of the effect multipliers, live
    (models/wear/effect_wear.py), in the simulator (sim/machine.py) and in the discrepancy fit
    (analysis/discrepancy/model.py). ``running_in`` None: no running-in; ``duty`` 1.0: no duty effect."""
    m = material if running_in is None else material * running_in
    return m * duty


def effect_multiplier(effects: EffectParameters, speed_m_s: np.ndarray, load_n: np.ndarray, retract: np.ndarray,
                      running_in: np.ndarray | None = None, duty: np.ndarray | float = 1.0) -> np.ndarray:
    """m = K_effective / K with every effect: :func:`wear_rate_multiplier`'s material factors, K(s)/K
    ``running_in`` and ``duty``, the product of the duty effects' factors of each segment, cell or move."""
    return combined_multiplier(wear_rate_multiplier(effects, speed_m_s, load_n, retract), running_in, duty)


def measured_straightness_m(wear_straightness_m: np.ndarray, straightness_initial_m: float,
                            temperature_change_k: np.ndarray | None, effects: EffectParameters) -> np.ndarray:
    """y = A0 + delta + c_T (T - T_0) + A_wear [m] (what a straightness measurement reads)."""
    y = straightness_initial_m + effects.initial_offset_m + np.asarray(wear_straightness_m, dtype=float)
    if effects.thermal_drift_m_per_k != 0.0 and temperature_change_k is not None:
        y = y + gauge_term_m(temperature_change_k, effects.thermal_drift_m_per_k)
    return y
