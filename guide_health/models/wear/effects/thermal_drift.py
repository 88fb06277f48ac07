"""``thermal_drift`` (c_T [m/K], dT_ref [K]): a measurement term. The straightness measurement bends with the
guide temperature: y = A + c_T (T - T_ref), T_ref = T_0 + dT_ref the temperature at which the guide is
straight to A0 (T_0 that of the first measurement). dT_ref is fitted when A0 is given (otherwise it is one
with A0). Reversible, unlike wear. The live model corrects each measurement by c_T (T - T_ref) before the K
update; its covariance rows are c_T and the gauge's offset e at T_ref (0 at the fitted values): the
correction with both moved is (c_T + dc) (T - T_ref) + de."""
from __future__ import annotations

import math

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

    def file_values(self, problem, values, t0_s):
        """The absolute T_ref = T_0 + dT_ref, dT_ref = -b / c_T (b fitted when A0 is given, else 0)."""
        c, b = values["thermal_drift_m_per_k"], values.get("thermal_offset_m", 0.0)
        return {"thermal_reference_c": float(problem.temperature_first_c - (b / c if c != 0.0 else 0.0))}

    def file_jacobian(self, problem, file_values):
        """The gauge's offset at T_ref: e = dc_T (T_ref - T_0) + db (b the fitted offset at T_0, when fitted)."""
        offset = self.row_names[1]
        return ((offset, "thermal_drift_m_per_k", file_values["thermal_reference_c"] - problem.temperature_first_c),
                (offset, "thermal_offset_m", 1.0))

    def fit_reference_offset(self, values: dict, se: dict, cov: np.ndarray, specs: list) -> None:
        """dT_ref = T_ref - T_0 = -b / c_T [K] from the fitted offset b and drift c_T into ``values``, its standard
        error by the delta method into ``se`` (``cov``: the fit's internal covariance, both um-scaled)."""
        names = [s.name for s in specs]
        i, j = names.index("thermal_drift_m_per_k"), names.index("thermal_offset_m")
        c, b = values["thermal_drift_m_per_k"], values["thermal_offset_m"]
        if c == 0.0:
            values["thermal_reference_offset_k"], se["thermal_reference_offset_k"] = math.nan, math.nan
            return
        grad = np.array([b / c ** 2, -1.0 / c]) * 1e-6          # per internal (um) unit of c_T and b
        sub = cov[np.ix_([i, j], [i, j])]
        values["thermal_reference_offset_k"] = -b / c
        se["thermal_reference_offset_k"] = math.sqrt(max(float(grad @ sub @ grad), 0.0))

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
    recorded=("thermal_drift_m_per_k",),
    outside_the_sums=("thermal_drift_m_per_k", "thermal_offset_m"),
    file_derived=("thermal_reference_c", "thermal_gauge_offset_m"),      # T_ref, the gauge's offset there
)


def gauge_term_m(temperature_change_k, drift_m_per_k: float) -> np.ndarray:
    """c_T (T - T_0) [m]: the gauge's reading beyond the straightness at the temperature changes T - T_0 [K]."""
    return drift_m_per_k * np.asarray(temperature_change_k, dtype=float)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """c_T, and the offset b at T_0 when A0 is given (with A0 fitted, b is one with A0)."""
    return [FitParameter("thermal_drift_m_per_k", "m/K", -1e-4, 1e-4, False, (0.0,))] + (
        [] if c.a0_free else [FitParameter("thermal_offset_m", "m", -1e-3, 1e-3, False, (0.0,))])
