"""The running-in form's uncertainty in the remaining life: other decay shapes and BIC-weighted averaging
(pure numpy/scipy, SI).

The library's running-in is K(s) = K (1 + r e^(-s/s0)). A record of a few tens of hours cannot always tell it
from other decay laws of the same two parameters, which forecast another remaining life (the tail of the
decay differs):

- ``hyperbolic``: K(s) / K = 1 + r / (1 + s/s0) (the extra wear grows as r s0 ln(1 + s/s0), without end);
- ``inverse_square``: K(s) / K = 1 + r (1 + s/s0)^-2 (a power law between the two).

``diagnose`` fits each form with the same multi-start fit (analysis/discrepancy/model.py: WearProblem's
``running_in_form``), forecasts each one's remaining life at the present duty and writes into the model file,
per form in :data:`RUNNING_IN_FORMS` order, the BIC weight w_i = exp(-BIC_i / 2) / sum_j exp(-BIC_j / 2)
(the posterior probability of the form under equal priors, Schwarz's approximation) and the offset
delta_i = ln(life_i / life_named) of its forecast from the named form's. The live interval
(:func:`form_averaged_interval_s`) is then the BIC-weighted mixture of the forms' lognormal forecasts, each
with the named form's delta-method spread: its median the point life, its quantiles at Phi(-z) and Phi(z) the
90 % interval. This is Bayesian model averaging (Hoeting et al. 1999, Stat. Sci. 14: 382, Eq. 1: the posterior
predictive is the posterior-weighted mixture of the models' predictives), neither the envelope of the forms nor
the mixture joined with the named form's interval: both contain the mixture's interval, so they cover more
often than they claim by construction (docs/discrepancy.md measures both); and a form the record rules out
(weight ~0) must not widen the interval, while a near tie must, by its share.
The offsets are those at the end of the diagnosed record; the forms converge as the decay dies out, so
holding them later errs wide.
"""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.lazy_scipy import brentq, ndtr

#: the running-in forms the model file averages over, in the order of its per-form lists (the library's first)
RUNNING_IN_FORMS = ("exponential", "hyperbolic", "inverse_square")


def running_in_form_factor_spread(form: str, mean_distance_m, distance_var_m2, ratio: float,
                                  distance_m: float) -> np.ndarray:
    """Mean of K(s) / K of ``form`` (not the exponential: the running-in effect's module) over sliding distances spread
    uniformly on [m - h, m + h], h = sqrt(3 var) (clipped at s = 0), from the forms' antiderivatives:
    hyperbolic int r / (1 + s/s0) ds = r s0 ln(1 + s/s0); inverse square int r (1 + s/s0)^-2 ds = -r s0 / (1 + s/s0)."""
    m = np.asarray(mean_distance_m, dtype=float)
    h = np.sqrt(3.0 * np.asarray(distance_var_m2, dtype=float))
    a, b = np.maximum(m - h, 0.0) / distance_m, (m + h) / distance_m
    width = b - a
    if form == "hyperbolic":
        point, integral = 1.0 / (1.0 + m / distance_m), np.log1p(b) - np.log1p(a)
    elif form == "inverse_square":
        point, integral = (1.0 + m / distance_m) ** -2, 1.0 / (1.0 + a) - 1.0 / (1.0 + b)
    else:
        raise ValueError(f"unknown running-in form {form!r} (forms: {', '.join(RUNNING_IN_FORMS[1:])})")
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(width > 1e-9, integral / np.where(width > 1e-9, width, 1.0), point)
    return 1.0 + ratio * mean


def running_in_form_extra_s(form: str, horizon_s: float, ratio: float, distance_m: float, s_now_m: float,
                            sliding_speed_m_s: float) -> float:
    """int_0^T (K(s_now + v t) / K - 1) dt [s] of ``form``: the running-in's extra wear time per unit steady
    rate over a horizon T (exponential as effect_life.running_in_extra_m_per_rate)."""
    if ratio == 0.0 or not sliding_speed_m_s > 0:
        return 0.0
    a, b = s_now_m / distance_m, (s_now_m + sliding_speed_m_s * horizon_s) / distance_m
    scale = ratio * distance_m / sliding_speed_m_s
    if form == "exponential":
        return scale * (math.exp(-a) - math.exp(-b))
    if form == "hyperbolic":
        return scale * (math.log1p(b) - math.log1p(a))
    if form == "inverse_square":
        return scale * (1.0 / (1.0 + a) - 1.0 / (1.0 + b))
    raise ValueError(f"unknown running-in form {form!r}")


def running_in_form_life_s(form: str, margin_m: float, steady_rate_m_s: float, ratio: float, distance_m: float,
                           s_now_m: float, sliding_speed_m_s: float) -> float:
    """T with steady_rate (T + extra(T)) = margin (seed 000 Eq. 12 with the form's decay on the way); 0 when
    the margin is used up, inf without wear, NaN for non-finite inputs."""
    if not (math.isfinite(margin_m) and math.isfinite(steady_rate_m_s)):
        return math.nan
    if margin_m <= 0:
        return 0.0
    if steady_rate_m_s <= 0:
        return math.inf

    def gap(t: float) -> float:
        return steady_rate_m_s * (t + running_in_form_extra_s(form, t, ratio, distance_m, s_now_m,
                                                              sliding_speed_m_s)) - margin_m

    hi = margin_m / steady_rate_m_s          # the extra wear only shortens the life: gap(hi) >= 0
    return float(brentq(gap, 0.0, hi, xtol=1e-9 * hi)) if gap(hi) > 0 else float(hi)


def bic_weights(bic: np.ndarray) -> np.ndarray:
    """w_i = exp(-(BIC_i - BIC_min) / 2) / sum (a non-finite BIC: weight 0)."""
    b = np.asarray(bic, dtype=float)
    ok = np.isfinite(b)
    w = np.where(ok, np.exp(-0.5 * (np.where(ok, b, 0.0) - (b[ok].min() if ok.any() else 0.0))), 0.0)
    return w / w.sum() if w.sum() > 0 else np.eye(b.size)[0]


def mixture_quantile(p: float, centres: np.ndarray, weights: np.ndarray, sd: float) -> float:
    """x with sum_i w_i Phi((x - mu_i) / sd) = p: the p-quantile of a normal mixture of common sd."""
    mu, w = np.asarray(centres, dtype=float), np.asarray(weights, dtype=float)

    def cdf(x: float) -> float:
        return float(w @ ndtr((x - mu) / sd)) - p

    span = 10.0 * sd + float(np.ptp(mu))
    return float(brentq(cdf, mu.min() - span, mu.max() + span, xtol=1e-12 * max(1.0, span)))


def form_averaged_interval_s(life: tuple[float, float, float], ln_offsets, weights,
                             z: float) -> tuple[float, float, float]:
    """(life, low, high) [s] with the running-in forms' forecasts averaged in (module text): ln life of form i
    ~ N(ln life + delta_i, sd^2), sd = ln(high / low) / (2 z) of the named form's interval (its 90 % ends at
    +-z sd); the point is the mixture's median, the interval its quantiles at Phi(-z) and Phi(z) (one form:
    the named life and interval exactly). Unchanged with one form of weight 1, or without a finite interval."""
    centre, low, high = life
    w = np.asarray(weights, dtype=float)
    d = np.asarray(ln_offsets, dtype=float)
    keep = w > 0
    if not (np.count_nonzero(keep) > 1 and math.isfinite(centre) and centre > 0 and low > 0
            and math.isfinite(high) and z > 0):
        return life
    sd = max(math.log(high / low) / (2.0 * z), 1e-9)
    mid = 0.5 * math.log(high * low)           # the named form's ln-life centre (its interval's middle)
    centres, shares = mid + d[keep], w[keep] / w[keep].sum()
    # the named point sits at the interval's ln-middle (delta method); each form's point moves with its centre
    shift = math.log(centre) - mid
    q_low, q_mid, q_high = (mixture_quantile(float(ndtr(x)), centres, shares, sd) for x in (-z, 0.0, z))
    return math.exp(q_mid + shift), math.exp(q_low), math.exp(q_high)
