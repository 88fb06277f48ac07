"""``load_along_rail`` (g [1/m]): a duty effect. The load varies along the rail (a misaligned rail or a non-uniform
foundation): W(x) = W (1 + g (x - x_ref)), x_ref the work-weighted mean position of the run (so K stays the
mean): m = max(1 + g (x - x_ref), 0)."""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    SimulateValue,
    size_beside_check,
)


class LoadAlongRail(Effect):
    """A duty factor of where the work is done."""

    def plausible_strong_size(self, c):
        g = min(3.0, 0.9 / max(c.position_spread_m, 1e-3))
        return {"load_gradient_per_m": g}, "g [1/m]", g

    def own_consistency_check(self, record):
        """Its claim: the wear at each position grows with the work done there, at a rate linear in x, so its
        signature grows from zero with the work (where the jobs were, not when). A gauge or form error is there
        from the first measurement and does not grow (an offset), and a gauge drifting with clock time grows
        with the clock: where the jobs' positions move along the rail over the record, either can pass for a
        gradient. The check refits with both freed beside it (the offset only when the parameters give A0;
        else A0 is fitted already): g must stay ``SIGNIFICANT_SD`` standard errors from 0."""
        values, se = record.refit_beside(("gauge_offset", "gauge_drift_in_time"))
        return size_beside_check("g [1/m]", values["load_gradient_per_m"], se["load_gradient_per_m"],
                                 "a gauge offset and a gauge drift in clock time")

    def live_values(self, p, named):
        return {"load_gradient_per_m": float(p["load_gradient_per_m"]) if named else 0.0,
                "load_reference_position_m": float(p["load_reference_position_m"])}

    def live_duty_factor(self, e, t_s, x_m, last_relubrication_s):
        return live_factor(x_m, e.load_gradient_per_m, e.load_reference_position_m)

    def simulation_fields(self, sim, run):
        return {"load_reference_position_m": run["work_weighted_position_m"]}

    def truth_duty_factor(self, e, t_a_s, t_b_s, x_a_m, x_b_m):
        """m at each move's mid-position (exact: linear in x, the work uniform in x)."""
        if e.load_gradient_per_m == 0.0:
            return None
        return load_along_rail_factor(0.5 * (x_a_m + x_b_m), e.load_gradient_per_m, e.load_reference_position_m)

    def fit_duty_factor(self, values, problem):
        """m at each cell's position, x_ref the record's work-weighted mean position."""
        if "load_gradient_per_m" not in values:
            return None
        return load_along_rail_factor(problem.cells.position_m, values["load_gradient_per_m"], problem.position_ref_m)

    def file_values(self, problem, values, t0_s):
        return {"load_reference_position_m": float(problem.position_ref_m)}


EFFECT = LoadAlongRail(
    id="load_along_rail",
    term="m = max(1 + g (x - x_ref), 0), x_ref the work-weighted mean position",
    meaning="load along the rail: the load varies along the travel (misalignment, foundation)",
    separating_duty="jobs confined to different sections of the rail",
    simulate=SimulateValue("load_gradient_per_m", "1/m", 0.0),       # x_ref: the run's work-weighted mean position
    duty=True,
    parameters=(
        EffectParameter("load_gradient_per_m", 0.0, "1/m", "[-1e3, 1e3]",
                        "load_along_rail g: load W (1 + g (x - x_ref)) along the rail (misalignment, foundation)"),
        EffectParameter("load_reference_position_m", 0.0, "m", "[-1e3, 1e3]",
                        "load_along_rail x_ref (diagnose: the work-weighted mean position, axis frame)"),
    ),
    fitted_to_file=("load_gradient_per_m",),
    covariance_rows=(CovarianceRow("load_gradient_per_m", 6, 2, rate=True),),
    fields=(("load_gradient_per_m", 0.0, "g"), ("load_reference_position_m", 0.0, "x_ref")),
    recorded=("load_gradient_per_m", "load_reference_position_m"),
)


def load_along_rail_factor(position_m: np.ndarray, gradient_per_m: float, reference_m: float) -> np.ndarray:
    """m of ``load_along_rail``: max(1 + g (x - x_ref), 0) [-]."""
    return np.maximum(1.0 + gradient_per_m * (np.asarray(position_m, dtype=float) - reference_m), 0.0)


def live_factor(x_m: np.ndarray, gradient_per_m: float, reference_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(m, dm/dg) at segment mid-positions x [m] (dm/dg = x - x_ref, 0 where m is clipped at 0)."""
    rail = 1.0 + gradient_per_m * (x_m - reference_m)
    return np.maximum(rail, 0.0), np.where(rail > 0, x_m - reference_m, 0.0)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """g within +-1 / (the largest distance of the work from x_ref)."""
    g_max = 1.0 / max(c.position_spread_m, 1e-3)
    return [FitParameter("load_gradient_per_m", "1/m", -g_max, g_max, False, (0.0,))]
