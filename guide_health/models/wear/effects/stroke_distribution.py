"""``stroke_distribution`` (w [-]): a straightness term. Eq. 5 replaces the stroke-length coefficient j of every
stroke by its mean 1/2. The exact depth of the always-travelled zone (Eq. 6) is K/(H b) per unit load per pass
over it, whatever the stroke length: P(t) = sum_i W_i ds_i m_i / max(L_i, L_s) (L_i the length of the pass
containing segment i, L_s the slider length: a pass shorter than the slider covers the point for L_i only).
With a weight w: A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P]; w = 1 is the observed stroke
distribution, w = 0 Eq. 7. Equal for every w when each job's mean stroke is (l_min + l_max) / 2."""
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


class StrokeDistribution(Effect):
    """The straightness term: the weight w of the pass work P against Eq. 7's work G."""

    def plausible_strong_size(self, c):
        return {"stroke_distribution_weight": 1.0}, "w", 1.0

    def live_values(self, p, named):
        return {"stroke_distribution_weight": float(p["stroke_distribution_weight"]) if named else 0.0}

    def weight(self, e) -> float:
        return e.stroke_distribution_weight

    def straightness_wear_m(self, wear_coefficient, hardness_pa, contact_width_m, effective_work_nm,
                            effective_pass_work_n, stroke_sum_m, e):
        """:func:`straightness_wear_m` with the weight of ``e`` (the EffectParameters)."""
        return straightness_wear_m(wear_coefficient, hardness_pa, contact_width_m, effective_work_nm,
                                   effective_pass_work_n, stroke_sum_m, e.stroke_distribution_weight)

    def pass_weight_per_m(self, pass_length_m, slider_length_m):
        """:func:`pass_weight_per_m`."""
        return pass_weight_per_m(pass_length_m, slider_length_m)


EFFECT = StrokeDistribution(
    id="stroke_distribution",
    term=("the always-travelled zone gets K W/(H b) per pass whatever the stroke length (Eq. 6); weight w "
          "between that and Eq. 5's j = 1/2"),
    meaning="stroke distribution: the observed strokes, not Eq. 5's j = 1/2, set the wear depth",
    separating_duty="separate jobs of short and of long strokes",
    simulate=SimulateValue("stroke_distribution_weight", "-", 0.0, "[0, 1]"),
    parameters=(
        EffectParameter("stroke_distribution_weight", 0.0, "-", "[-1, 2]",
                        "stroke_distribution w: A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P], P the "
                        "work of each pass over max(pass length, slider length) (Eq. 5's j = 1/2 at w = 0); "
                        "diagnose fits it in [-1, 2]"),
    ),
    fitted_to_file=("stroke_distribution_weight",),
    covariance_rows=(CovarianceRow("stroke_distribution_weight", 9, 3),),
    fields=(("stroke_distribution_weight", 0.0, "w"),),
    recorded=("stroke_distribution_weight",),
    outside_the_sums=("stroke_distribution_weight",),
)


def pass_weight_per_m(pass_length_m: np.ndarray, slider_length_m: float) -> np.ndarray:
    """1 / max(L, L_s) [1/m]: a pass deposits W per unit (W ds) / max(L, L_s) at the always-travelled
    zone (Eq. 6's severe-wear zone), so a full pass adds K W / (H b) of depth whatever its length."""
    return 1.0 / np.maximum(np.asarray(pass_length_m, dtype=float), slider_length_m)


def straightness_wear_m(wear_coefficient: float, hardness_pa: float, contact_width_m: float,
                        effective_work_nm: np.ndarray, effective_pass_work_n: np.ndarray,
                        stroke_sum_m: float, stroke_distribution_weight: float = 0.0) -> np.ndarray:
    """A_wear = K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] [m].  # seed 000 Eq. 7/10 (w = 0)

    Without a stroke range (l_min + l_max not > 0: no completed stroke, or none of the strokes was observed)
    Eq. 7's mean stroke is undefined: NaN, as the live monitor's straightness before its first stroke."""
    g = np.asarray(effective_work_nm, dtype=float)
    p = np.asarray(effective_pass_work_n, dtype=float)
    w = stroke_distribution_weight
    if not stroke_sum_m > 0:
        return np.full(np.broadcast(g, p).shape, np.nan)
    return wear_coefficient / (hardness_pa * contact_width_m) * ((1.0 - w) * 2.0 * g / stroke_sum_m + w * p)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """w in [-1, 2]."""
    return [FitParameter("stroke_distribution_weight", "-", -1.0, 2.0, False, (0.5,))]
