"""Where model and measurement disagree: residual structure over time and against operating conditions.

Statistics (scipy.stats), each with the number that says whether a pattern is real, not just a large RMSE:
- Wald-Wolfowitz runs test on the signs of the residuals in time order (too few runs = systematic);
- lag-1 autocorrelation of the residuals with its large-sample z = r sqrt(n) (white noise: |z| < 2);
- time windows: maximal runs of same-sign residuals (>= 3 measurements) whose mean is significant
  against the noise (t = mean / (sigma / sqrt(m)), sigma from successive differences, von Neumann),
  reported when |t| > 3;
- operating conditions: for every measurement interval, the residual increment (measured minus model
  straightness gained over the interval) against the interval's work-weighted mean feed speed, load,
  stroke length, stroke position, retract share of the work and temperature change; Spearman rank
  correlation, 'systematic' when p < 0.01 / (number of conditions) (Bonferroni).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import stats

from guide_health.analysis.discrepancy.model import WearProblem


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
    return {"runs": runs, "expected_runs": mean, "z": z, "p_value": float(2 * stats.norm.sf(abs(z)))}


def lag1_autocorrelation(residuals: np.ndarray) -> dict[str, float]:
    r = residuals - residuals.mean()
    denom = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / denom if denom > 0 else 0.0
    z = rho * math.sqrt(r.size)
    return {"r": rho, "z": z, "p_value": float(2 * stats.norm.sf(abs(z)))}


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
        "windows": systematic_windows(t_h, res_um, sigma),
    }
    out["systematic_in_time"] = bool(out["runs_test"]["p_value"] < alpha
                                     or out["lag1_autocorrelation"]["p_value"] < alpha)
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
        rho, p = stats.spearmanr(values[ok], target[ok])
        rows.append({"condition": name, "statistic": "spearman_rho", "rho": float(rho), "p_value": float(p),
                     "against": "residual" if name == "temperature_k" else "residual_increment",
                     "range": [float(np.nanmin(values[ok])), float(np.nanmax(values[ok]))],
                     "systematic": bool(p < alpha / max(n_tests, 1))})
    rows.sort(key=lambda r: r["p_value"])
    out["conditions"] = rows
    out["systematic_conditions"] = [r["condition"] for r in rows if r["systematic"]]
    return out


def unexplained_structure(after: dict[str, Any], named: list[str]) -> dict[str, Any]:
    """The verdict on the residuals after the final fit: ``present`` when they are still systematic in time
    (runs test or lag-1 autocorrelation, p < 0.01) or follow an operating condition (Bonferroni); then
    ``where`` (time windows of one sign) and ``conditions`` (which, with rho) say where and under which
    condition, and ``message`` says it first: physics outside the effect library, the named effects (if
    any) are not an explanation."""
    present = bool(after["systematic_in_time"] or after["systematic_conditions"])
    out: dict[str, Any] = {"present": present, "where": [], "conditions": [], "message": ""}
    if not present:
        return out
    out["where"] = [{k: w[k] for k in ("start_h", "end_h", "mean_residual_um", "t_statistic")}
                    for w in after["windows"]]
    out["conditions"] = [{"condition": c["condition"], "rho": c["rho"], "p_value": c["p_value"]}
                         for c in after["conditions"] if c["systematic"]]
    rt, ac = after["runs_test"], after["lag1_autocorrelation"]
    parts = [f"runs test p = {rt['p_value']:.2g}, lag-1 autocorrelation {ac['r']:+.2f} (p = {ac['p_value']:.2g})"]
    if out["where"]:
        parts.append("in " + ", ".join(f"{w['start_h']:.1f}..{w['end_h']:.1f} h ({w['mean_residual_um']:+.2f} um)"
                                       for w in out["where"][:4]))
    if out["conditions"]:
        parts.append("following " + ", ".join(f"{c['condition']} (rho {c['rho']:+.2f})" for c in out["conditions"]))
    verdict = (f"the named effects ({', '.join(named)}) reduce the gap but do not explain it" if named
               else "no library effect explains it")
    out["message"] = ("UNEXPLAINED STRUCTURE: the residuals after the fit are not noise (" + "; ".join(parts)
                      + f"): physics outside the effect library; {verdict}")
    return out
