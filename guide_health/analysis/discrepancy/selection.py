"""Forward selection of effects: add one at a time while one earns its parameters.

An effect earns its place when both hold for the best candidate of a round:
- the Bayesian information criterion on the fit span drops by more than ``BIC_THRESHOLD``
  (BIC = n ln(RSS/n) + k ln n; a drop of 10 is "very strong" evidence on Kass & Raftery's scale);
- the forecast error on the held-out later measurements does not get worse: RMSE_new <= RMSE_old
  (1 + 1/sqrt(2 m)), m held-out points (the sampling error of an RMSE).
Of the candidates that earn their place, the one with the best fit-plus-forecast score is added
(BIC + m ln(MSE_heldout), the held-out Gaussian log-likelihood added to the criterion: a wrong mechanism
that fits the past can still forecast badly); the search stops when none earns its place.

The same machinery scores seed 000's pin-on-disc table (:func:`select_pin_on_disc_law`), where the
held-out error is leave-one-out cross-validation (the rows have no time order).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from guide_health.models.wear.effects.registry import LOAD_POWER

BIC_THRESHOLD = 10.0
TIE_MARGIN = 2.0        # BIC differences below 2 are "not worth more than a bare mention" (Kass & Raftery)
#: the pin-on-disc law's load exponent n of W^n: the registry's effect of that physics names it (the report's key)
LOAD_EXPONENT = LOAD_POWER.id


@dataclass
class SelectionResult:
    named: list[str]
    baseline: Any
    final: Any
    rounds: list[list[dict]] = field(default_factory=list)   # per round: one row per candidate tried
    fits: dict = field(default_factory=dict)                  # effect tuple -> fit
    dropped: list[dict] = field(default_factory=list)         # the backward pass: {effect, delta_bic}
    ties: list[dict] = field(default_factory=list)            # per round: {selected, tied: [effects]}


def forward_selection(fit: Callable[..., Any], candidates: list[str],
                      bic_threshold: float = BIC_THRESHOLD, max_effects: int = 3,
                      fit_all: Callable[[list], list] | None = None) -> SelectionResult:
    """``fit(effects[, warm=fit_of_the_current_model])`` returns an object with ``bic`` and
    ``heldout_rmse_um`` (NaN = no held-out data). ``fit_all([(effects, warm or None), ...])``, when given,
    returns the same fits as ``fit`` would, in order (e.g. computed in several processes)."""
    current: tuple[str, ...] = ()
    base = fit(current)
    cur_fit = base
    result = SelectionResult(named=[], baseline=base, final=base, fits={(): base})
    remaining = list(candidates)
    while remaining and len(current) < max_effects:
        rows = []
        jobs = [(current + (name,), cur_fit if current else None) for name in remaining]
        fitted = fit_all(jobs) if fit_all else [fit(e, warm=w) if w is not None else fit(e) for e, w in jobs]
        for name, f in zip(remaining, fitted):
            result.fits[current + (name,)] = f
            d_bic = f.bic - cur_fit.bic
            held_ok = (math.isnan(f.heldout_rmse_um) or math.isnan(cur_fit.heldout_rmse_um)
                       or f.heldout_rmse_um <= cur_fit.heldout_rmse_um * (1.0 + heldout_tolerance(f)))
            rows.append({"effect": name, "added_to": list(current), "fit": f, "delta_bic": d_bic,
                         "heldout_improves": bool(held_ok),
                         "earns_place": bool(d_bic < -bic_threshold and held_ok)})
        rows.sort(key=lambda r: r["fit"].bic)
        earning = sorted((r for r in rows if r["earns_place"]), key=lambda r: selection_score(r["fit"]))
        for r in rows:
            r["selected"] = bool(earning) and r is earning[0]
        result.rounds.append(rows)
        if not earning:
            break
        best = earning[0]
        tied = [r["effect"] for r in earning[1:] if r["fit"].bic - best["fit"].bic < TIE_MARGIN]
        if tied:
            result.ties.append({"round": len(result.rounds), "selected": best["effect"], "tied": tied,
                                "bic_margin": TIE_MARGIN})
        current = current + (best["effect"],)
        cur_fit = best["fit"]
        result.named.append(best["effect"])
        remaining.remove(best["effect"])
    result.final = cur_fit
    if len(current) > 1:
        backward_pass(fit, result, bic_threshold)
    return result


def backward_pass(fit: Callable[..., Any], result: SelectionResult, bic_threshold: float) -> None:
    """After the forward search: drop, one at a time, the named effect whose removal costs the least BIC
    while that cost is below the threshold (an effect added early can be made redundant by later ones)."""
    current = tuple(result.named)
    while len(current) > 1:
        trials = []
        for name in current:
            rest = tuple(e for e in current if e != name)
            f = result.fits.get(rest) or fit(rest, warm=result.final)
            result.fits[rest] = f
            trials.append((f.bic - result.final.bic, name, rest, f))
        cost, name, rest, f = min(trials, key=lambda t: t[0])
        if cost >= bic_threshold:
            break
        result.dropped.append({"effect": name, "delta_bic": cost})
        current, result.final = rest, f
        result.named.remove(name)


def selection_score(fit) -> float:
    """BIC on the fit span plus the Gaussian log-likelihood term of the held-out forecasts,
    n_h ln(MSE_h): of the effects that earn their place, the one that fits *and* forecasts best."""
    m = getattr(fit, "n_heldout", 0)
    if m == 0 or not math.isfinite(fit.heldout_rmse_um):
        return fit.bic
    return fit.bic + m * math.log(max(fit.heldout_rmse_um, 1e-12) ** 2)


def heldout_tolerance(fit) -> float:
    """Relative sampling error of an RMSE over m held-out points, 1 / sqrt(2 m): a forecast error that
    grows by less than this has not got worse."""
    m = getattr(fit, "n_heldout", 0)
    return 1.0 / math.sqrt(2.0 * m) if m > 0 else 0.0


# ---------------------------------------------------------------------------------------------
# Seed 000 pin-on-disc: does a load or speed exponent earn its place in gamma = c W v?
# ---------------------------------------------------------------------------------------------


@dataclass
class LawFit:
    effects: tuple[str, ...]
    values: dict[str, float]
    std_errors: dict[str, float]
    rss: float
    bic: float
    rmse_rel: float             # RMS relative error of the wear rate on the rows
    heldout_rmse_um: float      # leave-one-out RMS relative error (named for the selection interface)
    n: int
    k: int

    def summary(self) -> dict[str, Any]:
        return {"effects": list(self.effects),
                "parameters": {k: {"value": v, "std_error": self.std_errors[k]} for k, v in self.values.items()},
                "bic": self.bic, "rms_rel_error": self.rmse_rel, "loo_rms_rel_error": self.heldout_rmse_um}


def _fit_law(v, w, gamma, effects, rows=None) -> tuple[np.ndarray, Any]:
    """gamma = c (W/W_ref)^n (v/v_ref)^m W_ref v_ref, least squares on relative residuals
    (the rows span an order of magnitude; the seed's repeats average three tests each)."""
    rows = np.arange(gamma.size) if rows is None else rows
    w_ref, v_ref = float(np.exp(np.log(w).mean())), float(np.exp(np.log(v).mean()))
    names = ["wear_rate_per_load_speed"] + [e for e in (LOAD_EXPONENT, "speed_exponent") if e in effects]

    def model(x, vv, ww):
        c = x[0] * 1e-14
        n = x[names.index(LOAD_EXPONENT)] if LOAD_EXPONENT in names else 1.0
        m = x[names.index("speed_exponent")] if "speed_exponent" in names else 1.0
        return c * w_ref * v_ref * (ww / w_ref) ** n * (vv / v_ref) ** m

    def res(x):
        return (model(x, v[rows], w[rows]) - gamma[rows]) / gamma[rows]

    x0 = np.array([2.0] + [1.0] * (len(names) - 1))
    sol = least_squares(res, x0)
    return sol, (names, model)


def select_pin_on_disc_law(speed_m_s, load_n, wear_rate_m3_s, bic_threshold: float = BIC_THRESHOLD) -> dict:
    """Forward selection of a load and a speed exponent on pin-on-disc rows (seed 000 Table 2)."""
    v = np.asarray(speed_m_s, float)
    w = np.asarray(load_n, float)
    g = np.asarray(wear_rate_m3_s, float)
    n = g.size

    def fit(effects, warm=None):
        sol, (names, model) = _fit_law(v, w, g, effects)
        rss = float(2 * sol.cost)
        k = len(names)
        dof = max(n - k, 1)
        cov = rss / dof * np.linalg.pinv(sol.jac.T @ sol.jac)
        vals = {nm: float(x) * (1e-14 if nm == "wear_rate_per_load_speed" else 1.0) for nm, x in zip(names, sol.x)}
        ses = {nm: math.sqrt(max(cov[i, i], 0)) * (1e-14 if nm == "wear_rate_per_load_speed" else 1.0)
               for i, nm in enumerate(names)}
        loo = []
        for i in range(n):
            rows = np.delete(np.arange(n), i)
            s_i, (_, model_i) = _fit_law(v, w, g, effects, rows)
            loo.append((model_i(s_i.x, v[i], w[i]) - g[i]) / g[i])
        return LawFit(tuple(effects), vals, ses, rss, n * math.log(rss / n) + k * math.log(n),
                      float(np.sqrt(rss / n)), float(np.sqrt(np.mean(np.square(loo)))), n, k)

    sel = forward_selection(fit, [LOAD_EXPONENT, "speed_exponent"], bic_threshold)
    both = sel.fits.get((LOAD_EXPONENT, "speed_exponent")) or fit((LOAD_EXPONENT, "speed_exponent"))
    return {
        "named_effects": sel.named,
        "baseline": sel.baseline.summary(),
        "final": sel.final.summary(),
        "candidates": [{"effect": r["effect"], "delta_bic": r["delta_bic"], "earns_place": r["earns_place"],
                        **r["fit"].summary()} for r in sel.rounds[0]],
        "free_power_law": both.summary(),
        "bic_threshold": bic_threshold,
    }
