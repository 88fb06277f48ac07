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

from guide_health.analysis.discrepancy.analysis import disagreement
from guide_health.analysis.discrepancy.duty import DutyCells
from guide_health.analysis.discrepancy.model import FitResult, WearProblem, rel_errors
from guide_health.analysis.discrepancy.model_file import model_parameters
from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD, forward_selection

# what each effect means, for the report
EFFECT_MEANING = {
    "running_in": "running-in: K starts high and decays over the sliding distance",
    "retract_asymmetry": "feed/retract asymmetry: the retract stroke wears less per unit Archard work",
    "speed_dependent_wear": "speed-dependent wear: the lubricant film lifts the load off the asperities at speed",
    "load_exponent": "load exponent: wear grows faster (or slower) than linearly with the load",
    "stroke_distribution": "stroke distribution: the observed strokes, not Eq. 5's j = 1/2, set the wear depth",
    "thermal_drift": "thermal drift: the straightness measurement follows the guide temperature",
    "initial_offset": "initial offset: the initial straightness is not the A0 of the parameters",
}

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


def _steady_stage(problem: WearProblem, base: FitResult, final: FitResult) -> dict[str, Any]:
    """The seed's steady stage: after the running-in transient ({} when the record does not reach it)."""
    s0 = final.values["running_in_distance_m"]
    steady = sliding_distance_at_measurements(problem) >= STEADY_STAGE_DISTANCES * s0
    if not steady.any():
        return {}
    return {"steady_stage": {
        "from_h": float(problem.t_s[steady][0] / 3600.0),
        "sliding_distance_m": STEADY_STAGE_DISTANCES * s0,
        "baseline_max_rel_error": float(rel_errors(base.predicted_m[steady], problem.y_m[steady]).max()),
        "final_max_rel_error": float(rel_errors(final.predicted_m[steady], problem.y_m[steady]).max()),
    }}


def diagnose_cells(cells: DutyCells, params: dict[str, Any], heldout_fraction: float = 0.25,
                   bic_threshold: float = BIC_THRESHOLD) -> dict[str, Any]:
    """The discrepancy workflow over duty cells (see ``duty.py``); returns the JSON-ready result with the
    series for plots under ``series``."""
    t0 = time.perf_counter()
    problem = WearProblem(cells, params, heldout_fraction=heldout_fraction)
    selection = forward_selection(problem.fit, problem.available_effects(), bic_threshold=bic_threshold)
    base, final = selection.baseline, selection.final
    where = disagreement(problem, base.predicted_m)
    after = disagreement(problem, final.predicted_m)
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
    named = list(selection.named)
    final_gap = _gap(final)
    effects = {e: {"meaning": EFFECT_MEANING[e],
                   "parameters": {s.name: final_gap["parameters"][s.name] for s in problem.specs[e]}}
               for e in named}
    result: dict[str, Any] = {
        "named_effects": named,
        "effects": effects,
        "baseline": _gap(base),
        "final": final_gap,
        "gap": {
            "rmse_ratio": final.rmse_um / base.rmse_um if base.rmse_um > 0 else math.nan,
            "heldout_rmse_ratio": (final.heldout_rmse_um / base.heldout_rmse_um
                                   if base.heldout_rmse_um > 0 else math.nan),
        },
        "candidates": candidates,
        "where_baseline_disagrees": where,
        "residuals_after": {k: after[k] for k in ("residual_rms_um", "runs_test", "lag1_autocorrelation",
                                                  "systematic_in_time", "systematic_conditions")},
        "data": {
            "measurements": int(problem.y_m.size), "fit_measurements": int(problem.fit_mask.sum()),
            "heldout_measurements": int(problem.heldout_mask.sum()),
            "heldout_from_h": (float(problem.t_s[problem.heldout_mask][0] / 3600.0)
                               if problem.heldout_mask.any() else math.nan),
            "duration_h": cells.duration_s / 3600.0, "sliding_distance_m": cells.total_distance_m,
            "segments": cells.segments, "rejected_segments": cells.rejected_segments, "cells": cells.cells,
            "rejected_samples": dict(cells.rejected_samples),
            "stroke_sum_m": problem.stroke_sum_m, "feed_speed_m_s": problem.feed_speed_m_s,
            "retract_speed_m_s": problem.retract_speed_m_s,
            "retract_direction": "+x" if problem.retract_sign > 0 else "-x",
            "load_reference_n": problem.load_reference_n,
            "temperature_recorded": problem.temperature_change_k is not None,
            "straightness_initial_fitted": problem.a0_free,
        },
        "selection": {"criterion": "BIC on the fit span and held-out RMSE", "bic_threshold": bic_threshold,
                      "heldout_fraction": heldout_fraction},
    }
    if "running_in" in named:
        result.update(_steady_stage(problem, base, final))
    # the model file: the named effects refitted on every measurement (the held-out span scored the choice)
    whole = WearProblem(cells, params, heldout_fraction=0.0)
    result["model_file"] = model_parameters(whole, whole.fit(tuple(named), warm=final), named)
    result["fit_s"] = time.perf_counter() - t0
    result["series"] = {
        "t_h": problem.t_s / 3600.0, "measured_um": problem.y_m * 1e6,
        "baseline_um": base.predicted_m * 1e6, "final_um": final.predicted_m * 1e6,
        "heldout": problem.heldout_mask,
    }
    return result
