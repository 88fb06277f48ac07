"""``thermal_drift`` (c_T [m/K], dT_ref [K]): a measurement term. The straightness measurement bends with the
guide temperature: y = A + c_T (T - T_ref), T_ref = T_0 + dT_ref the temperature at which the guide is
straight to A0 (T_0 that of the first measurement). dT_ref is fitted when A0 is given (otherwise it is one
with A0). Reversible, unlike wear. The live model corrects each measurement by c_T (T - T_ref) before the K
update; its covariance rows are c_T and the gauge's offset e at T_ref (0 at the fitted values): the
correction with both moved is (c_T + dc) (T - T_ref) + de."""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    LiveRequirement,
    SimulateValue,
)


class ThermalDrift(Effect):
    """The gauge's temperature term: each straightness reading is corrected by c_T (T - T_ref)."""

    def plausible_strong_size(self, c):
        return {"thermal_drift_m_per_k": 1.5e-6}, "c_T [um/K]", 1.5

    def live_values(self, p, named):
        return {"thermal_drift_m_per_k": float(p["thermal_drift_m_per_k"]) if named else 0.0,
                "thermal_reference_c": float(p["thermal_reference_c"])}

    def is_on(self, e) -> bool:
        return e is not None and e.thermal_drift_m_per_k != 0.0

    def temperature_offset_k(self, e, temperature_c: float) -> float:
        """T - T_ref [K] of a reading [degC]."""
        return temperature_c - e.thermal_reference_c

    def correction_m(self, e, offset_k: float) -> float:
        """c_T (T - T_ref) [m]: what the gauge reads beyond the straightness."""
        return e.thermal_drift_m_per_k * offset_k

    def reading_term_m(self, e, temperature_change_k):
        """c_T (T - T_0) [m] of a simulated or fitted reading (None: no term)."""
        if e.thermal_drift_m_per_k != 0.0 and temperature_change_k is not None:
            return gauge_term_m(temperature_change_k, e.thermal_drift_m_per_k)
        return None

    def rise_gradients(self, offsets_k) -> dict:
        """{row name: d(corrected reading)/d(row)}: the correction with both rows moved is (c_T + dc) (T - T_ref)
        + de, so a reading falls by the offsets per unit dc and by 1 per unit de."""
        return dict(zip(self.row_names, (-offsets_k, -1.0)))


EFFECT = ThermalDrift(
    id="thermal_drift",
    term=("the measurement reads c_T (T - T_ref) more (needs `guide/temperature`), fitted linearly as c_T (T - "
          "T_0) + b, dT_ref = -b / c_T"),
    meaning="thermal drift: the straightness measurement follows the guide temperature",
    separating_duty="straightness measured at rest across a temperature change (a warm-up without motion)",
    simulate=SimulateValue("thermal_drift_m_per_k", "m/K", 0.0),
    parameters=(
        EffectParameter("thermal_drift_m_per_k", 0.0, "m/K", "[-1e-4, 1e-4]",
                        "thermal_drift c_T: the straightness gauge reads A + c_T (T - T_ref); each measurement is "
                        "corrected with the guide/temperature reading in force at its stamp"),
        EffectParameter("thermal_reference_c", 20.0, "degC", "[-1e6, 1e6]",
                        "thermal_drift T_ref: the guide temperature at which the gauge reads the true straightness "
                        "(diagnose's T_0 - b / c_T: far from the guide's temperatures when the drift is mostly a "
                        "constant offset)"),
    ),
    fitted_to_file=("thermal_drift_m_per_k",),
    covariance_rows=(CovarianceRow("thermal_drift_m_per_k", 10, 4), CovarianceRow("thermal_gauge_offset_m", 11, 4)),
    requires=LiveRequirement("thermal_drift_m_per_k", "!= 0"),
    needs_temperature=True,
    reported_extra=("thermal_reference_offset_k",),      # dT_ref = -b / c_T (analysis/discrepancy/model.py)
    fields=(("thermal_drift_m_per_k", 0.0, "c_T"), ("thermal_reference_c", None, "live T_ref")),
)


def gauge_term_m(temperature_change_k, drift_m_per_k: float) -> np.ndarray:
    """c_T (T - T_0) [m]: the gauge's reading beyond the straightness at the temperature changes T - T_0 [K]."""
    return drift_m_per_k * np.asarray(temperature_change_k, dtype=float)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """c_T, and the offset b at T_0 when A0 is given (with A0 fitted, b is one with A0)."""
    return [FitParameter("thermal_drift_m_per_k", "m/K", -1e-4, 1e-4, False, (0.0,))] + (
        [] if c.a0_free else [FitParameter("thermal_offset_m", "m", -1e-3, 1e-3, False, (0.0,))])
