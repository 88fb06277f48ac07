"""`diagnose` of a slewing bag: which missing wear effect explains the measured tilting clearances?

The record goes through the live node's core (:func:`~guide_health.analysis.slewing_replay.analyse_slewing_run`:
the same input rules, reversal deadband and load in force), with the raceway wear model watched: every
increment of new ground d phi the wear model takes (with the load in force and the stroke it belongs to) and
every accepted clearance reading (with the travel before it). The baseline is the monitor's model,
c = c_0 + k g, g = sum d phi r(F_a, M_T) (models/slewing/raceway_wear.py); k is fitted to the readings.

Candidates (each one parameter, its no-effect value in brackets):
* ``clearance_offset`` delta [m] (0): the bearing started from another clearance than ``tilting_clearance_initial_m``
  (a different acceptance value, a gauge set up otherwise);
* ``wear_load_exponent`` n (1): a roller pass wears as Q^n rather than Q (the raceway's wear law depends on the
  contact pressure), Q_ref the work-weighted geometric mean roller load of the record;
* ``small_oscillation_wear`` a (1): travel in strokes of amplitude below theta_crit (adjacent rollers' tracks do not
  overlap, models/slewing/fatigue.py) wears a times as much per radian (fretting-like wear of small oscillations).

Selection: the guides' forward selection (analysis/discrepancy/selection.py: an effect must lower the BIC by more
than ``bic_threshold``), and a named effect's parameter must also lie ``SIGNIFICANT_SD`` standard errors from its
no-effect value; one that earns the BIC but not the 3 sd is reported as not separable (its column is nearly a
multiple of the baseline's: e.g. a small-oscillation share that never changes). After the selection the
residuals are tested against the reading noise ``tilting_clearance_noise_m``: chi^2 above its 99 % point says
structure remains unexplained. Every reading is in the fit (a handful of tilting tests leaves none to hold out).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.special import gammaincinv

from guide_health.analysis.discrepancy.analysis import FLAG_ALPHA  # the false-flag level, also of the chi^2 test here
from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD, forward_selection
from guide_health.analysis.slewing_replay import analyse_slewing_run
from guide_health.models.slewing.fatigue import critical_amplitude_rad
from guide_health.models.slewing.monitor import SlewingMonitor
from guide_health.models.slewing.raceway_wear import (
    axial_roller_loads_n,
    clearance_rate_per_k_load_power,
    sliding_weight_table,
)
from guide_health.models.wear.effects.base import SIGNIFICANT_SD
from guide_health.params.typed import slewing_monitor_params

#: the candidates: (parameter, unit, no-effect value, meaning)
SLEWING_EFFECTS: dict[str, tuple[str, str, float, str]] = {
    "clearance_offset": ("delta_m", "m", 0.0, "the bearing started from another tilting clearance"),
    "wear_load_exponent": ("n", "-", 1.0, "a roller pass wears as Q^n: the wear law depends on the load"),
    "small_oscillation_wear": ("a", "-", 1.0, "strokes below the critical angle wear a times as much per radian"),
}
EXPONENT_BOUNDS = (0.2, 5.0)        # the load exponent's search range
MIN_READINGS = 4                    # fewer readings: nothing is diagnosed (k and one effect need >= 4)
SEPARABLE_CONDITION = 1e8           # condition number of the scaled normal equations beyond which columns merge


class _WatchedWear:
    """The monitor's raceway wear model, with every travel increment and clearance reading recorded."""

    def __init__(self, wear, fatigue) -> None:
        self._wear, self._fatigue = wear, fatigue
        self.loads = (0.0, 0.0)
        self.travel: list[tuple[float, float, float, int]] = []     # (d phi, F_a, M_T, stroke number)
        self.readings: list[tuple[int, float, int]] = []            # (stamp [ns], clearance [m], travel count)

    def on_loads(self, axial_load_n: float, tilting_moment_nm: float) -> None:
        self.loads = (float(axial_load_n), float(tilting_moment_nm))
        self._wear.on_loads(axial_load_n, tilting_moment_nm)

    def on_travel(self, travel_rad: float) -> None:
        if travel_rad != 0.0:
            self.travel.append((abs(float(travel_rad)), *self.loads, self._fatigue.strokes))
        self._wear.on_travel(travel_rad)

    def on_measurement(self, t_ns: int, clearance_m: float) -> str | None:
        reason = self._wear.on_measurement(t_ns, clearance_m)
        if reason is None:
            self.readings.append((int(t_ns), float(clearance_m), len(self.travel)))
        return reason

    def __getattr__(self, name: str) -> Any:
        return getattr(self._wear, name)


@dataclass
class SlewingRecord:
    """What the fit needs of a record: per travel increment d phi [rad], the load sample it ran under (index
    into the unique loads) and whether its stroke's amplitude is below theta_crit; per reading its stamp, value
    [m] and the increments before it."""

    dphi_rad: np.ndarray
    load_index: np.ndarray
    small: np.ndarray
    roller_loads_n: np.ndarray            # one row of Z roller loads per unique (F_a, M_T)
    reading_t_ns: np.ndarray
    reading_m: np.ndarray
    reading_travel: np.ndarray
    critical_rad: float
    reference_load_n: float = field(init=False)

    def __post_init__(self) -> None:
        # Q_ref: geometric mean roller load weighted by each roller's baseline wear (Q d phi)
        per_load = np.bincount(self.load_index, weights=self.dphi_rad, minlength=self.roller_loads_n.shape[0])
        weights = self.roller_loads_n * per_load[:, None]
        loaded = (self.roller_loads_n > 0.0) & (weights > 0.0)
        self.reference_load_n = (float(np.exp(np.sum(weights[loaded] * np.log(self.roller_loads_n[loaded]))
                                              / np.sum(weights[loaded]))) if loaded.any() else 1.0)


def watch_record(run, params: dict) -> tuple[SlewingRecord, dict]:
    """The run through the node's core with the wear model watched: (the record, replay's report)."""
    p = slewing_monitor_params(params)
    monitor = SlewingMonitor(p)
    watched = _WatchedWear(monitor.wear, monitor.fatigue)
    monitor.wear = watched
    _, report = analyse_slewing_run(run, params, monitor=monitor)
    travel = np.asarray(watched.travel, dtype=float).reshape(-1, 4)
    pairs, load_index = np.unique(travel[:, 1:3], axis=0, return_inverse=True)
    strokes = travel[:, 3].astype(np.int64)
    # a stroke's amplitude is half its new ground (only ground beyond the extreme counts as travel)
    amplitude = 0.5 * np.bincount(strokes, weights=travel[:, 0]) if strokes.size else np.zeros(0)
    critical = critical_amplitude_rad(p.roller_count)
    rollers = np.array([axial_roller_loads_n(fa, mt, p.roller_count, p.raceway_diameter_m) for fa, mt in pairs])
    readings = np.asarray(watched.readings, dtype=float).reshape(-1, 3)
    record = SlewingRecord(
        dphi_rad=travel[:, 0], load_index=np.asarray(load_index, dtype=np.int64).reshape(-1),
        small=amplitude[strokes] < critical if strokes.size else np.zeros(0, bool),
        roller_loads_n=rollers.reshape(-1, p.roller_count), reading_t_ns=readings[:, 0].astype(np.int64),
        reading_m=readings[:, 1], reading_travel=readings[:, 2].astype(np.int64), critical_rad=critical)
    report.pop("series", None)
    return record, report


@dataclass
class SlewingFit:
    """One least-squares fit of k and the effects' parameters to the readings."""

    effects: tuple[str, ...]
    values: dict[str, float]
    sd: dict[str, float]
    rss_m2: float
    bic: float
    residual_m: np.ndarray
    heldout_rmse_um: float = math.nan
    n_heldout: int = 0


class SlewingProblem:
    """The readings against c_0 + delta + k (g_large + a g_small), g built with the load exponent n."""

    def __init__(self, record: SlewingRecord, chi_table, raceway_diameter_m: float, initial_clearance_m: float):
        self.record = record
        self.chi_table = chi_table
        self.raceway_diameter_m = float(raceway_diameter_m)
        self.initial_clearance_m = float(initial_clearance_m)
        self._columns: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def columns(self, exponent: float) -> tuple[np.ndarray, np.ndarray]:
        """(g_large, g_small) per reading [m per (m^2/N)]: the clearance per unit k of the travel in strokes at or
        above, and below, theta_crit."""
        if exponent not in self._columns:
            r = self.record
            rates = clearance_rate_per_k_load_power(r.roller_loads_n, self.chi_table, self.raceway_diameter_m,
                                                    exponent, r.reference_load_n)
            step = r.dphi_rad * rates[r.load_index]
            ends = r.reading_travel
            large = np.concatenate([[0.0], np.cumsum(np.where(r.small, 0.0, step))])[ends]
            small = np.concatenate([[0.0], np.cumsum(np.where(r.small, step, 0.0))])[ends]
            self._columns[exponent] = (large, small)
        return self._columns[exponent]

    def _linear(self, effects: tuple[str, ...], exponent: float):
        """Linear least squares at a fixed exponent: (coefficients, covariance / sigma^2, names, rss)."""
        large, small = self.columns(exponent)
        y = self.record.reading_m - self.initial_clearance_m
        names, cols = [], []
        if "clearance_offset" in effects:
            names.append("delta_m")
            cols.append(np.ones_like(y))
        if "small_oscillation_wear" in effects:
            names += ["k", "ka"]
            cols += [large, small]
        else:
            names.append("k")
            cols.append(large + small)
        x = np.column_stack(cols)
        scale = np.linalg.norm(x, axis=0)          # columns of unit norm: the offset [1] beside g [~1e8]
        scale[scale == 0.0] = 1.0
        coef, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
        coef = coef / scale
        rss = float(np.sum((y - x @ coef) ** 2))
        gram = (x / scale).T @ (x / scale)
        # a column (nearly) a multiple of another: the parameters are not separable, their sd infinite
        cov = (np.linalg.inv(gram) / np.outer(scale, scale) if np.linalg.cond(gram) < SEPARABLE_CONDITION
               else np.full(gram.shape, np.inf))
        return coef, cov, names, rss

    def fit(self, effects: tuple[str, ...], warm=None) -> SlewingFit:
        """k and the parameters of ``effects`` (``warm``: forward_selection's start value, not needed here: the
        fit is linear but for n, searched on EXPONENT_BOUNDS); sd from the residual variance."""
        effects = tuple(effects)
        exponent, exponent_sd = 1.0, 0.0
        if "wear_load_exponent" in effects:
            best = minimize_scalar(lambda e: self._linear(effects, e)[3], bounds=EXPONENT_BOUNDS, method="bounded",
                                   options={"xatol": 1e-4})
            exponent = float(best.x)
        coef, cov, names, rss = self._linear(effects, exponent)
        m = self.record.reading_m.size
        n_par = len(names) + int("wear_load_exponent" in effects)
        sigma2 = rss / (m - n_par) if m > n_par else math.nan
        values = dict(zip(names, (float(c) for c in coef)))
        separable = bool(np.all(np.isfinite(cov)))
        sd = {name: math.sqrt(max(cov[i, i], 0.0) * sigma2) if separable else math.inf
              for i, name in enumerate(names)}
        if "small_oscillation_wear" in effects:
            k, ka = values["k"], values.pop("ka")
            i, j = names.index("k"), names.index("ka")
            a = ka / k if k != 0.0 else math.nan
            var = ((cov[j, j] - 2 * a * cov[i, j] + a * a * cov[i, i]) * sigma2 / (k * k)
                   if separable and k != 0.0 else math.inf)
            values["a"], sd["a"] = a, math.sqrt(max(var, 0.0))
            sd.pop("ka")
        if "wear_load_exponent" in effects:
            h = 1e-3         # d^2 RSS / d n^2 of the profile (k refitted): Var(n) = 2 sigma^2 / RSS''
            above, below = self._linear(effects, exponent + h)[3], self._linear(effects, exponent - h)[3]
            curvature = (above - 2 * rss + below) / h**2
            exponent_sd = math.sqrt(2.0 * sigma2 / curvature) if curvature > 0 else math.inf
            values["n"], sd["n"] = exponent, exponent_sd
        bic = m * math.log(max(rss, 1e-30) / m) + n_par * math.log(m)
        return SlewingFit(effects, values, sd, rss, bic, self.record.reading_m - self.predict_m(values, exponent))

    def predict_m(self, values: dict[str, float], exponent: float = 1.0) -> np.ndarray:
        """The clearance [m] at each reading for fitted ``values`` (k, delta_m, a) at the load exponent."""
        large, small = self.columns(exponent)
        k = values["k"]
        return (self.initial_clearance_m + values.get("delta_m", 0.0) + k * large
                + k * values.get("a", 1.0) * small)


def diagnose_slewing(run, params: dict, bic_threshold: float = BIC_THRESHOLD) -> dict:
    """The workflow on a slewing run (see the module doc): a JSON-ready dict."""
    p = slewing_monitor_params(params)
    record, replay = watch_record(run, params)
    m = record.reading_m.size
    if m < MIN_READINGS:
        raise ValueError(f"{m} accepted tilting-clearance readings: diagnose needs at least {MIN_READINGS} (k and "
                         "one effect)")
    if record.dphi_rad.size == 0:
        raise ValueError("no travel of the slewing axis: the wear cannot be told from the readings")
    chi = sliding_weight_table(p.roller_length_m, p.roller_diameter_m, p.youngs_modulus_pa, p.poisson)
    problem = SlewingProblem(record, chi, p.raceway_diameter_m, p.tilting_clearance_initial_m)
    # small oscillations are a candidate only when some travel was made in them (and some not)
    some_small = 0 < int(record.small.sum()) < record.small.size
    candidates = [e for e in SLEWING_EFFECTS if e != "small_oscillation_wear" or some_small]
    result = forward_selection(problem.fit, candidates, bic_threshold=bic_threshold)
    return _result(problem, result, p, replay, bic_threshold)


def _significance(fit: SlewingFit, effect: str) -> float:
    """|value - no-effect value| / sd of the effect's parameter in ``fit`` (0 when unknown)."""
    name, _, none, _ = SLEWING_EFFECTS[effect]
    sd = fit.sd.get(name, math.inf)
    return abs(fit.values[name] - none) / sd if sd > 0 and math.isfinite(sd) else 0.0


def _result(problem: SlewingProblem, result, p, replay: dict, bic_threshold: float) -> dict:
    final = result.final
    named = [e for e in result.named if _significance(final, e) >= SIGNIFICANT_SD]
    not_separable = [e for e in result.named if e not in named]
    if not_separable:      # the model without the effects the readings cannot separate from k
        final = problem.fit(tuple(named))
    effects = {}
    first_round = {row["effect"]: row for row in result.rounds[0]} if result.rounds else {}
    for effect, (name, unit, none, meaning) in SLEWING_EFFECTS.items():
        trial = first_round.get(effect)
        source = final if effect in final.effects else (trial["fit"] if trial else None)
        effects[effect] = {
            "parameter": name, "unit": unit, "no_effect_value": none, "meaning": meaning,
            "named": effect in named, "not_separable": effect in not_separable,
            "value": source.values.get(name) if source else None, "sd": source.sd.get(name) if source else None,
            "delta_bic_alone": trial["delta_bic"] if trial else None,
        }
    sigma = p.tilting_clearance_noise_m
    dof = max(problem.record.reading_m.size - len(final.values), 1)
    chi_square = final.rss_m2 / sigma ** 2
    limit = 2.0 * float(gammaincinv(0.5 * dof, 1.0 - FLAG_ALPHA))       # chi^2 quantile (dof)
    structure = {"present": bool(chi_square > limit), "chi_square": chi_square, "chi_square_99": limit, "dof": dof,
                 "message": (f"structure remains unexplained: residual chi^2 {chi_square:.1f} > {limit:.1f} "
                             f"(99 % point, {dof} dof, reading sd {sigma * 1e6:g} um)") if chi_square > limit else ""}
    return {
        "kind": "slewing", "named_effects": named, "not_separable": not_separable, "effects": effects,
        "baseline": {"k_m2_n": result.baseline.values["k"], "rss_um2": result.baseline.rss_m2 * 1e12,
                     "bic": result.baseline.bic},
        "final": {"effects": list(final.effects), "values": final.values, "sd": final.sd,
                  "rss_um2": final.rss_m2 * 1e12, "bic": final.bic,
                  "rms_residual_um": float(np.sqrt(np.mean(final.residual_m ** 2))) * 1e6},
        "readings": int(problem.record.reading_m.size), "travel_increments": int(problem.record.dphi_rad.size),
        "travel_below_critical_share": float(np.sum(problem.record.dphi_rad[problem.record.small])
                                             / np.sum(problem.record.dphi_rad)),
        "critical_amplitude_deg": math.degrees(problem.record.critical_rad),
        "reference_roller_load_n": problem.record.reference_load_n, "bic_threshold": bic_threshold,
        "significant_sd": SIGNIFICANT_SD, "unexplained_structure": structure,
        "residuals_um": [float(v) * 1e6 for v in final.residual_m],
        "reading_t_ns": [int(t) for t in problem.record.reading_t_ns],
        "replay": {k: replay[k] for k in ("loads", "rejected_loads", "rejected_axis_angles",
                                          "rejected_tilting_clearances", "duration_h") if k in replay},
    }


def slewing_diagnose_lines(result: dict) -> list[str]:
    """The text summary of :func:`diagnose_slewing`'s result."""
    named = ", ".join(result["named_effects"]) or "none (the baseline explains the readings)"
    lines = [f"slewing diagnose: {result['readings']} tilting-clearance readings, "
             f"{result['travel_below_critical_share'] * 100:.1f} % of the travel in strokes below "
             f"{result['critical_amplitude_deg']:.2f} deg", f"  named: {named}"]
    for effect, e in result["effects"].items():
        if e["value"] is None:
            continue
        state = "named" if e["named"] else ("not separable from k" if e["not_separable"] else "not earned")
        sd = e["sd"] if e["sd"] is not None and math.isfinite(e["sd"]) else math.inf
        lines.append(f"  {effect:<24} {e['parameter']} = {e['value']:.4g} +- {sd:.2g} {e['unit']} (no effect "
                     f"{e['no_effect_value']:g}; alone dBIC {e['delta_bic_alone']:+.1f}): {state}")
    final = result["final"]
    lines.append(f"  k = {final['values']['k']:.4g} m^2/N, rms residual {final['rms_residual_um']:.2f} um")
    if result["unexplained_structure"]["present"]:
        lines.append(f"  {result['unexplained_structure']['message']}")
    return lines
