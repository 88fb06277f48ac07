"""``wear_rate_change`` (t_c [s], f [-]): a duty effect. The wear coefficient changes by the factor f at an unknown
time t_c (contamination, a chipped wiper, a new lubricant batch): m = 1 before, f after. Over a cell of duration
d centred at t the share of the work after t_c is clip((t + d/2 - t_c) / d, 0, 1) (uniform work within the
cell); live, each segment at its middle."""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.wear.effects.base import (
    SLIDING_DECAY_FORM,
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    LiveRequirement,
    SimulateValue,
)


class WearRateChange(Effect):
    """A duty factor of when the work is done."""

    def plausible_strong_size(self, c):
        return ({"wear_rate_change_time_s": 0.5 * c.fit_end_s, "wear_rate_change_factor": 2.5},
                "f - 1 (t_c mid-span)", 1.5)

    def live_values(self, p, named):
        return {"wear_rate_change_factor": float(p["wear_rate_change_factor"]) if named else 1.0,
                "wear_rate_change_time_s": float(p["wear_rate_change_stamp_s"]) if named else math.inf}

    def live_duty_factor(self, e, t_s, x_m, last_relubrication_s):
        return live_factor(t_s, e.wear_rate_change_time_s, e.wear_rate_change_factor)

    def simulation_fields(self, sim, run):
        return {"wear_rate_change_time_s": sim["wear_rate_change_h"] * 3600.0}

    def truth_duty_factor(self, e, t_a_s, t_b_s, x_a_m, x_b_m):
        """m by the share of each move's time after t_c."""
        if e.wear_rate_change_factor == 1.0:
            return None
        return wear_rate_change_factor(0.5 * (t_a_s + t_b_s), t_b_s - t_a_s, e.wear_rate_change_time_s,
                                       e.wear_rate_change_factor)

    def fit_duty_factor(self, values, problem):
        """m by the share of each cell's measurement interval after t_c (uniform work within it)."""
        if "wear_rate_change_factor" not in values:
            return None
        return wear_rate_change_factor(0.5 * (problem.cell_start_s + problem.cell_end_s),
                                       problem.cell_end_s - problem.cell_start_s, values["wear_rate_change_time_s"],
                                       values["wear_rate_change_factor"])

    def file_values(self, problem, values, t0_s):
        """t_c as an absolute stamp."""
        return {"wear_rate_change_stamp_s": float(t0_s + values["wear_rate_change_time_s"])}


EFFECT = WearRateChange(
    id="wear_rate_change",
    term="m = f after t_c (share of the interval's work after t_c)",
    meaning="wear-rate change: the wear coefficient changed by a factor at a time (contamination, "
            "a damaged wiper, another lubricant)",
    separating_duty="the same duty before and after a suspected event, with the event logged",
    simulate=SimulateValue("wear_rate_change_factor", "-", 1.0, note="t_c wear_rate_change_h"),
    duty=True,
    parameters=(
        EffectParameter("wear_rate_change_factor", 1.0, "-", "(0, 100]",
                        "wear_rate_change f: K x f from wear_rate_change_stamp_s on"),
        EffectParameter("wear_rate_change_stamp_s", 0.0, "s", "[0, 1e11]",
                        "wear_rate_change t_c: when the wear rate changed, seconds since the epoch of the message "
                        "stamps"),
    ),
    fitted_to_file=("wear_rate_change_factor",),
    covariance_rows=(CovarianceRow("wear_rate_change_factor", 7, 2, rate=True),),
    requires=LiveRequirement("wear_rate_change_stamp_s", "> 0", " (when it changed)"),
    simulation=(EffectParameter("wear_rate_change_h", 10.0, "h", "[0, inf)",
                                "t_c of the wear_rate_change effect, from the start"),),
    fields=(("wear_rate_change_factor", 1.0, "f"), ("wear_rate_change_time_s", math.inf, "t_c")),
    # a step in K against a smooth trend in time, K growing with the worn volume, K decaying with the sliding
    # distance (running-in in each of its decay laws: a decaying rate that levels off reads as a step), a gauge
    # drifting in time
    consistency_alternatives=("k_trend_in_time", "k_growth_with_wear", SLIDING_DECAY_FORM, "gauge_drift_in_time"),
    recorded=("wear_rate_change_factor", "wear_rate_change_time_s"),
)


def wear_rate_change_factor(time_s: np.ndarray, duration_s: np.ndarray, change_time_s: float,
                            factor: float) -> np.ndarray:
    """m of ``wear_rate_change`` for cells of the given duration centred at ``time_s``: 1 + (f - 1) x the
    share of the cell's work after t_c [-]."""
    t = np.asarray(time_s, dtype=float)
    d = np.maximum(np.asarray(duration_s, dtype=float), 1e-9)
    after = np.clip((t + 0.5 * d - change_time_s) / d, 0.0, 1.0)
    return 1.0 + (factor - 1.0) * after


def live_factor(t_s: np.ndarray, change_time_s: float, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """(m, after) at segment mid-times t [s, the clock of t_c]: f from t_c on, 1 before; dm/df = 1 where after."""
    after = t_s >= change_time_s
    return np.where(after, factor, 1.0), after


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """t_c within the fit span, f (log-scaled)."""
    t_fit = c.fit_end_s
    return [FitParameter("wear_rate_change_time_s", "s", 0.0, t_fit, False,
                         tuple(t_fit * f for f in (0.2, 0.4, 0.6, 0.8))),
            FitParameter("wear_rate_change_factor", "-", 0.05, 20.0, True, (0.5, 2.0))]
