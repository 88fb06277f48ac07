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
that should find it are one model, not a fitted curve. The package also gives each effect module's public
functions by name (module ``__getattr__`` over registry.MODULES: tests and tools that check a form directly), so
no file outside an effect's module names the module.
"""
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
    MODULES,
)


def __getattr__(name: str):
    """A public function or constant defined in an effect's module (the first of registry.MODULES that has it)."""
    for module in MODULES:
        value = vars(module).get(name)
        if value is not None and not name.startswith("_") and (
                name.isupper() or getattr(value, "__module__", None) == module.__name__):
            return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["CANDIDATE_IDS", "DUTY_EFFECT_IDS", "EFFECT_IDS", "EFFECT_VALUE", "EffectParameters", "combined_multiplier",
           "effect_multiplier", "measured_straightness_m", "wear_rate_multiplier"]
