"""``diagnose --since DATE``: what changed at the fit alarm, with the state before it as the baseline.

The live fit test (models/wear/fit_watch.py) dates an alarm ``model_fit_since_utc``: the measurement at which
it fired, which is up to ``WINDOW_MEASUREMENTS`` measurements after the change itself (the 99 % band count
looks back over that many). The change point c (the first measurement on the new line) is therefore searched
from ``WINDOW_MEASUREMENTS`` measurements before DATE to the end (at least ``MIN_AFTER`` measurements after
it), and for each c the record is explained by the plain model (seed 000 Eq. 11, y_j = A0 + K g_j, g_j the
straightness per unit K at measurement j, A0 fixed when the parameters give it) with, from c on,

* ``none``: nothing changed;
* an offset (the registry's INITIAL_TERM, its id the change's name): y_j + delta (a gauge or set-up offset),
  K unchanged;
* a new wear rate (the registry's RATE_STEP): K' after the anchor a = c - 1, y_j = A0 + K g_a + K' (g_j - g_a)
  (f = K' / K, reported under RATE_STEP's rate parameter);
* both.

All four are linear given c (ordinary least squares, the noise sd from the residuals); the one with the lowest
BIC = n ln(RSS / n) + p ln n wins, c counting as a parameter of the three changes (a change must lower the BIC
of none by the workflow's threshold, both the better single one's). The baseline is the model fitted on the
measurements before c (the state before the change): K, A0 and the straightness at DATE; or, with the
baseline 'params', the parameters' K (the model the monitor ran with), only the change fitted.

The model file describes the machine after the change, from the anchor measurement a on
(``model_from_stamp_s``, its stamp): ``straightness_initial_m`` the straightness at a on the new line (A0 + K
g_a + delta), ``wear_coefficient`` the K after the change (K' or K); loaded live (wear_monitor's ``~/load_model``) or
offline (``replay --model-file --model-at``) the guide is re-anchored there (models/wear/model_load.py): its
straightness is A_a + K (g - g_a), and the measurements up to a are folded into the K prior (the baseline's K sd for an
offset; the configured prior for a new K, whose only measurements are the ones after a, kept).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import yaml

from guide_health.analysis.discrepancy.model import WearProblem
from guide_health.io.outputs.files import write_text
from guide_health.models.wear.effects.registry import INITIAL_TERM, RATE_STEP
from guide_health.models.wear.fit_watch import WINDOW_MEASUREMENTS, utc_text
from guide_health.params import validate_wear_params

#: measurements after the change point at least (two to fit K' or delta and one to judge it)
MIN_AFTER = 3
#: the changes told apart: none, an offset, a new wear rate, both (named by the registry's effect ids)
OFFSET, NEW_RATE = INITIAL_TERM.id, RATE_STEP.id
CHANGES = ("none", OFFSET, NEW_RATE, f"{OFFSET}+{NEW_RATE}")
#: the fitted offset delta [m] and the reported wear-rate factor f = K'/K (the effects' own parameter names)
OFFSET_M = INITIAL_TERM.simulate.name
RATE_FACTOR = RATE_STEP.rate_row


def loss_per_k_m(problem) -> np.ndarray:
    """g_j [m per unit K] of the plain model at each measurement (WearProblem.predict_m is affine in K)."""
    one = problem.predict_m({"wear_coefficient": 1.0, "straightness_initial_m": 0.0})
    zero = problem.predict_m({"wear_coefficient": 0.0, "straightness_initial_m": 0.0})
    return one - zero


def _design(g: np.ndarray, c: int, change: str, a0_free: bool) -> tuple[np.ndarray, list[str]]:
    """Columns of y - (A0 when given) for change point c: [A0], K, [delta], [K']."""
    n = g.size
    after = np.arange(n) >= c
    cols, names = [], []
    if a0_free:
        cols.append(np.ones(n))
        names.append("straightness_initial_m")
    if NEW_RATE in change:
        g_a = g[c - 1]
        cols += [np.where(after, g_a, g), np.where(after, g - g_a, 0.0)]
        names += ["wear_coefficient", "wear_coefficient_after"]
    else:
        cols.append(g)
        names.append("wear_coefficient")
    if OFFSET in change:
        cols.append(after.astype(float))
        names.append(OFFSET_M)
    return np.column_stack(cols), names


def _fit(y: np.ndarray, x: np.ndarray, names: list[str], fixed: dict[str, float] | None = None) -> dict[str, Any]:
    """OLS: values, covariance s^2 (X'X)^-1 (s^2 = RSS / (n - p)), RSS, p; ``fixed`` {name: value}: those
    columns' terms taken off y (their value kept, their covariance rows 0)."""
    fixed = {k: v for k, v in (fixed or {}).items() if k in names}
    free = [i for i, name in enumerate(names) if name not in fixed]
    y = y - sum((x[:, names.index(k)] * v for k, v in fixed.items()), np.zeros_like(y))
    xf = x[:, free]
    beta = np.linalg.lstsq(xf, y, rcond=None)[0] if free else np.zeros(0)
    rss = float(np.sum((y - xf @ beta) ** 2))
    dof = max(y.size - len(free), 1)
    cov = np.zeros((len(names), len(names)))
    if free:
        cov[np.ix_(free, free)] = rss / dof * np.linalg.pinv(xf.T @ xf)
    values = {**dict(zip([names[i] for i in free], beta.tolist())), **fixed}
    return {"values": values, "cov": cov, "names": names, "rss": rss, "free": len(free)}


def _a0(fit: dict, a0_given: float | None) -> float:
    """A0 of a fit: the given one, or the fitted one when none was given."""
    return fit["values"]["straightness_initial_m"] if a0_given is None else a0_given


def _bic(rss: float, n: int, p: int) -> float:
    """BIC of a least-squares fit with the noise sd estimated: n ln(RSS / n) + p ln n."""
    return n * math.log(max(rss, 1e-300) / n) + p * math.log(n)


def _sd(fit: dict, name: str) -> float:
    """The standard error of a fitted value."""
    i = fit["names"].index(name)
    return math.sqrt(max(fit["cov"][i, i], 0.0))


def best_change(t_s: np.ndarray, y_m: np.ndarray, g: np.ndarray, a0_m: float | None, since_s: float,
                bic_threshold: float, k_m: float | None = None) -> dict:
    """The change point and kind (module text): the best change point of each kind by BIC; a change is named
    when it lowers the BIC of no change by ``bic_threshold`` (the workflow's rule for an effect), both when
    they lower the better single one's by as much again. ``a0_m`` None: A0 fitted; ``k_m``: K before the
    change fixed (the parameters' model), None: fitted."""
    n = y_m.size
    d = int(np.searchsorted(t_s, since_s, side="left"))
    first, last = max(2, d - WINDOW_MEASUREMENTS), n - MIN_AFTER
    if first > last:
        raise ValueError(f"--since: {n - d} measurement(s) from the date on; the change needs at least {MIN_AFTER} "
                         f"after it and 2 before it")
    a0_free = a0_m is None
    y = y_m if a0_free else y_m - a0_m
    fixed = None if k_m is None else {"wear_coefficient": k_m}
    x, names = _design(g, n, "none", a0_free)
    best = {"none": {"change": "none", "c": None, **_fit(y, x, names, fixed)}}
    best["none"]["bic"] = _bic(best["none"]["rss"], n, best["none"]["free"])
    for change in CHANGES[1:]:
        for c in range(first, last + 1):
            x, names = _design(g, c, change, a0_free)
            fit = _fit(y, x, names, fixed)
            bic = _bic(fit["rss"], n, fit["free"] + 1)           # + the change point
            if change not in best or bic < best[change]["bic"]:
                best[change] = {"change": change, "c": c, **fit, "bic": bic}
    single = min(CHANGES[1:3], key=lambda k: best[k]["bic"])
    chosen = single if best[single]["bic"] <= best["none"]["bic"] - bic_threshold else "none"
    if chosen != "none" and best[CHANGES[3]]["bic"] <= best[chosen]["bic"] - bic_threshold:
        chosen = CHANGES[3]
    return {**best[chosen], "bic_by_change": {k: v["bic"] for k, v in best.items()}}


def since_result(problem, since_s: float, t0_ns: int, bic_threshold: float,
                 k_m: float | None = None) -> dict[str, Any]:
    """The --since analysis of a WearProblem (its measurements and g_j): the baseline, the change named, and
    the model file's parameters after it (module text). ``since_s``: DATE [s from the cells' t0]; ``k_m``:
    the baseline's K fixed (the parameters' model), None: fitted on the measurements before the change."""
    t, y, g = problem.t_s, problem.y_m, loss_per_k_m(problem)
    a0_given = None if problem.a0_free else problem.a0_m
    best = best_change(t, y, g, a0_given, since_s, bic_threshold, k_m)
    c = best["c"] if best["c"] is not None else int(np.searchsorted(t, since_s, side="left"))
    before = slice(0, max(c, 2))
    x, names = _design(g[before], g[before].size, "none", a0_given is None)
    base = _fit(y[before] if a0_given is None else y[before] - a0_given, x, names,
                None if k_m is None else {"wear_coefficient": k_m})
    a0 = _a0(base, a0_given)
    k, k_sd = base["values"]["wear_coefficient"], _sd(base, "wear_coefficient")
    g_since = float(np.interp(since_s, t, g))
    result: dict[str, Any] = {
        "since_utc": utc_text(int(t0_ns + since_s * 1e9)),
        "baseline": {"measurements": int(g[before].size), "wear_coefficient": k, "wear_coefficient_sd": k_sd,
                     "straightness_initial_um": a0 * 1e6, "straightness_at_since_um": (a0 + k * g_since) * 1e6},
        "change": _named_change(best, t, t0_ns),
        "bic_by_change": best["bic_by_change"], "bic_threshold": bic_threshold,
    }
    result["model_file"] = _model_after(best, g, t, t0_ns, a0_given, base)
    return result


def _named_change(best: dict, t: np.ndarray, t0_ns: int) -> dict[str, Any]:
    """The change the record names: kind, registry effect ids, when, and its size with its sd."""
    change, c = best["change"], best["c"]
    if change == "none":
        return {"kind": "none", "named_effects": [], "message": "no change after the baseline explains the "
                "measurements better than the baseline itself"}
    v = best["values"]
    out: dict[str, Any] = {"kind": change, "named_effects": change.split("+"), "measurement_index": c,
                           "after_h": float(t[c - 1] / 3600.0), "before_h": float(t[c] / 3600.0),
                           "anchor_utc": utc_text(int(t0_ns + t[c - 1] * 1e9))}
    words = []
    if NEW_RATE in change:
        k, k2 = v["wear_coefficient"], v["wear_coefficient_after"]
        i, j = best["names"].index("wear_coefficient"), best["names"].index("wear_coefficient_after")
        cov = best["cov"]
        # f = K'/K, var by the delta method: (1/K)^2 var K' + (K'/K^2)^2 var K - 2 K'/K^3 cov
        var_f = cov[j, j] / k ** 2 + (k2 / k ** 2) ** 2 * cov[i, i] - 2 * k2 / k ** 3 * cov[i, j]
        out.update(wear_coefficient_before=k, wear_coefficient_after=k2,
                   wear_coefficient_after_sd=math.sqrt(max(cov[j, j], 0.0)), **{
                       RATE_FACTOR: k2 / k, f"{RATE_FACTOR}_sd": math.sqrt(max(var_f, 0.0))})
        words.append(f"the wear rate changed: K x{k2 / k:.2f} ± {math.sqrt(max(var_f, 0.0)):.2f} "
                     f"(K' = {k2:.3g} ± {math.sqrt(max(cov[j, j], 0.0)):.2g})")
    if OFFSET in change:
        out.update(offset_um=v[OFFSET_M] * 1e6, offset_sd_um=_sd(best, OFFSET_M) * 1e6)
        words.append(f"the measurements read {v[OFFSET_M] * 1e6:+.2f} ± "
                     f"{_sd(best, OFFSET_M) * 1e6:.2f} um more (an offset: gauge or set-up)")
    out["message"] = (" and ".join(words) + f" between {out['after_h']:.2f} h and {out['before_h']:.2f} h "
                      f"(after the measurement of {out['anchor_utc']})")
    return out


def _model_after(best: dict, g: np.ndarray, t: np.ndarray, t0_ns: int, a0_given: float | None,
                 base: dict) -> dict[str, Any]:
    """The wear_monitor parameters of the machine after the change, from the anchor on (module text)."""
    v = best["values"]
    a0 = _a0(best, a0_given)
    c = best["c"] if best["c"] is not None else g.size
    a = c - 1
    k = v["wear_coefficient"]
    model: dict[str, Any] = {
        "wear_coefficient": float(v.get("wear_coefficient_after", k)),
        "straightness_initial_m": float(max(a0 + k * g[a] + v.get(OFFSET_M, 0.0), 0.0)),
        "effects": "",
        "model_from_stamp_s": float(t0_ns * 1e-9 + t[a]),
    }
    if NEW_RATE not in best["change"]:
        # K is the baseline's: the measurements before the anchor are folded into its prior
        k_base, sd = base["values"]["wear_coefficient"], _sd(base, "wear_coefficient")
        if k_base > 0 and sd > 0:
            model["wear_coefficient"] = float(k_base)
            model["wear_coefficient_prior_rel_sd"] = float(sd / k_base)
    return model


def diagnose_since(cells, params: dict[str, Any], since_ns: int, bic_threshold: float,
                   baseline: str = "fit") -> dict[str, Any]:
    """The --since analysis of a record's duty cells (``params``: the base wear_monitor parameters, no
    effects; ``baseline`` 'fit': K before the change fitted on the measurements before it, 'params': the
    parameters' K and A0, e.g. of the model file the monitor ran with). ValueError (one line) for a record or
    date it cannot analyse."""
    if params["effects"]:
        raise ValueError(f"--since compares with the plain model; the parameters name effects ({params['effects']})")
    problem = WearProblem(cells, params, heldout_fraction=0.0)
    since_s = (since_ns - cells.t0_ns) * 1e-9
    if not problem.t_s[0] < since_s < problem.t_s[-1]:
        raise ValueError(f"--since {utc_text(since_ns)} is outside the record's measurements "
                         f"({utc_text(int(cells.t0_ns + problem.t_s[0] * 1e9))} .. "
                         f"{utc_text(int(cells.t0_ns + problem.t_s[-1] * 1e9))})")
    k_m = float(params["wear_coefficient"]) if baseline == "params" else None
    result = since_result(problem, since_s, cells.t0_ns, bic_threshold, k_m)
    result["baseline"]["source"] = baseline
    result["measurements"] = int(problem.y_m.size)
    return result


def write_since_model_file(path, base_params: dict[str, Any], result: dict[str, Any], source: str = "") -> None:
    """DIR/model.yaml of --since: the machine after the change, from model_from_stamp_s on (validated merged
    with the base first)."""
    model = result["model_file"]
    validate_wear_params({**base_params, **model})
    header = [f"# guide-health diagnose --since {result['since_utc']} {source}: the machine after the change "
              f"({result['change']['kind']}), from model_from_stamp_s on.",
              f"# {result['change']['message']}",
              "# Load it over the running model: wear_monitor's ~/load_model service (parameter model_file), or",
              "# offline: guide-health replay BAG --params BASE --model-file model.yaml --model-at DATE."]
    body = yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": model}}, sort_keys=False, width=200)
    write_text(path, "\n".join(header) + "\n" + body)


def since_text_lines(result: dict[str, Any]) -> list[str]:
    """The text report of --since."""
    b, ch = result["baseline"], result["change"]
    return [f"since {result['since_utc']}: {ch['message']}",
            f"  baseline ({b['measurements']} measurements before the change): K = {b['wear_coefficient']:.4g} ± "
            f"{b['wear_coefficient_sd']:.2g}, A0 = {b['straightness_initial_um']:.2f} um, straightness at the "
            f"date {b['straightness_at_since_um']:.2f} um",
            f"  named: {', '.join(ch['named_effects']) or 'none'} (BIC by change: "
            + ", ".join(f"{k} {v:.1f}" for k, v in result["bic_by_change"].items()) + ")"]
