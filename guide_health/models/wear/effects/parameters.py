"""The one effect-parameter type, offline (simulator truth, discrepancy fit) and live (wear_monitor).

Its fields are the registry's: each effect declares its own (base.Effect.fields, with their meaning) and how
the live model fills them from a guide's parameters (base.Effect.live_values). Times are on the caller's clock:
seconds from the record's start offline, seconds since the stamps' epoch live (the model file's ``*_stamp_s``).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from guide_health.models.wear.effects.base import Effect
from guide_health.models.wear.effects.registry import BY_ID, COVARIANCE_NAMES, EFFECTS, PHI_NAMES, simulate_field


def _no_effect(effect: Effect, name: str, value: Any) -> Any:
    """A field's no-effect value: the effect's, or (None) the default of its wear_monitor parameter ``name``."""
    return value if value is not None else next(p.default for p in effect.parameters if p.name == name)


class _EffectParameterMethods:
    """The methods of :data:`EffectParameters` (its fields come from the registry)."""

    @classmethod
    def from_values(cls, values: dict[str, float], **extra) -> Any:
        """From ``{effect id: value}`` (the ``simulate --effect`` values) plus field overrides."""
        fields = {simulate_field(BY_ID[name].simulate.name): float(v) for name, v in values.items()}
        fields.update(extra)
        return cls(effects=tuple(values), **fields)

    @classmethod
    def from_params(cls, p: Any) -> Any:
        """The live model's (a guide's frozen wear_monitor parameters, guide_health.params.typed, which hold
        ``diagnose --out``'s model file); None without effects. An effect not named keeps its no-effect value
        (each effect's ``live_values``)."""
        ids = tuple(e.strip() for e in str(p.effects).split(",") if e.strip())
        if not ids:
            return None
        values: dict[str, Any] = {}
        for effect in EFFECTS:     # each effect reads its own parameters only (plain values)
            own = {q.name: getattr(p, q.name) for q in effect.parameters}
            values.update(effect.live_values(own, effect.id in ids))
        return cls(effects=ids, slider_length_m=float(p.slider_length_m),
                   covariance=tuple(float(v) for v in p.effect_covariance), **values)

    def phi(self) -> np.ndarray:
        """The effect parameters in covariance-row order after K (registry.PHI_NAMES): each field of the row's
        name, v_lift 0 when absent; rows without a field (the gauge offset, A0) are deviations, 0."""
        return np.array([self._phi_value(name) for name in PHI_NAMES])

    def _phi_value(self, name: str) -> float:
        value = getattr(self, name, 0.0)
        return value if math.isfinite(value) else 0.0

    def covariance_matrix(self) -> np.ndarray:
        n = len(COVARIANCE_NAMES)
        c = np.asarray(self.covariance, dtype=float)
        if c.size == 0:
            return np.zeros((n, n))
        if c.size != n * n:       # the schema widens an older file's (params/schema.py LIST_UPGRADES)
            raise ValueError(f"effect_covariance has {c.size} numbers, not {n * n}")
        return c.reshape(n, n)


#: the one effect-parameter type: the named effect ids, then each registry entry's fields (base.Effect.fields,
#: catalogue order; the defaults are the baseline, no effect), the slider length L_s [m] (the live pass weight)
#: and the model file's covariance (live: len(COVARIANCE_NAMES)^2 numbers, row-major in that order)
_FIELDS = ([("effects", tuple, dataclasses.field(default=()))]
           + [(name, Any, dataclasses.field(default=_no_effect(e, name, value)))
              for e in EFFECTS for name, value, _ in e.fields]
           + [("slider_length_m", float, dataclasses.field(default=0.0)),
              ("covariance", tuple, dataclasses.field(default=()))])
EffectParameters = dataclasses.make_dataclass("EffectParameters", _FIELDS, bases=(_EffectParameterMethods,),
                                              frozen=True)
EffectParameters.__module__ = __name__
EffectParameters.__doc__ = "Parameter values of every effect; the defaults are the baseline (no effect)."
