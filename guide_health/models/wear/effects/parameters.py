"""The one effect-parameter type, offline (simulator truth, discrepancy fit) and live (wear_monitor).

Times are on the caller's clock: seconds from the record's start offline, seconds since the stamps' epoch
live (the model file's ``*_stamp_s``). ``lubrication_wear_growth`` is b [1/s] of m = 1 + b tau (recorded
relubrications, ``lubrication_interval_s`` = 0) or a [-] of m = 1 + a (tau mod T) / T (``lubrication_interval_s``
= T).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from guide_health.models.wear.effects.registry import (
    BY_ID,
    COVARIANCE_NAMES,
    PARAMETER_OWNER,
    PHI_NAMES,
    simulate_field,
)


def _default(effect: str, name: str) -> float:
    """The registry's default of an effect's wear_monitor parameter."""
    return next(p.default for p in BY_ID[effect].parameters if p.name == name)


@dataclass(frozen=True)
class EffectParameters:
    """Parameter values of every effect; the defaults are the baseline (no effect)."""

    effects: tuple[str, ...] = ()             # the named effect ids (live: the ``effects`` parameter)
    running_in_ratio: float = 0.0            # r: K(s=0) = (1 + r) K
    running_in_distance_m: float = _default("running_in", "running_in_distance_m")   # s0
    retract_wear_factor: float = 1.0         # rho
    retract_sign: int = -1                   # the retract's direction of travel (live; offline: the fit's)
    lift_speed_m_s: float = math.inf         # v_lift
    load_exponent: float = 1.0               # n
    load_reference_n: float = _default("load_exponent", "load_reference_n")          # W_ref
    load_gradient_per_m: float = 0.0         # g
    load_reference_position_m: float = 0.0   # x_ref
    wear_rate_change_factor: float = 1.0     # f
    wear_rate_change_time_s: float = math.inf  # t_c
    lubrication_wear_growth: float = 0.0     # b [1/s] or a [-]
    lubrication_interval_s: float = 0.0      # T (0: the recorded relubrications are the time base)
    lubrication_reference_stamp_s: float = 0.0     # live t_ref
    lubrication_forecast_interval_s: float = 0.0   # live, recorded form: the future relubrications' interval
    relubrication_t_s: tuple = ()            # offline: recorded relubrications [s from the start]
    thermal_drift_m_per_k: float = 0.0       # c_T
    thermal_reference_c: float = _default("thermal_drift", "thermal_reference_c")    # live T_ref
    initial_offset_m: float = 0.0            # delta
    stroke_distribution_weight: float = 0.0  # w
    slider_length_m: float = 0.0             # L_s (live pass weight)
    covariance: tuple = ()                   # live: len(COVARIANCE_NAMES)^2 numbers, row-major in that order

    @classmethod
    def from_values(cls, values: dict[str, float], **extra) -> EffectParameters:
        """From ``{effect id: value}`` (the ``simulate --effect`` values) plus field overrides."""
        fields = {simulate_field(BY_ID[name].simulate.name): float(v) for name, v in values.items()}
        fields.update(extra)
        return cls(effects=tuple(values), **fields)

    @classmethod
    def from_params(cls, p: Any) -> EffectParameters | None:
        """The live model's (a guide's frozen wear_monitor parameters, guide_health.params.typed, which hold
        ``diagnose --out``'s model file); None without effects. An effect not named keeps its no-effect value."""
        ids = tuple(e.strip() for e in str(p.effects).split(",") if e.strip())
        if not ids:
            return None
        no_effect = {f.name: f.default for f in dataclasses.fields(cls)}

        def rate(name: str, field: str = "") -> float:
            """``name``'s value when the effect owning it (registry.PARAMETER_OWNER) is named, else the field's
            no-effect value."""
            return float(getattr(p, name)) if PARAMETER_OWNER[name] in ids else no_effect[field or name]

        return cls(
            effects=ids,
            running_in_ratio=rate("running_in_ratio"),
            running_in_distance_m=float(p.running_in_distance_m),
            retract_wear_factor=rate("retract_wear_factor"),
            retract_sign=1 if p.retract_direction == "+x" else -1,
            lift_speed_m_s=rate("lift_speed_m_s") if p.lift_speed_m_s > 0 else math.inf,
            load_exponent=rate("load_exponent"),
            load_reference_n=float(p.load_reference_n),
            load_gradient_per_m=rate("load_gradient_per_m"),
            load_reference_position_m=float(p.load_reference_position_m),
            wear_rate_change_factor=rate("wear_rate_change_factor"),
            wear_rate_change_time_s=rate("wear_rate_change_stamp_s", "wear_rate_change_time_s"),
            lubrication_wear_growth=rate("lubrication_wear_growth"),
            lubrication_interval_s=float(p.lubrication_interval_s),
            lubrication_reference_stamp_s=float(p.lubrication_reference_stamp_s),
            lubrication_forecast_interval_s=float(p.lubrication_forecast_interval_s),
            thermal_drift_m_per_k=rate("thermal_drift_m_per_k"),
            thermal_reference_c=float(p.thermal_reference_c),
            stroke_distribution_weight=rate("stroke_distribution_weight"),
            slider_length_m=float(p.slider_length_m),
            covariance=tuple(float(v) for v in p.effect_covariance),
        )

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
