"""``retract_asymmetry`` (rho [-]): the retract (return) stroke wears rho times as much per unit Archard work as
the feed stroke (chips, cutting forces and the loaded contact act on the feed only: seed 000, end of
section 2.2)."""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    SimulateValue,
)


class RetractAsymmetry(Effect):
    """A material factor: rho on retract segments (none at rho = 1)."""

    def plausible_strong_size(self, c):
        return {"retract_wear_factor": 0.0}, "1 - rho", 1.0

    def live_values(self, p, named):
        return {"retract_wear_factor": float(p["retract_wear_factor"]) if named else 1.0,
                "retract_sign": 1 if p["retract_direction"] == "+x" else -1}

    def rate_factor(self, e, speed_m_s, load_n, retract):
        return None if e.retract_wear_factor == 1.0 else retract_factor(retract, e.retract_wear_factor)

    def record_references(self, problem):
        """The retract's direction: the faster direction of the record (the fit's)."""
        return {"retract_direction": "+x" if problem.retract_sign > 0 else "-x"}

    def live_rate_gradients(self, e, seg):
        return {self.rate_row: live_gradient(seg.effective_work_nm, seg.work_nm * seg.duty, seg.retract,
                                             e.retract_wear_factor)}


EFFECT = RetractAsymmetry(
    id="retract_asymmetry",
    term="the retract stroke wears rho x the feed per unit Archard work",
    meaning="feed/retract asymmetry: the retract stroke wears less per unit Archard work",
    separating_duty="retract strokes at another speed or load than the feed (or feed-only passes)",
    simulate=SimulateValue("retract_wear_factor", "-", 1.0),
    material=True,
    parameters=(
        EffectParameter("retract_wear_factor", 1.0, "-", "[0, 10]",
                        "retract_asymmetry rho: retract wear per unit work / feed's"),
        EffectParameter("retract_direction", "-x", "", "", "direction of the retract stroke (retract_asymmetry)",
                        choices=("-x", "+x")),
    ),
    fitted_to_file=("retract_wear_factor",),
    covariance_rows=(CovarianceRow("retract_wear_factor", 3, 1, rate=True),),
    fields=(("retract_wear_factor", 1.0, "rho"),
            ("retract_sign", -1, "the retract's direction of travel (live; offline: the fit's)")),
    recorded=("retract_wear_factor",),
)


def retract_factor(retract: np.ndarray, factor: float) -> np.ndarray:
    """rho on retract segments, 1 on feed segments [-]."""
    return np.where(np.asarray(retract, dtype=bool), factor, 1.0)


def live_gradient(effective_work_nm: np.ndarray, work_nm: np.ndarray, retract: np.ndarray, factor: float):
    """d(effective work)/d rho [N m]: the retract segments' effective work over rho (their plain work with the
    other multipliers when rho = 0)."""
    return np.where(retract, effective_work_nm / factor if factor else work_nm, 0.0)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """rho."""
    return [FitParameter("retract_wear_factor", "-", 0.0, 5.0, False, (0.5,))]
