"""What a record can resolve, before any effect is named; and whether rejected input could explain the misfit.

**Resolution.** K's interval from the baseline fit, and for each candidate the smallest effect it could detect
at this record's noise and duty. The Fisher information of a candidate's size parameter theta at the fitted
baseline (K, and A0 when fitted, as nuisance parameters): I = |P d|^2 / (sigma^2 theta_p^2), with d the change
of the predicted measurements on the fit span when the effect is added at its plausible size theta_p (the
secant of the prediction, i.e. the Jacobian of a linear effect), P the projection off the nuisance columns
(their Jacobian: K's column and a constant) and sigma the noise from successive differences of the baseline's
residuals. The estimate's sd is 1 / sqrt(I) = theta_p sigma / |P d|, and the detectable size is
``DETECTABLE_SD`` (3) sd: an effect of that size moves the record by 3 noise units beyond what K absorbs.
theta_p is the strong end of each effect's documented range (docs/discrepancy.md, Acceptance and Scenarios).

A candidate is *separable* when it stays detectable after also freeing the signature of any one other
detectable candidate (|P_f d_e| >= 3 sigma, P_f projecting off f's signature too). The record is too little to name
anything when fewer than ``MIN_FIT_MEASUREMENTS`` measurements are fitted, when K's 95 % interval is wider than
+-``MAX_K_REL_HALF_WIDTH`` (an effect's size is relative to a K the record has not fixed), or when no candidate
is separable (the plausible effects are either below 3 sd or look alike): the workflow then names nothing and
says "too little data: ..." with these numbers.

**Rejections.** Joint or load samples rejected by the input rules carry no wear: the wear they would have
added is about their share of the wear input times the wear the baseline predicts over the fit span. When that
share exceeds REJECTED_SHARE_LEAD (analysis/rejections.py) and the wear missing is at least the misfit (the
baseline residual's RMS beyond the noise, sqrt(rms^2 - sigma^2)), the rejections could explain the misfit:
no effect is named to explain missing wear.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from guide_health.analysis.discrepancy.analysis import noise_sd_von_neumann
from guide_health.analysis.discrepancy.model import FitResult, WearProblem, fit_context
from guide_health.analysis.rejections import REJECTED_SHARE_LEAD, rejection_summary, wear_input_share
from guide_health.models.wear.effects.base import SIGNIFICANT_SD
from guide_health.models.wear.effects.registry import BY_ID

#: detectable = this many sd of the effect's size estimate (the effects' significance rule, base.SIGNIFICANT_SD)
DETECTABLE_SD = SIGNIFICANT_SD
#: the fewest fitted measurements from which an effect is named: K, A0, an effect's two parameters and the
#: BIC's penalty need about three measurements per parameter
MIN_FIT_MEASUREMENTS = 12
#: K's 95 % interval wider than this (half-width relative to K) leaves the baseline itself uncalibrated: an
#: effect's size relative to K cannot be named
MAX_K_REL_HALF_WIDTH = 0.2
#: two-sided 95 % normal quantile (K's interval)
Z95 = 1.959964


def plausible_effect(effect: str, problem: WearProblem) -> tuple[dict[str, float], str, float] | None:
    """(the effect's parameters at its plausible size, what the size is, the size) for ``effect`` on this
    record: the strong end of the documented ranges (docs/discrepancy.md), its module's. None: an effect
    without one."""
    return BY_ID[effect].plausible_strong_size(fit_context(problem))


def _project_out(columns: np.ndarray, d: np.ndarray) -> np.ndarray:
    """d minus its least-squares fit by ``columns``."""
    coef, *_ = np.linalg.lstsq(columns, d, rcond=None)
    return d - columns @ coef


def data_resolution(problem: WearProblem, base: FitResult, candidates: list[str]) -> dict[str, Any]:
    """The ``data_resolution`` block: K's interval, per candidate its sd and detectable size, and the verdict
    ``too_little_data`` with its ``message``."""
    fit = problem.fit_mask
    n_fit = int(fit.sum())
    res = (problem.y_m - base.predicted_m)[fit]
    sigma = noise_sd_von_neumann(res)
    k, k_se = base.values["wear_coefficient"], base.std_errors["wear_coefficient"]
    k_step = {**base.values, "wear_coefficient": k * 1.001}
    nuisance = [(problem.predict_m(k_step) - base.predicted_m)[fit] / (1e-3 * k)]
    if problem.a0_free:
        nuisance.append(np.ones(n_fit))
    x = np.column_stack(nuisance)
    rows, signatures = [], {}
    for effect in candidates:
        plausible = plausible_effect(effect, problem)
        if plausible is None:
            continue
        values, size_name, size = plausible
        d = (problem.predict_m({**base.values, **values}) - base.predicted_m)[fit]
        r = _project_out(x, d)
        norm = float(np.linalg.norm(r))
        sd = size * sigma / norm if norm > 0 else math.inf
        signatures[effect] = r
        rows.append({"effect": effect, "size": size_name, "plausible_size": size, "size_sd": sd,
                     "detectable_size": DETECTABLE_SD * sd, "signature_um": norm * 1e6,
                     "detectable": bool(DETECTABLE_SD * sd <= size)})
    detectable = [r for r in rows if r["detectable"]]
    for row in rows:
        e = row["effect"]
        others = [signatures[o["effect"]] for o in detectable if o["effect"] != e]
        worst = min((float(np.linalg.norm(_project_out(o[:, None], signatures[e]))) for o in others),
                    default=float(np.linalg.norm(signatures[e])))
        row["separable"] = bool(row["detectable"] and worst >= DETECTABLE_SD * sigma)
        row["signature_after_others_um"] = worst * 1e6
    separable = [r["effect"] for r in rows if r["separable"]]
    too_few = n_fit < MIN_FIT_MEASUREMENTS
    k_loose = not Z95 * k_se <= MAX_K_REL_HALF_WIDTH * k
    too_little = too_few or k_loose or not separable
    out = {"noise_sd_um": sigma * 1e6, "fit_measurements": n_fit, "min_fit_measurements": MIN_FIT_MEASUREMENTS,
           "fit_span_h": float(problem.t_s[fit][-1] - problem.t_s[0]) / 3600.0,
           "sliding_distance_m": float(problem.cells.total_distance_m),
           "wear_coefficient": k, "wear_coefficient_std_error": k_se,
           "wear_coefficient_interval_95": [k - Z95 * k_se, k + Z95 * k_se],
           "detectable_sd": DETECTABLE_SD, "candidates": rows, "separable": separable,
           "too_little_data": bool(too_little)}
    out["message"] = _message(out, too_few, k_loose) if too_little else (
        f"the record resolves {', '.join(separable)} (detectable at 3 sd within their plausible size); "
        f"K = {k:.3g} +- {Z95 * k_se:.2g} (95 %)")
    return out


def _message(block: dict, too_few: bool, k_loose: bool) -> str:
    """"too little data: <numbers>"."""
    k, k_se = block["wear_coefficient"], block["wear_coefficient_std_error"]
    parts = [f"{block['fit_measurements']} fitted measurements over {block['fit_span_h']:.1f} h "
             f"({block['sliding_distance_m']:.0f} m of sliding), noise {block['noise_sd_um']:.2f} um",
             f"K = {k:.3g} +- {Z95 * k_se:.2g} (95 %, +-{Z95 * k_se / k:.0%})"]
    if too_few:
        parts.append(f"fewer than {MIN_FIT_MEASUREMENTS} fitted measurements")
    if k_loose:
        parts.append(f"K's interval wider than +-{MAX_K_REL_HALF_WIDTH:.0%}")
    if not block["separable"]:
        parts.append("no candidate is separable")
    worst = sorted(block["candidates"], key=lambda r: -r["detectable_size"] / r["plausible_size"])
    parts.append("smallest detectable effects (3 sd) against the plausible size: " + ", ".join(
        f"{r['effect']} {r['size']} {r['detectable_size']:.3g} vs {r['plausible_size']:.3g}"
        + ("" if r["detectable"] else " (undetectable)") + ("" if r["separable"] or not r["detectable"]
                                                            else " (not separable)")
        for r in worst))
    return "too little data: " + "; ".join(parts) + "; no effect is named"


def rejected_wear_check(problem: WearProblem, base: FitResult, params: dict) -> dict[str, Any]:
    """Could the samples rejected by the input rules explain the baseline's misfit? {} without rejections."""
    cells = problem.cells
    summary = rejection_summary(dict(cells.rejected_samples), cells.inputs, params) if cells.rejected_samples \
        else {}
    if not summary:
        return {}
    fit = problem.fit_mask
    share = wear_input_share(summary)
    pred = base.predicted_m[fit]
    wear_um = float(pred[-1] - pred[0]) * 1e6
    res = (problem.y_m - base.predicted_m)[fit] * 1e6
    sigma = noise_sd_von_neumann(res)
    misfit_um = math.sqrt(max(float(np.mean(res * res)) - sigma * sigma, 0.0))
    missing_um = share * max(wear_um, 0.0)
    explains = bool(share > REJECTED_SHARE_LEAD and missing_um >= misfit_um)
    out = {"rejected_wear_share": share, "baseline_wear_um": wear_um, "missing_wear_um": missing_um,
           "misfit_um": misfit_um, "explains_misfit": explains}
    if explains:
        out["message"] = (f"rejections could explain the misfit: {share:.1%} of the joint/load samples were rejected "
                          f"and carry no wear, about {missing_um:.2f} um of the {wear_um:.1f} um the baseline "
                          f"predicts, at least the misfit beyond noise ({misfit_um:.2f} um): no effect is named to "
                          "explain missing wear; resolve the rejections first")
    return out
