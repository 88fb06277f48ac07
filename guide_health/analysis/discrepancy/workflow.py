"""``diagnose``: baseline, where it disagrees, the candidates, the effects named, the gap before and after.

The baseline is the parameter file's model with K calibrated on the fit span (and A0 when
``straightness_initial_m`` is 0): a K that is merely off is a calibration, not a missing effect.
The later ``heldout_fraction`` of the measurements is never fitted: it scores forecasts.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from guide_health.analysis.discrepancy.analysis import disagreement, forecast_check, unexplained_structure
from guide_health.analysis.discrepancy.consistency import (
    check_named_effects,
    model_effects,
    outside_library,
    structure_form_tests,
)
from guide_health.analysis.discrepancy.duty import DutyCells
from guide_health.analysis.discrepancy.fit_pool import FitPool
from guide_health.analysis.discrepancy.model import FitResult, WearProblem, rel_errors
from guide_health.analysis.discrepancy.model_file import life_forms, model_parameters
from guide_health.analysis.discrepancy.resolution import data_resolution, rejected_wear_check
from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD, forward_selection
from guide_health.models.wear.effects.registry import BY_ID, EFFECTS, RECORD_REFERENCE_EFFECTS, SLIDING_DECAY

# what each effect means, and the duty variation that makes its signature distinct from the others' (for
# near-ties), for the report: the effect registry's words
EFFECT_MEANING = {e.id: e.meaning for e in EFFECTS}
SEPARATING_DUTY = {e.id: e.separating_duty for e in EFFECTS}

# what the JSON keeps of the residual analysis after the final fit
RESIDUALS_AFTER_KEYS = ("residual_rms_um", "runs_test", "lag1_autocorrelation", "ljung_box", "systematic_in_time",
                        "systematic_conditions", "binned_work", "systematic_binned", "heldout_forecast", "windows",
                        "structure_forms")
STEADY_STAGE_DISTANCES = 3.0     # the running-in transient is over after 3 s0 (exp(-3) = 5 %)


def _gap(fit: FitResult) -> dict[str, Any]:
    """Scores and parameters of a fit, with K up front."""
    return {**fit.summary(), "wear_coefficient": fit.values["wear_coefficient"],
            "wear_coefficient_std_error": fit.std_errors.get("wear_coefficient", math.nan)}


def sliding_distance_at_measurements(problem: WearProblem) -> np.ndarray:
    """Cumulative sliding distance [m] (loaded motion) at each measurement."""
    c = problem.cells
    n = problem.y_m.size
    per_interval = np.bincount(np.clip(c.interval, 0, n), weights=c.distance_m, minlength=n + 1)[:n]
    return np.cumsum(per_interval)


def fit_forecast(problem: WearProblem, fit: FitResult, limit_m: float, points: int = 60) -> dict[str, Any]:
    """The fitted model's forecast from the last measurement to the limit at the duty of the last quarter of
    the record (its mean straightness rate): life = (A_max - A_now) / rate, the 90 % band by the delta method
    over the fit's parameter covariance (A_now and the rate both move). {} without wear growth."""
    t, n = problem.t_s, problem.t_s.size
    j = max(0, int(0.75 * n) - 1)

    def now_and_rate(values):
        p = problem.predict_m(values)
        return p[-1], (p[-1] - p[j]) / max(t[-1] - t[j], 1e-9)

    a_now, rate = now_and_rate(fit.values)
    if not (rate > 0 and a_now < limit_m):
        return {}
    life_s = (limit_m - a_now) / rate
    cov = fit.extra.get("covariance")
    grad = np.zeros(len(cov["names"])) if cov else np.zeros(0)
    for i, name in enumerate(cov["names"] if cov else []):
        h = 1e-3 * math.sqrt(max(cov["matrix"][i, i], 0.0)) or 1e-9 * max(abs(fit.values[name]), 1e-12)
        a, r = now_and_rate({**fit.values, name: fit.values[name] + h})
        grad[i] = (math.log((limit_m - a) / r) - math.log(life_s)) / h if r > 0 and a < limit_m else 0.0
    sd = math.sqrt(max(float(grad @ cov["matrix"] @ grad), 0.0)) if cov else 0.0
    life_h = life_s / 3600.0
    low, high = life_h * math.exp(-1.645 * sd), life_h * math.exp(1.645 * sd)
    h = np.linspace(0.0, high, points)
    a_um, limit_um = a_now * 1e6, limit_m * 1e6
    return {"now_h": float(t[-1] / 3600.0), "now_ns": int(problem.cells.t0_ns + t[-1] * 1e9), "life_h": life_h,
            "life_low_h": low, "life_high_h": high, "limit_um": limit_um, "horizon_h": h.tolist(),
            **{k: np.minimum(a_um + (limit_um - a_um) * h / x, limit_um).tolist()
               for k, x in (("mid_um", life_h), ("fast_um", low), ("slow_um", high))}}


def _names(problem: WearProblem, effect: str) -> list[str]:
    """The reported parameters of an effect (with the derived ones its registry entry names)."""
    return [s.name for s in problem.specs[effect]] + list(BY_ID[effect].reported_extra)


def _tie(tie: dict) -> dict[str, Any]:
    """A near-tie of the forward search, with what would separate the effects."""
    effects = [tie["selected"], *tie["tied"]]
    return {**tie, "message": (f"the data cannot tell {' from '.join(effects)} (BIC within {tie['bic_margin']:g}); "
                               "to separate them run " + "; or ".join(SEPARATING_DUTY[e] for e in effects))}


def _steady_stage(problem: WearProblem, base: FitResult, final: FitResult) -> dict[str, Any]:
    """The seed's steady stage: after the running-in transient ({} when the record does not reach it)."""
    s0 = SLIDING_DECAY.fitted_decay(final.values)[1]
    steady = sliding_distance_at_measurements(problem) >= STEADY_STAGE_DISTANCES * s0
    if not steady.any():
        return {}
    return {"steady_stage": {
        "from_h": float(problem.t_s[steady][0] / 3600.0),
        "sliding_distance_m": STEADY_STAGE_DISTANCES * s0,
        "baseline_max_rel_error": float(rel_errors(base.predicted_m[steady], problem.y_m[steady]).max()),
        "final_max_rel_error": float(rel_errors(final.predicted_m[steady], problem.y_m[steady]).max()),
    }}


def _candidates(selection) -> list[dict[str, Any]]:
    """One row per candidate fit of every round of the forward search."""
    candidates = []
    for round_index, rows in enumerate(selection.rounds):
        for r in rows:
            f = r["fit"]
            candidates.append({
                "effect": r["effect"], "round": round_index + 1, "added_to": r["added_to"],
                "meaning": EFFECT_MEANING[r["effect"]],
                "delta_bic": r["delta_bic"], "score": -r["delta_bic"], "bic": f.bic,
                "rmse_um": f.rmse_um, "heldout_rmse_um": f.heldout_rmse_um,
                "heldout_improves": r["heldout_improves"], "earns_place": r["earns_place"],
                "selected": r["selected"],
                "parameters": f.parameter_table(),
            })
    return candidates


def _data_block(problem: WearProblem, cells: DutyCells) -> dict[str, Any]:
    """The record: measurements, the fit / held-out split, duty and what was rejected."""
    return {
        "measurements": int(problem.y_m.size), "fit_measurements": int(problem.fit_mask.sum()),
        "heldout_measurements": int(problem.heldout_mask.sum()),
        "heldout_from_h": (float(problem.t_s[problem.heldout_mask][0] / 3600.0)
                           if problem.heldout_mask.any() else math.nan),
        "duration_h": cells.duration_s / 3600.0, "sliding_distance_m": cells.total_distance_m,
        "segments": cells.segments, "rejected_segments": cells.rejected_segments, "cells": cells.cells,
        "rejected_samples": dict(cells.rejected_samples),
        "stroke_sum_m": problem.stroke_sum_m, "feed_speed_m_s": problem.feed_speed_m_s,
        "retract_speed_m_s": problem.retract_speed_m_s,
        **{k: v for e in RECORD_REFERENCE_EFFECTS for k, v in e.record_references(problem).items()},
        "temperature_recorded": problem.temperature_change_k is not None,
        "relubrications_recorded": 0 if problem.relubrication_t_s is None else int(problem.relubrication_t_s.size),
        "straightness_initial_fitted": problem.a0_free,
    }


def _select(problem: WearProblem, params: dict[str, Any], bic_threshold: float, workers: int):
    """(forward selection, data_resolution block, rejected_wear block): before naming, what the record resolves
    and whether rejected input could explain the misfit; either withholds every candidate."""
    baseline = problem.fit(())
    resolution = data_resolution(problem, baseline, problem.available_effects())
    rejected = rejected_wear_check(problem, baseline, params)
    withheld = resolution["too_little_data"] or rejected.get("explains_misfit", False)

    def fit(effects, warm=None):
        return baseline if not effects else problem.fit(effects, warm=warm)

    with FitPool(problem, workers) as pool:
        selection = forward_selection(fit, [] if withheld else problem.available_effects(),
                                      bic_threshold=bic_threshold, fit_all=pool.fit_all if pool else None)
    return selection, resolution, rejected


def diagnose_cells(cells: DutyCells, params: dict[str, Any], heldout_fraction: float = 0.25,
                   bic_threshold: float = BIC_THRESHOLD, relubrication_t_s=None, workers: int = 1) -> dict[str, Any]:
    """The discrepancy workflow over duty cells (see ``duty.py``); returns the JSON-ready result with the
    series for plots under ``series``. ``relubrication_t_s``: the recorded relubrications [s from the cells'
    t0] (maintenance events; None: the relubrication factor fits an interval). ``workers`` > 1: the candidate fits
    of a round in that many processes (fit_pool.py; the same result)."""
    t0 = time.perf_counter()
    problem = WearProblem(cells, params, heldout_fraction=heldout_fraction, relubrication_t_s=relubrication_t_s)
    selection, resolution, rejected = _select(problem, params, bic_threshold, workers)
    base, final = selection.baseline, selection.final
    where = disagreement(problem, base.predicted_m)
    after = disagreement(problem, final.predicted_m, mask=problem.fit_mask)     # the fit's own residuals
    named = list(selection.named)
    after["heldout_forecast"] = forecast_check(problem, final)
    after["structure_forms"] = structure_form_tests(problem, final, named)
    consistency = check_named_effects(problem, final, named)
    structure = unexplained_structure(after, named, outside={e: outside_library(c) for e, c in consistency.items()})
    final_gap = _gap(final)
    effects = {e: {"meaning": EFFECT_MEANING[e], **consistency[e],
                   "parameters": {name: final_gap["parameters"][name] for name in _names(problem, e)
                                  if name in final_gap["parameters"]}}
               for e in named}
    result: dict[str, Any] = {
        "unexplained_structure": structure,
        "explained": (bool(named) and not structure["present"]
                      and all(c["status"] == "finding" for c in consistency.values())),
        "data_resolution": resolution,
        **({"rejected_wear": rejected} if rejected else {}),
        **({"rejections_note": rejected["message"]} if rejected.get("explains_misfit") else {}),
        "named_effects": named,
        "consistency": consistency,
        "near_ties": [_tie(t) for t in selection.ties],
        "dropped_by_backward_pass": selection.dropped,
        "effects": effects,
        "baseline": _gap(base),
        "final": final_gap,
        "gap": {
            "rmse_ratio": final.rmse_um / base.rmse_um if base.rmse_um > 0 else math.nan,
            "heldout_rmse_ratio": (final.heldout_rmse_um / base.heldout_rmse_um
                                   if base.heldout_rmse_um > 0 else math.nan),
        },
        "candidates": _candidates(selection),
        "where_baseline_disagrees": where,
        "residuals_after": {k: after[k] for k in RESIDUALS_AFTER_KEYS},
        "data": _data_block(problem, cells),
        "selection": {"criterion": "BIC on the fit span and held-out RMSE", "bic_threshold": bic_threshold,
                      "heldout_fraction": heldout_fraction},
    }
    if SLIDING_DECAY.id in named:
        result.update(_steady_stage(problem, base, final))
    carried, left_out = model_effects(named, consistency)
    for effect in named:
        effects[effect]["in_model_file"] = effect not in left_out
        if left_out.get(effect):
            effects[effect]["in_model_file_in_its_place"] = left_out[effect]
    result["model_file_effects"] = carried
    _model_file_and_series(result, problem, params, (base, final), carried, relubrication_t_s)
    result["fit_s"] = time.perf_counter() - t0
    return result


def _model_file_and_series(result: dict, problem: WearProblem, params: dict, fits: tuple[FitResult, FitResult],
                           named: list[str], relubrication_t_s) -> None:
    """The model file (``named``: the effects it carries, consistency.model_effects; refitted on every
    measurement: the held-out span scored the choice), its forecast, and the series for the plot and
    residuals.csv."""
    base, final = fits
    whole = WearProblem(problem.cells, params, heldout_fraction=0.0, relubrication_t_s=relubrication_t_s)
    whole_fit = whole.fit(tuple(named), warm=final)
    forms = life_forms(whole, whole_fit, named, float(params["straightness_limit_m"]))
    if forms and result["unexplained_structure"]["present"]:
        forms["life_form_interval"] = "envelope"      # no form explains the record: none of their weights holds
    result["model_file"] = {**model_parameters(whole, whole_fit, named), **forms}
    result["forecast"] = fit_forecast(whole, whole_fit, float(params["straightness_limit_m"]))
    result["series"] = {
        "t_h": problem.t_s / 3600.0, "measured_um": problem.y_m * 1e6,
        "baseline_um": base.predicted_m * 1e6, "final_um": final.predicted_m * 1e6,
        "heldout": problem.heldout_mask,
    }
