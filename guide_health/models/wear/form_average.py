"""The running-in form's uncertainty in the remaining life: other decay shapes and BIC-weighted averaging
(pure numpy/scipy, SI).

The library's running-in is K(s) = K (1 + r e^(-s/s0)). A record of a few tens of hours cannot always tell it
from other decay laws of the same two parameters, which forecast another remaining life (the tail of the
decay differs), nor always from a step in K at one time (the registry's RATE_STEP). The other laws are power laws
K(s) / K = 1 + r (1 + s/s0)^-p (:data:`POWER_LAW_EXPONENTS`), from a fast tail to slow ones:

- ``inverse_square`` p = 2; ``hyperbolic`` p = 1 (the extra wear grows as r s0 ln(1 + s/s0), without end);
- ``inverse_two_thirds_power`` p = 2/3 and ``inverse_cube_root`` p = 1/3: the excess rate still falls, but
  the extra wear grows as s^(1-p) without bound, so a 20 h record's end is still inside the running-in.

A grid of exponents stands in for a free p (a third decay parameter the record rarely resolves): each law is
a two-parameter fit of the same size as the library's, so their BIC compare directly.

``diagnose`` refits the model it carries with the running-in in each law (in the step's place when it carries
the step in K; analysis/discrepancy/model_file.py), forecasts each fit's remaining life at the present duty and
writes into the model file, in :data:`LIFE_FORMS` order (the carried model first), the BIC weight
w_i = exp(-BIC_i / 2) / sum_j exp(-BIC_j / 2) (the posterior probability of the form under equal priors,
Schwarz's approximation), the offset delta_i = ln(life_i / life_carried) and the ratio c_i of its
delta-method ln-life sd to the carried model's. The live interval (:func:`form_averaged_interval_s`) is then
the BIC-weighted mixture of the forms' lognormal forecasts: its median the point life, its quantiles at
Phi(-z) and Phi(z) the 90 % interval. This is Bayesian model averaging (Hoeting et al. 1999, Stat. Sci. 14:
382, Eq. 1: the posterior predictive is the posterior-weighted mixture of the models' predictives), neither
the envelope of the forms nor the mixture joined with the carried model's interval: both contain the
mixture's interval, so they cover more often than they claim by construction (docs/discrepancy.md measures
both); and a form the record rules out (weight ~0) must not widen the interval, while a near tie must, by its
share. The offsets are those at the end of the diagnosed record; the forms converge as the decay dies out,
so holding them later errs wide.
"""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.lazy_scipy import brentq, ndtr

#: p of the power-law forms K(s) / K = 1 + r (1 + s/s0)^-p
POWER_LAW_EXPONENTS = {"hyperbolic": 1.0, "inverse_square": 2.0, "inverse_cube_root": 1.0 / 3.0,
                       "inverse_two_thirds_power": 2.0 / 3.0}
#: the running-in decay laws, the library's first
RUNNING_IN_FORMS = ("exponential", "hyperbolic", "inverse_square", "inverse_cube_root", "inverse_two_thirds_power")
#: the model file's per-form lists (``life_form_*``): the model the file carries, then the running-in effect in
#: each decay law (in its place when the file carries the step in K; the carried law's own slot has weight 0)
LIFE_FORMS = ("carried",) + RUNNING_IN_FORMS
#: the order of the per-form lists written before LIFE_FORMS (``running_in_form_*``: the exponential carried)
LEGACY_RUNNING_IN_FORMS = RUNNING_IN_FORMS[:3]


def running_in_form_exponent(form: str) -> float:
    """p of a power-law form K(s) / K = 1 + r (1 + s/s0)^-p (:data:`POWER_LAW_EXPONENTS`)."""
    try:
        return POWER_LAW_EXPONENTS[form]
    except KeyError:
        raise ValueError(f"unknown running-in form {form!r} "
                         f"(power-law forms: {', '.join(POWER_LAW_EXPONENTS)})") from None


def power_decay_integral(a, b, exponent: float):
    """int_a^b (1 + x)^-p dx = ((1 + b)^(1-p) - (1 + a)^(1-p)) / (1 - p) (ln((1 + b) / (1 + a)) at p = 1),
    written as (1 + a)^(1-p) expm1((1 - p) L) / (1 - p), L = ln((1 + b) / (1 + a)), so that it stays exact
    for b - a small and p near 1."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    log_ratio = np.log1p(b) - np.log1p(a)
    q = 1.0 - exponent
    if abs(q) < 1e-12:
        return log_ratio
    return np.exp(q * np.log1p(a)) * np.expm1(q * log_ratio) / q


def running_in_form_factor_spread(form: str, mean_distance_m, distance_var_m2, ratio: float,
                                  distance_m: float) -> np.ndarray:
    """Mean of K(s) / K of a power-law ``form`` (not the exponential: the running-in effect's module) over
    sliding distances spread uniformly on [m - h, m + h], h = sqrt(3 var) (clipped at s = 0), from the form's
    antiderivative r s0 int (1 + x)^-p dx (:func:`power_decay_integral`)."""
    p = running_in_form_exponent(form)
    m = np.asarray(mean_distance_m, dtype=float)
    h = np.sqrt(3.0 * np.asarray(distance_var_m2, dtype=float))
    a, b = np.maximum(m - h, 0.0) / distance_m, (m + h) / distance_m
    width = b - a
    point = (1.0 + m / distance_m) ** -p
    with np.errstate(invalid="ignore", divide="ignore"):
        integral = power_decay_integral(a, b, p)
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
    return scale * float(power_decay_integral(a, b, running_in_form_exponent(form)))


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


def life_form_lists(weights, ln_offsets, ln_sd_ratios, legacy_weights, legacy_ln_offsets):
    """(weights, ln-life offsets, ln-sd ratios) in LIFE_FORMS order: the ``life_form_*`` lists, or, when they
    are at their default (one form) and the legacy ``running_in_form_*`` lists (LEGACY_RUNNING_IN_FORMS order,
    the carried exponential first) are not, those mapped onto LIFE_FORMS (spread ratio 1)."""
    if sum(1 for w in weights if w > 0) > 1 or sum(1 for w in legacy_weights if w > 0) <= 1:
        return list(weights), list(ln_offsets), list(ln_sd_ratios)
    slot = {form: LIFE_FORMS.index(form) for form in LEGACY_RUNNING_IN_FORMS[1:]}
    w, d = [0.0] * len(LIFE_FORMS), [0.0] * len(LIFE_FORMS)
    w[0], d[0] = float(legacy_weights[0]), float(legacy_ln_offsets[0])
    for form, wi, di in zip(LEGACY_RUNNING_IN_FORMS[1:], legacy_weights[1:], legacy_ln_offsets[1:]):
        w[slot[form]], d[slot[form]] = float(wi), float(di)
    return w, d, [1.0] * len(LIFE_FORMS)


def bic_weights(bic: np.ndarray) -> np.ndarray:
    """w_i = exp(-(BIC_i - BIC_min) / 2) / sum (a non-finite BIC: weight 0)."""
    b = np.asarray(bic, dtype=float)
    ok = np.isfinite(b)
    w = np.where(ok, np.exp(-0.5 * (np.where(ok, b, 0.0) - (b[ok].min() if ok.any() else 0.0))), 0.0)
    return w / w.sum() if w.sum() > 0 else np.eye(b.size)[0]


def mixture_quantile(p: float, centres: np.ndarray, weights: np.ndarray, sd) -> float:
    """x with sum_i w_i Phi((x - mu_i) / sd_i) = p: the p-quantile of a normal mixture (``sd`` one for all
    components, or one per component)."""
    mu, w = np.asarray(centres, dtype=float), np.asarray(weights, dtype=float)
    sds = np.broadcast_to(np.asarray(sd, dtype=float), mu.shape)

    def cdf(x: float) -> float:
        return float(w @ ndtr((x - mu) / sds)) - p

    span = 10.0 * float(sds.max()) + float(np.ptp(mu))
    return float(brentq(cdf, mu.min() - span, mu.max() + span, xtol=1e-12 * max(1.0, span)))


def form_averaged_interval_s(life: tuple[float, float, float], ln_offsets, weights, z: float,
                             ln_sd_ratios=None, envelope: bool = False) -> tuple[float, float, float]:
    """(life, low, high) [s] with the forms' forecasts averaged in (module text): ln life of form i
    ~ N(ln life + delta_i, (c_i sd)^2), sd = ln(high / low) / (2 z) of the carried model's interval (its 90 %
    ends at +-z sd), c_i the form's delta-method ln-life sd over the carried model's at the diagnosed record's
    end (``ln_sd_ratios``; 1 where not given); the point is the mixture's median, the interval its quantiles
    at Phi(-z) and Phi(z) (one form: the carried life and interval exactly). Unchanged with one form of weight
    1, or without a finite interval. The lists are in LIFE_FORMS order (:func:`life_form_lists`).
    ``envelope``: the ends are instead the lowest form's low end and the highest form's high end (mid + delta_i
    -+ z c_i sd, every form of weight > 0 and the carried one): no form's weight is trusted (the record holds
    structure no form explains), so the interval claims at least 90 %, not 90 %; the point stays the mixture's
    median."""
    centre, low, high = life
    w = np.asarray(weights, dtype=float)
    d = np.asarray(ln_offsets, dtype=float)[:w.size]
    c = np.ones(w.size)
    if ln_sd_ratios is not None:
        given = np.asarray(ln_sd_ratios, dtype=float)[:w.size]
        c[:given.size] = given
    keep = w > 0
    if not (np.count_nonzero(keep) > 1 and d.size == w.size and math.isfinite(centre) and centre > 0 and low > 0
            and math.isfinite(high) and z > 0):
        return life
    sd = max(math.log(high / low) / (2.0 * z), 1e-9)
    mid = 0.5 * math.log(high * low)           # the carried model's ln-life centre (its interval's middle)
    centres, shares, sds = mid + d[keep], w[keep] / w[keep].sum(), sd * c[keep]
    # the carried point sits at the interval's ln-middle (delta method); each form's point moves with its centre
    shift = math.log(centre) - mid
    q_low, q_mid, q_high = (mixture_quantile(float(ndtr(x)), centres, shares, sds) for x in (-z, 0.0, z))
    if envelope:
        q_low = min(q_low, mid - z * sd, float(np.min(centres - z * sds)))
        q_high = max(q_high, mid + z * sd, float(np.max(centres + z * sds)))
    return math.exp(q_mid + shift), math.exp(q_low), math.exp(q_high)
