"""Wear physics that seed 000's baseline lacks: one module per effect, and the registry that lists them.

The baseline (seed 000) is Archard wear with one constant K (Eq. 10), mapped to straightness through Eq. 7
with Eq. 5's j = 1/2, starting from a known A0:

    A(t) = A0 + 2 K G(t) / (H b (l_min + l_max)),        G(t) = sum_i W_i ds_i   [N m]

Each effect is a physical term with physical parameters, in its own module here (registry.py lists them and
derives every list of them): a wear-rate multiplier m_i (dV_i = K W_i ds_i m_i / H) of the material pair or of
the duty (when and where the work is done), a straightness term, or a measurement term. Its module is its one
home: its parameters, its multiplier (or term) and gradient, its live form, its report words, its model-file
keys and simulation parameters; the rest of guide_health reaches it through the registry (the roles and the
methods of base.Effect), never by its name. The simulator's truth (``guide_health.sim.machine``), the
candidates of ``guide_health.analysis.discrepancy`` and the live model (models/wear/effect_wear.py) evaluate the
*same* functions with one parameter type (parameters.EffectParameters), so a hidden effect and the candidate
that should find it are one model, not a fitted curve. The imports below re-export the effects' functions the
simulator and the discrepancy fit call by name (test/test_effect_home.py's allow-list).
"""
from guide_health.models.wear.effects.load_along_rail import load_along_rail_factor
from guide_health.models.wear.effects.load_exponent import load_exponent_factor
from guide_health.models.wear.effects.lubrication_interval import (
    lubrication_interval_factor,
    relubrication_growth_factor,
    time_since_relubrication_s,
)
from guide_health.models.wear.effects.multiplier import (
    combined_multiplier,
    effect_multiplier,
    measured_straightness_m,
    wear_rate_multiplier,
)
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import (
    CANDIDATE_IDS,
    DUTY_EFFECT_IDS,
    EFFECT_IDS,
    EFFECT_VALUE,
)
from guide_health.models.wear.effects.running_in import (
    running_in_factor,
    running_in_factor_mean,
    running_in_factor_spread,
)
from guide_health.models.wear.effects.speed_dependent_wear import LUBRICATION_SPEED_EXPONENT, asperity_load_share
from guide_health.models.wear.effects.stroke_distribution import pass_weight_per_m, straightness_wear_m
from guide_health.models.wear.effects.wear_rate_change import wear_rate_change_factor

__all__ = ["CANDIDATE_IDS", "DUTY_EFFECT_IDS", "EFFECT_IDS", "EFFECT_VALUE", "LUBRICATION_SPEED_EXPONENT",
           "EffectParameters", "asperity_load_share", "load_along_rail_factor", "load_exponent_factor",
           "lubrication_interval_factor", "measured_straightness_m", "pass_weight_per_m",
           "relubrication_growth_factor", "running_in_factor", "running_in_factor_mean",
           "running_in_factor_spread", "straightness_wear_m", "time_since_relubrication_s",
           "wear_rate_change_factor", "wear_rate_multiplier",
           "combined_multiplier", "effect_multiplier"]
