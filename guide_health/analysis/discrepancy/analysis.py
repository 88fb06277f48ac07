"""Where model and measurement disagree: residual structure over time and against operating conditions.

Statistics (the distributions' tails from scipy.special: diagnose does not import scipy.stats), each with
the number that says whether a pattern is real, not just a large RMSE:
- Wald-Wolfowitz runs test on the signs of the residuals in time order (too few runs = systematic);
- lag-1 autocorrelation of the residuals with its large-sample z = r sqrt(n) (white noise: |z| < 2);
- time windows: maximal runs of same-sign residuals (>= 3 measurements) whose mean is significant
  against the noise (t = mean / (sigma / sqrt(m)), sigma from successive differences, von Neumann),
  reported when |t| > 3;
- Ljung-Box Q over lags 1..3 of the residuals in time order (a slow wander that lag 1 alone misses);
- operating conditions: for every measurement interval, the residual increment (measured minus model
  straightness gained over the interval) against the interval's work-weighted mean feed speed, load,
  stroke length, stroke position, retract share of the work and temperature change; Spearman rank
  correlation, 'systematic' when p < 0.01 / (number of conditions) (Bonferroni);
- binned work (any shape, not only monotonic): the cells' work split into ``WORK_BINS`` work-weighted
  quantile bins of one condition (sliding speed, load, pass length, position on the rail; feed/retract),
  the residual regressed on the cumulative work of each bin (an F-test against a constant; white residuals
  of a complete model follow no such combination): a wear rate that depends on the condition in a way the
  model lacks leaves a residual that does, e.g. a rate varying as a sine along the rail. Bonferroni over
  the conditions, p < 0.01 / (number of binned conditions);
- the held-out forecast (:func:`forecast_check`): the bias and drift of the later measurements the fit
  never saw against the fitted model's forecast, tested under the forecast covariance (noise plus the
  parameters' uncertainty carried through the model): a wrong mechanism that absorbs the structure of the
  fit span, leaving white residuals there, drifts away from the data outside its own uncertainty.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import special

from guide_health.analysis.discrepancy.model import WearProblem


def _average_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of ``x``, ties sharing their mean rank (scipy.stats.rankdata's 'average')."""
    _, inverse, counts = np.unique(x, return_inverse=True, return_counts=True)
    upper = np.cumsum(counts)
    return ((upper - (counts - 1) / 2.0)[inverse]).astype(float)


def spearman(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Spearman's rank correlation and its two-sided p-value by the t approximation with n - 2 degrees of
    freedom (as scipy.stats.spearmanr; written with scipy.special so that ``diagnose`` does not import
    scipy.stats, 0.4 s). NaN, NaN when either input is constant."""
    rx, ry = _average_ranks(np.asarray(x, dtype=float)), _average_ranks(np.asarray(y, dtype=float))
    rx -= rx.mean()
    ry -= ry.mean()
    norm = math.sqrt(float(rx @ rx) * float(ry @ ry))
    if norm == 0.0:
        return math.nan, math.nan
    rho = max(-1.0, min(1.0, float(rx @ ry) / norm))
    dof = rx.size - 2
    if abs(rho) == 1.0:
        return rho, 0.0
    t = rho * math.sqrt(dof / ((1.0 - rho) * (1.0 + rho)))
    return rho, float(2 * special.stdtr(dof, -abs(t)))

def runs_test(residuals: np.ndarray) -> dict[str, float]:
    """Wald-Wolfowitz runs test on residual signs: z < 0 means fewer runs than chance (systematic)."""
    signs = np.sign(residuals[residuals != 0])
    n_pos, n_neg = int((signs > 0).sum()), int((signs < 0).sum())
    n = n_pos + n_neg
    if n_pos == 0 or n_neg == 0:
        return {"runs": 1, "expected_runs": math.nan, "z": -math.inf, "p_value": 0.0}
    runs = 1 + int((signs[1:] != signs[:-1]).sum())
    mean = 2.0 * n_pos * n_neg / n + 1.0
    var = 2.0 * n_pos * n_neg * (2.0 * n_pos * n_neg - n) / (n * n * (n - 1.0))
    z = (runs - mean) / math.sqrt(var) if var > 0 else 0.0
    return {"runs": runs, "expected_runs": mean, "z": z, "p_value": float(2 * special.ndtr(-abs(z)))}


def lag1_autocorrelation(residuals: np.ndarray) -> dict[str, float]:
    r = residuals - residuals.mean()
    denom = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / denom if denom > 0 else 0.0
    z = rho * math.sqrt(r.size)
    return {"r": rho, "z": z, "p_value": float(2 * special.ndtr(-abs(z)))}


def ljung_box(residuals: np.ndarray, lags: int = 3) -> dict[str, float]:
    """Ljung-Box Q = n (n + 2) sum_k r_k^2 / (n - k) over lags 1..``lags``, chi-square with ``lags`` dof."""
    r = residuals - residuals.mean()
    n = r.size
    denom = float(r @ r)
    if denom <= 0 or n <= lags + 1:
        return {"q": 0.0, "lags": lags, "p_value": 1.0}
    q = n * (n + 2) * sum((float(r[k:] @ r[:-k]) / denom) ** 2 / (n - k) for k in range(1, lags + 1))
    return {"q": q, "lags": lags, "p_value": float(special.chdtrc(lags, q))}


WORK_BINS = 4


def binned_work_tests(problem: WearProblem, residual_um: np.ndarray, mask: np.ndarray,
                      bins: int = WORK_BINS) -> list[dict[str, Any]]:
    """For each cell condition: does the residual follow the cumulative work done in some of its bins?
    F-test of the residual on the per-bin cumulative work (plus a constant) against the constant alone."""
    c = problem.cells
    n = problem.y_m.size
    y = residual_um[mask]
    conditions = {"sliding_speed_m_s": np.log(c.speed_m_s), "load_n": np.log(c.load_n),
                  "pass_length_m": c.pass_length_m, "position_m": c.position_m,
                  "retract": problem.retract.astype(float)}
    rows = []
    for name, values in conditions.items():
        if name == "retract":
            b = values.astype(int)
        else:
            order = np.argsort(values, kind="stable")
            cum = np.cumsum(c.work_nm[order])
            b = np.empty(values.size, dtype=int)
            b[order] = np.minimum((bins * cum / max(cum[-1], 1e-300)).astype(int), bins - 1)
        nb = int(b.max()) + 1 if b.size else 0
        work = np.bincount(np.clip(c.interval, 0, n) * nb + b, weights=c.work_nm, minlength=(n + 1) * nb)
        g = np.cumsum(work.reshape(n + 1, nb)[:n], axis=0)[mask]
        g = g[:, g.std(axis=0) > 0]
        if g.shape[1] == 0 or y.size < g.shape[1] + 4:
            continue
        x = np.column_stack((np.ones(y.size), (g - g.mean(axis=0)) / g.std(axis=0)))
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        rank = int(np.linalg.matrix_rank(x)) - 1
        rss1 = float(np.sum((y - x @ coef) ** 2))
        rss0 = float(np.sum((y - y.mean()) ** 2))
        dof = y.size - rank - 1
        f = ((rss0 - rss1) / max(rank, 1)) / (rss1 / dof) if rss1 > 0 and dof > 0 else 0.0
        rows.append({"condition": name, "statistic": "binned_work_f", "bins": nb, "f": f,
                     "p_value": float(special.fdtrc(max(rank, 1), dof, f)) if dof > 0 else 1.0,
                     "against": "residual"})
    return rows


def forecast_check(problem: WearProblem, fit: Any, alpha: float = 0.01) -> dict[str, Any]:
    """Do the held-out measurements drift away from the fit's forecast? The forecast error e of the m later
    measurements has, if the model is right, the covariance S = s^2 I + J C J' (s^2 the fit's residual
    variance, C its parameter covariance, J = d prediction / d parameter by finite differences). Its bias
    and drift in time are estimated by generalised least squares on [1, t] under S and tested together:
    F = b' (X' S^-1 X)^-1 b / 2 against F(2, n_fit - k) (s^2 is estimated). Only a bias or a drift counts: a
    held-out span that is merely noisier than the fit span is no structure. {} without held-out data."""
    held = problem.heldout_mask
    cov = fit.extra.get("covariance")
    m = int(held.sum())
    dof = fit.n_fit - fit.n_params
    if m < 4 or not cov or dof <= 0:
        return {}
    base = problem.predict_m(fit.values)[held]
    names, c = cov["names"], np.asarray(cov["matrix"], dtype=float)
    jac = np.zeros((m, len(names)))
    for i, name in enumerate(names):
        step = 1e-3 * math.sqrt(max(c[i, i], 0.0)) or 1e-6 * max(abs(fit.values[name]), 1e-12)
        jac[:, i] = (problem.predict_m({**fit.values, name: fit.values[name] + step})[held] - base) / step
    s2 = fit.rss_um2 * 1e-12 / dof
    e = problem.y_m[held] - base
    sigma = s2 * np.eye(m) + jac @ c @ jac.T
    t_h = problem.t_s[held] / 3600.0
    x = np.column_stack((np.ones(m), t_h - t_h.mean()))
    si_x = np.linalg.solve(sigma, x)
    a = x.T @ si_x
    coef = np.linalg.solve(a, si_x.T @ e)
    f = float(coef @ a @ coef) / 2.0
    p = float(special.fdtrc(2, dof, f))
    return {"f": f, "dof": [2, dof], "p_value": p, "bias_um": float(coef[0] * 1e6),
            "drift_um_per_h": float(coef[1] * 1e6), "rmse_um": float(np.sqrt(np.mean(e * e)) * 1e6),
            "expected_rmse_um": float(np.sqrt(np.trace(sigma) / m) * 1e6),
            "from_h": float(t_h[0]), "to_h": float(t_h[-1]), "mean_error_um": float(e.mean() * 1e6),
            "systematic": bool(p < alpha)}


def noise_sd_von_neumann(values: np.ndarray) -> float:
    """Noise sd from successive differences (insensitive to a slow trend)."""
    d = np.diff(values)
    return float(np.sqrt(np.mean(d * d) / 2.0)) if d.size else math.nan


def systematic_windows(t_h: np.ndarray, residual_um: np.ndarray, sigma_um: float, min_points: int = 3,
                       t_threshold: float = 3.0) -> list[dict[str, float]]:
    """Maximal same-sign runs of residuals with a significant mean."""
    out = []
    signs = np.sign(residual_um)
    start = 0
    for i in range(1, signs.size + 1):
        if i == signs.size or signs[i] != signs[start]:
            m = i - start
            if m >= min_points and sigma_um > 0:
                mean = float(residual_um[start:i].mean())
                t = mean / (sigma_um / math.sqrt(m))
                if abs(t) > t_threshold:
                    out.append({"start_h": float(t_h[start]), "end_h": float(t_h[i - 1]), "measurements": m,
                                "mean_residual_um": mean, "t_statistic": t})
            start = i
    return out


def interval_conditions(problem: WearProblem) -> dict[str, np.ndarray]:
    """Work-weighted operating conditions of every measurement interval (index j: from j-1 to j)."""
    c = problem.cells
    n = problem.y_m.size
    k = c.interval                      # n: after the last measurement (not counted)
    work = np.bincount(k, weights=c.work_nm, minlength=n + 1)[:n]
    feed = ~problem.retract
    feed_work = np.bincount(k, weights=c.work_nm * feed, minlength=n + 1)[:n]

    def wmean(values, mask=None):
        w = c.work_nm if mask is None else c.work_nm * mask
        tot = np.bincount(k, weights=w, minlength=n + 1)[:n]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(k, weights=w * values, minlength=n + 1)[:n] / tot

    cond = {
        "feed_speed_m_s": np.exp(wmean(np.log(c.speed_m_s), feed)),
        "feed_load_n": np.exp(wmean(np.log(c.load_n), feed)),
        "stroke_length_m": wmean(c.pass_length_m),
        "stroke_position_m": wmean(c.position_m),
        "retract_work_share": np.where(work > 0, 1.0 - feed_work / np.where(work > 0, work, 1.0), np.nan),
        "archard_work_nm": work,
    }
    if problem.temperature_change_k is not None:
        cond["temperature_change_k"] = np.concatenate(([np.nan], np.diff(problem.temperature_change_k)))
        cond["temperature_k"] = problem.temperature_change_k
    return cond


def disagreement(problem: WearProblem, predicted_m: np.ndarray, alpha: float = 0.01,
                 mask: np.ndarray | None = None) -> dict[str, Any]:
    """Residual structure of a model (usually the baseline) over the whole record, or over the measurements
    in ``mask`` (the fit span: a held-out forecast error grows by nature and is not structure of the fit)."""
    mask = np.ones(problem.y_m.size, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    res_um = ((problem.y_m - predicted_m) * 1e6)[mask]
    t_h = problem.t_s[mask] / 3600.0
    sigma = noise_sd_von_neumann(res_um)
    out: dict[str, Any] = {
        "residual_rms_um": float(np.sqrt(np.mean(res_um ** 2))),
        "noise_sd_um": sigma,
        "runs_test": runs_test(res_um),
        "lag1_autocorrelation": lag1_autocorrelation(res_um),
        "ljung_box": ljung_box(res_um),
        "windows": systematic_windows(t_h, res_um, sigma),
    }
    out["systematic_in_time"] = bool(out["runs_test"]["p_value"] < alpha
                                     or out["lag1_autocorrelation"]["p_value"] < alpha
                                     or out["ljung_box"]["p_value"] < alpha)
    increment = np.concatenate(([np.nan], np.diff(res_um)))
    cond = {k: v[mask] for k, v in interval_conditions(problem).items()}
    rows = []
    n_tests = len([k for k in cond if k != "archard_work_nm"])
    for name, values in cond.items():
        if name == "archard_work_nm":
            continue
        target = res_um if name == "temperature_k" else increment      # drift: the level; wear: the gain
        ok = np.isfinite(values) & np.isfinite(target)
        if ok.sum() < 6 or np.ptp(values[ok]) == 0:
            continue
        rho, p = spearman(values[ok], target[ok])
        rows.append({"condition": name, "statistic": "spearman_rho", "rho": float(rho), "p_value": float(p),
                     "against": "residual" if name == "temperature_k" else "residual_increment",
                     "range": [float(np.nanmin(values[ok])), float(np.nanmax(values[ok]))],
                     "systematic": bool(p < alpha / max(n_tests, 1))})
    binned = binned_work_tests(problem, (problem.y_m - predicted_m) * 1e6, mask)
    for r in binned:
        r["systematic"] = bool(r["p_value"] < alpha / max(len(binned), 1))
    rows.sort(key=lambda r: r["p_value"])
    out["conditions"] = rows
    out["condition_tests"] = n_tests          # the Spearman family's Bonferroni count
    out["binned_work"] = sorted(binned, key=lambda r: r["p_value"])
    out["systematic_conditions"] = [r["condition"] for r in rows if r["systematic"]]
    out["systematic_binned"] = [r["condition"] for r in binned if r["systematic"]]
    return out


#: the flag's false-alarm level: the smallest of its tests' p-values (each Bonferroni-adjusted within its family,
#: :func:`flag_statistic`) below this raises ``unexplained_structure``. Set from the power table of
#: bench/flag_power.py (docs/discrepancy.md): the level whose false-flag rate on clean runs stays <= 5 %
FLAG_ALPHA = 0.01


def flag_statistic(after: dict[str, Any]) -> dict[str, float]:
    """The p-values the flag compares with FLAG_ALPHA, one per test: runs test, lag-1 autocorrelation and
    Ljung-Box as they are; the Spearman correlations and the binned-work F-tests Bonferroni-adjusted over their
    conditions (min p x count); the held-out forecast's F-test; the nested F-tests of structure forms added to
    the final model (``after["structure_forms"]``, consistency.structure_form_tests), Bonferroni-adjusted over
    the forms. ``min_p``: the smallest (the flag's statistic)."""
    conditions = after.get("conditions", [])
    n_conditions = max(after.get("condition_tests", len(conditions)), 1)
    binned = after.get("binned_work", [])
    forecast = after.get("heldout_forecast") or {}
    forms = after.get("structure_forms", [])
    p = {"runs_test": after["runs_test"]["p_value"], "lag1_autocorrelation": after["lag1_autocorrelation"]["p_value"],
         "ljung_box": after.get("ljung_box", {}).get("p_value", 1.0),
         "conditions": min((min(r["p_value"] * n_conditions, 1.0) for r in conditions), default=1.0),
         "binned_work": min((min(r["p_value"] * len(binned), 1.0) for r in binned), default=1.0),
         "heldout_forecast": forecast.get("p_value", 1.0),
         "structure_forms": min((min(r["p_value"] * len(forms), 1.0) for r in forms), default=1.0)}
    p = {k: float(v) if math.isfinite(v) else 1.0 for k, v in p.items()}
    p["min_p"] = min(p.values())
    return p


def unexplained_structure(after: dict[str, Any], named: list[str], alpha: float = FLAG_ALPHA,
                          outside: dict[str, list[str]] | None = None) -> dict[str, Any]:
    """The verdict on the residuals after the final fit: ``present`` when they are still systematic in time
    (runs test, lag-1 autocorrelation or Ljung-Box), follow an operating condition (Spearman, Bonferroni), the
    work done in some bins of one (binned work, Bonferroni) or the held-out forecast drifts away
    (``after["heldout_forecast"]``, :func:`forecast_check`), each at p < ``alpha`` (:func:`flag_statistic`,
    FLAG_ALPHA); then ``where`` (time windows of one sign) and ``conditions`` (which, with rho or F) say where
    and under which condition, and ``message`` says it first: physics outside the effect library, the named
    effects (if any) are not an explanation. ``statistic``: the tests' p-values and their minimum. ``outside``
    ({named effect: why}, consistency.outside_library): named effects whose check found structure outside the
    library (a form that is no library effect fits better, or the effect's own check failed) raise the flag
    too, whatever the residual tests say: a named effect that absorbs such structure is never reported alone."""
    stat = flag_statistic(after)
    forecast = after.get("heldout_forecast") or {}
    missed = stat["heldout_forecast"] < alpha
    outside = {e: why for e, why in (outside or {}).items() if why}
    present = stat["min_p"] < alpha or bool(outside)
    out: dict[str, Any] = {"present": present, "where": [], "conditions": [], "message": "", "statistic": stat,
                           "alpha": alpha, "outside_library": outside}
    if not present:
        return out
    out["where"] = [{k: w[k] for k in ("start_h", "end_h", "mean_residual_um", "t_statistic")}
                    for w in after["windows"]]
    n_conditions, n_binned = max(after.get("condition_tests", 1), 1), max(len(after.get("binned_work", [])), 1)
    out["conditions"] = [{"condition": c["condition"], "rho": c["rho"], "p_value": c["p_value"]}
                         for c in after["conditions"] if c["p_value"] * n_conditions < alpha]
    out["conditions"] += [{"condition": c["condition"], "test": "binned_work", "f": c["f"], "bins": c["bins"],
                           "p_value": c["p_value"]} for c in after.get("binned_work", [])
                          if c["p_value"] * n_binned < alpha]
    rt, ac = after["runs_test"], after["lag1_autocorrelation"]
    lb = after.get("ljung_box", {"p_value": float("nan")})
    parts = [f"runs test p = {rt['p_value']:.2g}, lag-1 autocorrelation {ac['r']:+.2f} (p = {ac['p_value']:.2g}), "
             f"Ljung-Box p = {lb['p_value']:.2g}"]
    if out["where"]:
        parts.append("in " + ", ".join(f"{w['start_h']:.1f}..{w['end_h']:.1f} h ({w['mean_residual_um']:+.2f} um)"
                                       for w in out["where"][:4]))
    if missed:
        out["where"].append({"start_h": forecast["from_h"], "end_h": forecast["to_h"],
                             "mean_residual_um": forecast["mean_error_um"], "t_statistic": math.nan,
                             "heldout_forecast": True})
        parts.append(f"the held-out forecast {forecast['from_h']:.1f}..{forecast['to_h']:.1f} h drifts away: bias "
                     f"{forecast['bias_um']:+.2f} um, drift {forecast['drift_um_per_h']:+.3f} um/h beyond its "
                     f"uncertainty (F = {forecast['f']:.1f}, p = {forecast['p_value']:.1g})")
    if out["conditions"]:
        parts.append("following " + ", ".join(
            f"{c['condition']} (rho {c['rho']:+.2f})" if "rho" in c
            else f"the work per {c['condition']} bin (F = {c['f']:.1f}, p = {c['p_value']:.1g})"
            for c in out["conditions"]))
    forms = after.get("structure_forms", [])
    fitted = [r for r in forms if r["p_value"] * len(forms) < alpha]
    if fitted:
        parts.append("the residuals follow " + ", ".join(f"{r['meaning']} (F = {r['f']:.1f}, p = {r['p_value']:.1g})"
                                                          for r in fitted))
    if outside:
        parts.append("the named " + "; ".join(f"{e} is a reading ({', '.join(why)})" for e, why in outside.items()))
    verdict = (f"the named effects ({', '.join(named)}) reduce the gap but do not explain it" if named
               else "no library effect explains it")
    out["message"] = ("UNEXPLAINED STRUCTURE: the residuals after the fit are not noise (" + "; ".join(parts)
                      + f"): physics outside the effect library; {verdict}")
    return out
