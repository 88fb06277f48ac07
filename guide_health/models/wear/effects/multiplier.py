"""The effects together: the wear-rate multiplier of a segment (or cell) and the measured straightness.

m = K_effective / K = the material factors (registry.MATERIAL_FACTORS, in that order: the asperity share, the
load exponent's, the retract's) x K(s)/K (registry.SLIDING_DECAY) x the duty effects' factors of when and where
the work is done (their modules give the live and the offline forms). :func:`combined_multiplier` is the one
place these are combined (live monitor, simulator, discrepancy fit). y = A0 + delta + c_T (T - T_0) + A_wear
(registry.INITIAL_TERM, registry.GAUGE_TEMPERATURE).
"""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import GAUGE_TEMPERATURE, INITIAL_TERM, MATERIAL_FACTORS


def wear_rate_multiplier(effects: EffectParameters, speed_m_s: np.ndarray, load_n: np.ndarray,
                         retract: np.ndarray, sliding_decay: np.ndarray | None = None) -> np.ndarray:
    """m = K_effective / K for segments (or cells) with the given speed, load and direction.

    ``sliding_decay`` is K(s)/K of each segment (registry.SLIDING_DECAY's factor, mean over the segment or at a
    point); None means none.
    """
    m = None
    for effect in MATERIAL_FACTORS:        # the product in registry order (its last bit depends on it)
        factor = effect.rate_factor(effects, speed_m_s, load_n, retract)
        if factor is not None:
            m = factor if m is None else m * factor
    if m is None:
        m = np.ones_like(np.asarray(speed_m_s, dtype=float))
    return combined_multiplier(m, sliding_decay)


def combined_multiplier(material: np.ndarray, sliding_decay: np.ndarray | None = None,
                        duty: np.ndarray | float = 1.0) -> np.ndarray:
    """m = (material factors x K(s)/K) x duty factors [-]: the one product of the effect multipliers, live
    (models/wear/effect_wear.py), in the simulator (sim/machine.py) and in the discrepancy fit
    (analysis/discrepancy/model.py). ``sliding_decay`` None: no running-in; ``duty`` 1.0: no duty effect."""
    m = material if sliding_decay is None else material * sliding_decay
    return m * duty


def effect_multiplier(effects: EffectParameters, speed_m_s: np.ndarray, load_n: np.ndarray, retract: np.ndarray,
                      sliding_decay: np.ndarray | None = None, duty: np.ndarray | float = 1.0) -> np.ndarray:
    """m = K_effective / K with every effect: :func:`wear_rate_multiplier`'s material factors, K(s)/K
    ``sliding_decay`` and ``duty``, the product of the duty effects' factors of each segment, cell or move."""
    return combined_multiplier(wear_rate_multiplier(effects, speed_m_s, load_n, retract), sliding_decay, duty)


def measured_straightness_m(wear_straightness_m: np.ndarray, straightness_initial_m: float,
                            temperature_change_k: np.ndarray | None, effects: EffectParameters) -> np.ndarray:
    """y = A0 + delta + c_T (T - T_0) + A_wear [m] (what a straightness measurement reads)."""
    y = straightness_initial_m + INITIAL_TERM.reading_offset_m(effects) + np.asarray(wear_straightness_m, dtype=float)
    gauge = GAUGE_TEMPERATURE.reading_term_m(effects, temperature_change_k)
    if gauge is not None:
        y = y + gauge
    return y
