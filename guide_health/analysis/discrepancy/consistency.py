"""Does each named effect pass a check of its own physics against the record? A *finding* when it does, a
*reading* when it fails (the data are fitted by it, but its physics is not what the record shows), *ambiguous*
when an alternative form fits as well: then both are reported, with the measurement that separates them.

The checks (after the forward selection) are the effects': each effect's module says which forms it is checked
against (``Effect.consistency_alternatives``, registry.CONSISTENCY_ALTERNATIVES), its own physics check
(``Effect.own_consistency_check``, e.g. a relubrication period seen to repeat) and the measurement that tells it
from a step in K (``Effect.consistency_separation``). The alternative forms here are forms for the check, not
library effects (but the registry's step in K, RATE_STEP, and its decay of K with sliding distance,
SLIDING_DECAY, fitted in each decay law of models/wear/form_average.py and the best by BIC kept: a decaying
wear rate of another shape, e.g. linear to a floor, must not pass as a step because the exponential fits it
less well):

  (a) a smooth trend in K with clock time: m = 1 + a (t - t_first) / (t_last - t_first),
  (b) K growing with the worn volume: m = 1 + a W(t) / W_total, W the Archard work done before the cell,
  (c) a gauge whose zero drifts with clock time: y += d (t - t_first), no wear change. Idle periods tell
      (c) from wear: the gauge drifts while the machine stands, wear needs motion.

Every named effect is also checked against (c) in place of all the named effects (a drift that re-weights the
jobs' work can look like a material or duty effect on a duty that varies job by job), and, in its own place,
against the structure forms outside the library (``STRUCTURE_FORMS``: what a library effect can absorb of
structure it does not hold):

  (d) a gauge whose zero steps at one time: y += d H(t - t_s) (a gauge knocked, a rail re-clamped; no change in
      wear). t_s is profiled, not fitted: the measurement boundary where a step in the residuals of the model
      without the named effect (with its wear rescaled) leaves the least squares, at least ``STEP_MARGIN``
      measurements from either end of the fit span; its BIC counts t_s as a parameter;
  (e) a wear profile along the rail: m = max(1 + sum_k a_k cos(k pi u), 0) for k = 1..``POSITION_MODES``, u the
      cell's position scaled to [0, 1] over the work's 1..99 % positions (a smooth basis: the first
      ``POSITION_MODES`` modes of any profile along the travel; a foundation of varying stiffness).

An effect's own check may refit the final model with check forms freed beside it (``ConsistencyRecord.refit_beside``:
(c), or (f) a gauge offset y += d, a form error there from the first measurement, when A0 is given): its size
must stay significant beside them.

The same forms (c) and (e) added to the final model are the flag's nested tests of structure
(:func:`structure_form_tests`): an F-test of the final model against it plus the form, whether anything is
named or not (a gauge drifting in clock time is told from wear by the idle periods; a wear profile along the
rail by where the work was done).

A named effect that is a *reading* because a form outside the library fits better (or that fails its own
check) raises the unexplained-structure flag (analysis.unexplained_structure, ``outside_library``): the effect
absorbs structure the library does not hold, so it is never named with no flag.

Each alternative replaces the named effect in the final model (the other named effects kept), is refitted on
the same fit span and compared by BIC (both have the same measurements): dBIC = BIC_alt - BIC_named.
|dBIC| <= ``AMBIGUOUS_BIC`` (6: the lower edge of "strong" evidence on Kass & Raftery's scale, 1995) is a
tie: ``ambiguous``; an alternative better by more is ``reading``; every alternative worse by more is a
``finding``.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy import special

from guide_health.analysis.discrepancy.model import FitResult, WearProblem, in_decay_law
from guide_health.models.wear.effects.base import ConsistencyRecord, FitParameter
from guide_health.models.wear.effects.registry import (
    BY_ID,
    CONSISTENCY_ALTERNATIVES,
    INITIAL_TERM,
    RATE_STEP,
    SLIDING_DECAY,
)
from guide_health.models.wear.form_average import RUNNING_IN_FORMS

#: |BIC_alternative - BIC_named| at or below this is a tie (Kass & Raftery 1995: 6..10 "strong")
AMBIGUOUS_BIC = 6.0
#: the idle period a separating straightness check should span [h] (at least this, or twice the longest idle
#: stretch of the record)
SEPARATING_IDLE_H = 10.0

# the alternative forms: id -> (what it is, its fitted parameter)
ALTERNATIVES = {
    "k_trend_in_time": "the wear coefficient changing smoothly with clock time (a linear ramp, no step)",
    "k_growth_with_wear": "the wear coefficient growing with the worn volume (debris: wear accelerating smoothly)",
    "gauge_drift_in_time": "the gauge zero drifting with clock time (no change in wear)",
    "gauge_step_in_time": "the gauge zero stepping at one time (no change in wear)",
    "wear_profile_along_rail": "a wear rate that varies smoothly along the rail (a profile, not a gradient)",
    RATE_STEP.id: "a step in the wear coefficient at one time",
    SLIDING_DECAY.id: "the wear coefficient decaying with the sliding distance (running-in; the best of its decay "
                      "laws)",
}
_ALT_SPECS = {
    "k_trend_in_time": [FitParameter("k_trend_per_record", "-", -0.9, 20.0, False, (0.5, 2.0))],
    "k_growth_with_wear": [FitParameter("k_growth_per_work", "-", -0.9, 20.0, False, (0.5, 2.0))],
    "gauge_drift_in_time": [FitParameter("gauge_drift_m_per_s", "m/s", -2e-9, 2e-9, False, (0.0,))],
    "gauge_step_in_time": [FitParameter("gauge_step_m", "m", -1e-4, 1e-4, False, (0.0,))],
    # a gauge or form error there from the first measurement: y + d (an effect's own check frees it beside it)
    "gauge_offset": [FitParameter("gauge_offset_m", "m", -1e-4, 1e-4, False, (0.0,))],
}
#: the cosine modes of the wear profile along the rail, form (e)
POSITION_MODES = 4
#: a profiled gauge step leaves at least this many fit-span measurements on either side
STEP_MARGIN = 3
_ALT_SPECS["wear_profile_along_rail"] = [FitParameter(f"wear_profile_mode_{k}", "-", -0.9, 0.9, False, (0.0,))
                                         for k in range(1, POSITION_MODES + 1)]
#: the forms every named effect is checked against in its own place: structure outside the library
STRUCTURE_FORMS = ("gauge_step_in_time", "wear_profile_along_rail")
#: the forms the flag's nested F-tests add to the final model (each nested in it: no profiled parameter)
NESTED_FORMS = ("gauge_drift_in_time", "wear_profile_along_rail")


def checked_against(effect: str) -> tuple[str, ...] | None:
    """The alternative forms an effect is checked against (None: it has no check of its own beyond the
    selection): the forms whose signature in a record can look like the effect's (its module says)."""
    return CONSISTENCY_ALTERNATIVES.get(effect)


class CheckProblem(WearProblem):
    """The workflow's problem with the alternative forms of the checks as extra 'effects'."""

    def __init__(self, problem: WearProblem):
        super().__init__(problem.cells, problem.params, heldout_fraction=float(problem.heldout_mask.mean()),
                         relubrication_t_s=problem.relubrication_t_s)
        # the same fit span as the workflow's (its rounding of the held-out share is kept exactly)
        self.fit_mask, self.heldout_mask = problem.fit_mask.copy(), problem.heldout_mask.copy()
        self.specs = {**problem.specs, **_ALT_SPECS}
        c, n = self.cells, self.t_s.size
        self.t_first_s, self.t_span_s = float(self.t_s[0]), max(float(self.t_s[-1] - self.t_s[0]), 1.0)
        # the Archard work done before each cell's middle (cells of one interval: its work before + half its own)
        k = np.clip(c.interval, 0, n)
        per_interval = np.bincount(k, weights=c.work_nm, minlength=n + 1)
        before = np.concatenate(([0.0], np.cumsum(per_interval)))[k] + 0.5 * per_interval[k]
        self.work_share_before = before / max(float(per_interval.sum()), 1e-300)
        lo, hi = _weighted_quantiles(c.position_m, c.work_nm, (0.01, 0.99))
        self.position_low_m, self.position_span_m = lo, max(hi - lo, 1e-6)
        self.gauge_step_at_s = float(self.t_s[-1])       # set by profile_gauge_step before a fit of form (d)

    def fit_span(self) -> WearProblem:
        """The fit span's problem (WearProblem.fit_span) with the work shares of its cells only."""
        span = super().fit_span()
        span.work_share_before = self.work_share_before[:span.retract.size]
        return span

    def _internal_factor(self, spec: FitParameter) -> float:
        if spec.name == "gauge_drift_m_per_s":
            return 1e-6 / 3600.0                # um per hour inside the fit
        return super()._internal_factor(spec)

    def _duty_factors(self, values: dict[str, float]):
        m = super()._duty_factors(values)
        if "k_trend_per_record" in values:
            m = m * np.maximum(1.0 + values["k_trend_per_record"] * (self.cells.time_s - self.t_first_s)
                               / self.t_span_s, 0.0)
        if "k_growth_per_work" in values:
            m = m * np.maximum(1.0 + values["k_growth_per_work"] * self.work_share_before, 0.0)
        if "wear_profile_mode_1" in values:
            u = np.clip((self.cells.position_m - self.position_low_m) / self.position_span_m, 0.0, 1.0)
            profile = sum(values[f"wear_profile_mode_{k}"] * np.cos(k * np.pi * u)
                          for k in range(1, POSITION_MODES + 1))
            m = m * np.maximum(1.0 + profile, 0.0)
        return m

    def predict_m(self, values: dict[str, float]) -> np.ndarray:
        y = super().predict_m(values)
        if "gauge_drift_m_per_s" in values:
            y = y + values["gauge_drift_m_per_s"] * (self.t_s - self.t_first_s)
        if "gauge_step_m" in values:
            y = y + values["gauge_step_m"] * (self.t_s >= self.gauge_step_at_s)
        return y + values.get("gauge_offset_m", 0.0)


def _weighted_quantiles(values: np.ndarray, weights: np.ndarray, q: tuple[float, ...]) -> list[float]:
    """Weighted quantiles of ``values`` (the first value whose cumulative weight share reaches each q)."""
    order = np.argsort(values, kind="stable")
    cum = np.cumsum(weights[order])
    share = cum / max(float(cum[-1]), 1e-300) if cum.size else cum
    return [float(values[order][min(int(np.searchsorted(share, x)), values.size - 1)]) for x in q]


def profile_gauge_step(problem: CheckProblem, final: FitResult, replaces: list[str]) -> float:
    """The time [s] of form (d)'s step: the fit model without the ``replaces`` effects (their parameters at no
    effect), its residuals r on the fit span regressed on [1, wear w, H(t - t_j)] for every boundary j with
    ``STEP_MARGIN`` measurements on either side; the boundary of the least residual sum of squares (half-way
    between the measurements). The record's end when the fit span is too short for a step."""
    dropped = {s.name for e in replaces for s in problem.specs[e]}
    values = {k: v for k, v in final.values.items() if k not in dropped}
    span = problem.fit_mask
    t, y = problem.t_s[span], problem.y_m[span]
    pred = problem.predict_m(values)[span]
    n = t.size
    if n < 2 * STEP_MARGIN + 2:
        return float(problem.t_s[-1]) + 1.0
    r, w = (y - pred) * 1e6, (pred - pred[0]) * 1e6
    best, at = np.inf, float(t[-1])
    for j in range(STEP_MARGIN, n - STEP_MARGIN + 1):
        x = np.column_stack((np.ones(n), w, (np.arange(n) >= j).astype(float)))
        coef, *_ = np.linalg.lstsq(x, r, rcond=None)
        rss = float(np.sum((r - x @ coef) ** 2))
        if rss < best:
            best, at = rss, 0.5 * float(t[j - 1] + t[j])
    return at


def idle_hours(problem: WearProblem) -> tuple[float, float]:
    """(total, longest) idle time [h] of the record: measurement intervals without sliding."""
    n = problem.t_s.size
    dist = np.bincount(np.clip(problem.cells.interval, 0, n), weights=problem.cells.distance_m, minlength=n + 1)[:n]
    gaps = np.diff(np.concatenate(([0.0], problem.t_s))) / 3600.0
    idle = gaps[dist <= 0.0]
    return float(idle.sum()), float(idle.max()) if idle.size else 0.0


def separating_measurement(named: str, alternative: str, fit: FitResult, problem: WearProblem) -> str:
    """What measurement would tell ``named`` from ``alternative`` (with this record's numbers)."""
    _, longest = idle_hours(problem)
    idle_h = max(SEPARATING_IDLE_H, 2.0 * longest)
    if alternative == "gauge_drift_in_time":
        d_um_h = fit.values["gauge_drift_m_per_s"] * 3.6e9
        return (f"a straightness check before and after a {idle_h:.0f} h idle period (no motion) separates gauge "
                f"drift from wear: a drifting gauge moves {d_um_h * idle_h:+.2f} um over it ({d_um_h:+.3f} um/h), "
                "wear adds nothing; or a reference artefact measured with the gauge")
    if alternative == "k_growth_with_wear":
        return ("a change of duty (a light-load or idle week) separates wear growth with worn volume from a "
                "step or a clock-time trend: the former follows the work done, not the time")
    if alternative == "k_trend_in_time":
        return ("a longer record at a steady duty separates a step from a smooth trend: after a step the wear "
                "rate stays constant, under a trend it keeps changing; a logged event (wiper, lubricant) dates a "
                "step")
    if alternative == "gauge_step_in_time":
        return ("a straightness check of a reference artefact (or the rail re-measured) separates a gauge that "
                f"stepped at {fit.extra['gauge_step_time_s'] / 3600.0:.1f} h from wear: a gauge step moves both")
    if alternative == "wear_profile_along_rail":
        return ("a straightness profile along the rail (positions, not one number) separates a wear profile along "
                "the rail from the named effect")
    return (BY_ID[named].consistency_separation or getattr(BY_ID.get(alternative), "consistency_separation", "")
            or "a longer record at a steady duty")


def own_check(effect: str, problem: WearProblem, fit: FitResult,
              alt_problem: CheckProblem | None = None) -> dict[str, Any]:
    """The effect's check of its own physics against the record (its module's), {"passed": True} without one.
    Its ``refit_beside(forms)``: ``fit``'s model with the check forms freed beside it, on ``alt_problem`` (made
    from ``problem`` when not given); "gauge_offset" is left out when A0 or its offset is fitted (it is that
    term)."""
    relubrications = problem.relubrication_t_s.size if problem.relubrication_t_s is not None else None
    fit_span_s = float(problem.t_s[problem.fit_mask][-1] - problem.t_s[0])

    def refit_beside(forms: tuple[str, ...]) -> tuple[dict[str, float], dict[str, float]]:
        alt = alt_problem if alt_problem is not None else CheckProblem(problem)
        offset_fitted = alt.a0_free or INITIAL_TERM.id in fit.effects
        freed = tuple(f for f in forms if not (f == "gauge_offset" and offset_fitted))
        beside = alt.fit(tuple(fit.effects) + freed, warm=fit)
        return beside.values, beside.std_errors

    return BY_ID[effect].own_consistency_check(ConsistencyRecord(relubrications, fit_span_s, fit.values,
                                                                 refit_beside))


def _status(rows: list[dict], own_check_passed: bool) -> str:
    if not own_check_passed or any(r["delta_bic"] < -AMBIGUOUS_BIC for r in rows):
        return "reading"
    return "ambiguous" if any(abs(r["delta_bic"]) <= AMBIGUOUS_BIC for r in rows) else "finding"


def outside_library(check: dict[str, Any]) -> list[str]:
    """Why a named effect's check says the record holds structure outside the library: its own check failed, or
    a form that is no library effect fits better than it by more than ``AMBIGUOUS_BIC`` ([] when neither)."""
    why = [] if check["own_check"].get("passed", True) else [check["own_check"].get("reason", "its own check failed")]
    return why + [f"{r['form']} fits better by {-r['delta_bic']:.1f} in BIC" for r in check["alternatives"]
                  if r["form"] not in BY_ID and r["delta_bic"] < -AMBIGUOUS_BIC]


def _alternative_fit(alt_problem: CheckProblem, effects: tuple[str, ...], form: str,
                     final: FitResult) -> tuple[FitResult, dict[str, Any]]:
    """(fit, extra reported values) of ``effects`` (``form`` among them); the decay with sliding distance in
    each of its decay laws, the lowest BIC kept (its law reported)."""
    if form != SLIDING_DECAY.id:
        return alt_problem.fit(effects, warm=final), {}
    fits = []
    for law in RUNNING_IN_FORMS:
        with in_decay_law(alt_problem, law):
            fits.append((alt_problem.fit(effects, warm=final), law))
    f, law = min(fits, key=lambda fl: fl[0].bic if np.isfinite(fl[0].bic) else np.inf)
    return f, {"decay_law": law}


def _alternative(alt_problem: CheckProblem, kept: tuple[str, ...], form: str, final: FitResult,
                 replaces: list[str]) -> dict[str, Any]:
    """The fit with ``form`` in place of the effects ``replaces`` (``kept`` stay), scored against ``final``."""
    profiled = 0.0
    if form == "gauge_step_in_time":
        alt_problem.gauge_step_at_s = profile_gauge_step(alt_problem, final, replaces)
        profiled = float(np.log(final.n_fit))          # the step's time counts as a parameter
    f, extra = _alternative_fit(alt_problem, kept + (form,), form, final)
    if profiled:
        f.extra["gauge_step_time_s"] = alt_problem.gauge_step_at_s
    return {"form": form, "meaning": ALTERNATIVES[form], "replaces": replaces,
            "delta_bic": f.bic + profiled - final.bic, "bic": f.bic + profiled, "heldout_rmse_um": f.heldout_rmse_um,
            "parameters": {s.name: f.values[s.name] for s in alt_problem.specs[form]}
            | ({"gauge_step_time_h": alt_problem.gauge_step_at_s / 3600.0} if profiled else {}), **extra, "_fit": f}


def check_named_effects(problem: WearProblem, final: FitResult, named: list[str]) -> dict[str, dict[str, Any]]:
    """Per named effect: {status, check, alternatives: [{form, meaning, replaces, delta_bic, bic, parameters}],
    separating_measurement}. Every named effect is also checked against a gauge drifting with clock time in
    place of all the named effects: on a duty that varies job by job, a drift can look like a material or duty
    effect that re-weights the work of the jobs."""
    if not named:
        return {}
    alt_problem = CheckProblem(problem)
    whole = _alternative(alt_problem, (), "gauge_drift_in_time", final, list(named))
    out: dict[str, dict[str, Any]] = {}
    for effect in named:
        forms = [a for a in dict.fromkeys((*(checked_against(effect) or ()), *STRUCTURE_FORMS)) if a not in named]
        own = own_check(effect, problem, final, alt_problem)
        rest = tuple(e for e in named if e != effect)
        rows = [_alternative(alt_problem, rest, form, final, [effect]) for form in forms]
        if not (rest == () and "gauge_drift_in_time" in forms):
            rows.append(whole)
        close = [r for r in rows if r["delta_bic"] <= AMBIGUOUS_BIC]
        text = [f"{r['form']}{'' if r['replaces'] == [effect] else ' in place of ' + ' + '.join(r['replaces'])} "
                f"dBIC {r['delta_bic']:+.1f}" for r in rows]
        out[effect] = {
            "status": _status(rows, own["passed"]), "tie_bic": AMBIGUOUS_BIC,
            "check": "; ".join(([own["reason"]] if "reason" in own else [])
                               + [f"against {', '.join(text)} (tie within {AMBIGUOUS_BIC:g})"]),
            "own_check": own,
            "alternatives": [{k: v for k, v in r.items() if k != "_fit"} for r in rows],
            "separating_measurement": "; ".join(dict.fromkeys(
                separating_measurement(effect, r["form"], r["_fit"], problem)
                for r in sorted(close, key=lambda r: r["delta_bic"]))),
        }
    return out


def structure_form_tests(problem: WearProblem, final: FitResult, named: list[str]) -> list[dict[str, Any]]:
    """The flag's nested tests: the final model plus each of ``NESTED_FORMS`` refitted on the fit span, F =
    ((RSS_final - RSS_plus) / q) / (RSS_plus / (n - k_plus)) against F(q, n - k_plus), q the form's parameters
    (the extra-sum-of-squares F-test of nested least-squares models)."""
    alt_problem = CheckProblem(problem)
    rows = []
    for form in NESTED_FORMS:
        plus = alt_problem.fit(tuple(named) + (form,), warm=final)
        q, dof = len(alt_problem.specs[form]), plus.n_fit - plus.n_params
        if dof <= 0 or plus.rss_um2 <= 0:
            continue
        f = max(final.rss_um2 - plus.rss_um2, 0.0) / q / (plus.rss_um2 / dof)
        rows.append({"form": form, "meaning": ALTERNATIVES[form], "f": float(f), "dof": [q, dof],
                     "p_value": float(special.fdtrc(q, dof, f))})
    return rows


def model_effects(named: list[str], checks: dict[str, dict[str, Any]]) -> tuple[list[str], dict[str, str]]:
    """(the effects the model file carries, {named effect left out: the library effect in its place, or ""}).

    Only what the record prefers is forecast from: a finding, or a tie the named effect leads (no alternative
    fits better; the tie is reported). A reading, or a tie an alternative leads, is left out of the model; when
    that alternative is a library effect (the step in K, the decay with sliding distance) it stands in its
    place, else (a trend, a gauge drift: forms for the check only) nothing does."""
    carried: list[str] = []
    left_out: dict[str, str] = {}
    for effect in named:
        check = checks.get(effect, {"status": "finding", "alternatives": []})
        best = min(check["alternatives"], key=lambda a: a["delta_bic"], default=None)
        if check["status"] == "finding" or (check["status"] == "ambiguous" and (best is None
                                                                               or best["delta_bic"] >= 0.0)):
            carried.append(effect)
            continue
        stand_in = best["form"] if best is not None and best["delta_bic"] < 0.0 and best["form"] in BY_ID else ""
        left_out[effect] = stand_in
        if stand_in and stand_in not in named and stand_in not in carried:
            carried.append(stand_in)
    return carried, left_out
