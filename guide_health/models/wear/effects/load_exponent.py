"""``load_exponent`` (n [-]): wear rate proportional to W^n instead of W (seed 000 Table 2 tests this):
m = (W / W_ref)^(n - 1). W_ref only scales K; the simulator uses ``load_reference_n``, the workflow the
work-weighted geometric mean load of the run, so its fitted K stays comparable with the baseline's."""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    SimulateValue,
    size_beside_check,
    work_weighted_geomean,
)


class LoadExponent(Effect):
    """A material factor: (W / W_ref)^(n - 1)."""

    def plausible_strong_size(self, c):
        return {"load_exponent": 2.0}, "n - 1", 1.0

    def own_consistency_check(self, record):
        """Its claim: the wear rate follows the load, W^n. A gauge whose zero drifts with clock time adds wear-like
        growth that does not follow the load; where the load history trends with time (or light jobs fill more
        hours than heavy ones) n - 1 can take that growth. The check refits with a gauge drift in clock time
        freed beside it: n - 1 must stay ``SIGNIFICANT_SD`` standard errors from 0 (the jobs' loads, not the
        clock, carry it; idle periods, where the clock runs and nothing wears, separate the two as well)."""
        values, se = record.refit_beside(("gauge_drift_in_time",))
        return size_beside_check("n - 1", values["load_exponent"] - 1.0, se["load_exponent"],
                                 "a gauge drift in clock time")

    def live_values(self, p, named):
        return {"load_exponent": float(p["load_exponent"]) if named else 1.0,
                "load_reference_n": float(p["load_reference_n"])}

    def rate_factor(self, e, speed_m_s, load_n, retract):
        return load_exponent_factor(load_n, e.load_exponent, e.load_reference_n)

    def simulation_fields(self, sim, run):
        return {"load_reference_n": sim["load_reference_n"]}

    def fit_references(self, cells):
        """W_ref [N]: the record's work-weighted geometric mean load, so the fitted K stays the baseline's."""
        return {"load_reference_n": work_weighted_geomean(cells.load_n, cells.work_nm)}

    def record_references(self, problem):
        """W_ref: the record's work-weighted geometric mean load [N] (the fit's)."""
        return {"load_reference_n": float(problem.fit_references["load_reference_n"])}

    def live_rate_gradients(self, e, seg):
        return {self.rate_row: live_gradient(seg.effective_work_nm, seg.load_n, e.load_reference_n)}

    def scenario_load_exponent(self, e):
        """n when named: a scenario's load scale s_W moves the rate by s_W^n (m = (W / W_ref)^(n - 1))."""
        return e.load_exponent if self.id in e.effects else None

    def scenario_dln(self, e, scales, v_s, dln):
        """d ln(rate) / dn = ln(W / W_ref): the scaled load adds ln(s_W)."""
        if self.id in e.effects and scales.load_scale != 1.0:
            return dln + math.log(scales.load_scale)
        return dln


EFFECT = LoadExponent(
    id="load_exponent",
    term="wear rate ∝ W^n: factor (W/W_ref)^(n-1)",
    meaning="load exponent: wear grows faster (or slower) than linearly with the load",
    separating_duty="jobs at two or more loads at the same feed speed",
    simulate=SimulateValue("load_exponent", "-", 1.0),
    material=True,
    parameters=(
        EffectParameter("load_exponent", 1.0, "-", "[0, 4]",
                        "load_exponent n: wear rate proportional to (W / W_ref)^n W_ref"),
        EffectParameter("load_reference_n", 1000.0, "N", "(0, 1e9]",
                        "load_exponent W_ref (diagnose: the geometric mean load)"),
    ),
    fitted_to_file=("load_exponent",),
    covariance_rows=(CovarianceRow("load_exponent", 5, 1, rate=True),),
    simulation=(EffectParameter("load_reference_n", 1000.0, "N", "(0, inf)", "W_ref of the load_exponent effect"),),
    fields=(("load_exponent", 1.0, "n"), ("load_reference_n", None, "W_ref")),
    recorded=("load_exponent", "load_reference_n"),
)


def load_exponent_factor(load_n: np.ndarray, exponent: float, reference_load_n: float) -> np.ndarray:
    """(W / W_ref)^(n - 1): wear rate proportional to W^n [-]."""
    w = np.asarray(load_n, dtype=float)
    if exponent == 1.0:
        return np.ones_like(w)
    return (np.maximum(w, 1e-12) / reference_load_n) ** (exponent - 1.0)


def live_gradient(effective_work_nm: np.ndarray, load_n: np.ndarray, reference_load_n: float) -> np.ndarray:
    """d(effective work)/dn [N m]: m' / m = ln(W / W_ref)."""
    return effective_work_nm * np.log(np.maximum(load_n, 1e-12) / reference_load_n)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """n."""
    return [FitParameter("load_exponent", "-", 0.0, 4.0, False, (0.7, 1.5))]
