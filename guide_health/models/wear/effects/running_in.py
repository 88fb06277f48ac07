"""``running_in`` (r [-], s0 [m]): K decays from (1 + r) K to K over the sliding distance s,
K(s) = K (1 + r exp(-s / s0)). Seed 000 Fig. 9 shows it: fast straightness loss first, then the steady stage
the model describes. A new surface (regrind, new rail) runs in again."""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.effects.base import (
    RATE_STEP_FORM,
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    SimulateValue,
)
from guide_health.models.wear.form_average import running_in_form_factor_spread


class RunningInEffect(Effect):
    """K decaying over the sliding distance on the present surface."""

    def plausible_strong_size(self, c):
        return {"running_in_ratio": 3.0, "running_in_distance_m": 500.0}, "r (s0 = 500 m)", 3.0

    def live_values(self, p, named):
        return {"running_in_ratio": float(p["running_in_ratio"]) if named else 0.0,
                "running_in_distance_m": float(p["running_in_distance_m"])}

    def is_on(self, e) -> bool:
        return e.running_in_ratio > 0

    def decay(self, e) -> tuple[float, float]:
        """(r, s0 [m]) of K(s) = K (1 + r exp(-s / s0))."""
        return e.running_in_ratio, e.running_in_distance_m

    def live_factor_mean(self, e, s_start_m, s_end_m):
        """Mean K(s)/K of segments [s_start, s_end] on the present surface (:func:`running_in_factor_mean`)."""
        return running_in_factor_mean(s_start_m, s_end_m, e.running_in_ratio, e.running_in_distance_m)

    def cell_factor(self, e, form: str, mean_distance_m, distance_var_m2):
        """Mean K(s)/K of duty cells whose sliding distances on the present surface spread uniformly with the
        given mean [m] and variance [m^2], the decay law ``form`` (models/wear/form_average.py; "exponential":
        :func:`running_in_factor_spread`); None: 1 (no running-in)."""
        if e.running_in_ratio == 0.0:
            return None
        if form != "exponential":
            return running_in_form_factor_spread(form, mean_distance_m, distance_var_m2, e.running_in_ratio,
                                                 e.running_in_distance_m)
        return running_in_factor_spread(mean_distance_m, distance_var_m2, e.running_in_ratio, e.running_in_distance_m)

    def simulation_fields(self, sim, run):
        return {"running_in_distance_m": sim["running_in_distance_m"]}

    def fitted_decay(self, values: dict) -> tuple[float, float]:
        """(r, s0 [m]) of a fit's values."""
        return values["running_in_ratio"], values["running_in_distance_m"]

    def steady(self, values: dict) -> dict:
        """A fit's values with the running-in off (the steady stage's rate)."""
        return {**values, "running_in_ratio": 0.0}

    def live_decay_gradients(self, e, effective_work_nm, s_start_m, ds_m) -> dict:
        """{row name: d(effective work)/d(r), d/d(s0)} of segments (:func:`live_gradients`)."""
        d_r, d_s0 = live_gradients(effective_work_nm, s_start_m, ds_m, e.running_in_ratio, e.running_in_distance_m)
        return dict(zip(self.row_names, (d_r, d_s0)))


EFFECT = RunningInEffect(
    id="running_in",
    term="K(s) = K (1 + r e^(-s/s0)) over the sliding distance s",
    meaning="running-in: K starts high and decays over the sliding distance",
    separating_duty="a longer record (running-in decays with sliding distance and is over after 3 s0)",
    simulate=SimulateValue("running_in_ratio", "-", 0.0, note="s0 is running_in_distance_m"),
    material=True,
    parameters=(
        EffectParameter("running_in_ratio", 0.0, "-", "[0, 100]", "running_in r: K(s) = K (1 + r exp(-s / s0))"),
        EffectParameter("running_in_distance_m", 100.0, "m", "(0, 1e9]",
                        "running_in s0, sliding distance of the decay"),
    ),
    fitted_to_file=("running_in_ratio", "running_in_distance_m"),
    covariance_rows=(CovarianceRow("running_in_ratio", 1, 1), CovarianceRow("running_in_distance_m", 2, 1)),
    simulation=(EffectParameter("running_in_distance_m", 100.0, "m", "(0, inf)",
                                "s0 of the running_in effect (models/wear/effects/)"),),
    fields=(("running_in_ratio", 0.0, "r: K(s=0) = (1 + r) K"), ("running_in_distance_m", None, "s0")),
    consistency_alternatives=(RATE_STEP_FORM,),      # a decay over the first metres looks like a step in K
    consistency_separation="a record from a new or reground surface separates running-in (the rate decays over "
                           "the first sliding distance, at every reset) from a step in K at one clock time",
    recorded=("running_in_ratio", "running_in_distance_m"),
)


def running_in_factor(sliding_distance_m: np.ndarray, ratio: float, distance_m: float) -> np.ndarray:
    """K(s) / K = 1 + r exp(-s / s0) at the sliding distance s [m]."""
    if ratio == 0.0:
        return np.ones_like(np.asarray(sliding_distance_m, dtype=float))
    return 1.0 + ratio * np.exp(-np.asarray(sliding_distance_m, dtype=float) / distance_m)


def running_in_factor_mean(s_start_m: np.ndarray, s_end_m: np.ndarray, ratio: float,
                           distance_m: float) -> np.ndarray:
    """Mean of K(s)/K over [s_start, s_end] (exact integral of the exponential over a segment)."""
    s_a = np.asarray(s_start_m, dtype=float)
    s_b = np.asarray(s_end_m, dtype=float)
    if ratio == 0.0:
        return np.ones_like(s_a)
    ds = s_b - s_a
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_exp = distance_m * (np.exp(-s_a / distance_m) - np.exp(-s_b / distance_m)) / ds
    mean_exp = np.where(ds > 0, mean_exp, np.exp(-s_a / distance_m))
    return 1.0 + ratio * mean_exp


def running_in_factor_spread(mean_distance_m: np.ndarray, distance_var_m2: np.ndarray, ratio: float,
                             distance_m: float) -> np.ndarray:
    """Mean of K(s)/K over sliding distances spread uniformly with the given mean and variance:
    1 + r exp(-s_mean / s0) sinh(h) / h, h = sqrt(3 var) / s0 (half-width of the uniform over s0)."""
    if ratio == 0.0:
        return np.ones_like(np.asarray(mean_distance_m, dtype=float))
    h = np.sqrt(3.0 * np.asarray(distance_var_m2, dtype=float)) / distance_m
    wide = h > 1e-6                       # below: the series 1 + h^2/6 (sinh(h)/h loses its digits)
    shape = np.sinh(h) / h if wide.all() else np.where(wide, np.sinh(h) / np.where(wide, h, 1.0), 1.0 + h * h / 6.0)
    return 1.0 + ratio * np.exp(-np.asarray(mean_distance_m, dtype=float) / distance_m) * shape


def live_gradients(effective_work_nm: np.ndarray, s_start_m: np.ndarray, ds_m: np.ndarray, ratio: float,
                   distance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """d(effective work)/dr and d/ds0 of segments starting at s_start on the present surface [N m per unit],
    K(s)/K taken at the segment's middle (a gradient only)."""
    decay = np.exp(-(s_start_m + 0.5 * ds_m) / distance_m)
    return (effective_work_nm * decay,
            effective_work_nm * ratio * decay * (s_start_m + 0.5 * ds_m) / distance_m ** 2)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """r and s0 (s0 between a thousandth and all of the record's sliding distance, log-scaled)."""
    dist = max(c.total_distance_m, 1.0)
    return [FitParameter("running_in_ratio", "-", 0.0, 100.0, False, (1.0,)),
            FitParameter("running_in_distance_m", "m", dist * 1e-3, dist, True,
                         tuple(dist * f for f in (0.01, 0.04, 0.15)))]
