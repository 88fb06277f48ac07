"""``diagnose --out DIR`` writes DIR/model.yaml: what the workflow learnt, as wear_monitor parameters.

A ROS 2 parameters file (``/**/wear_monitor: ros__parameters:``) with the calibrated K, the A0 the fit used,
the named effects the live model integrates (``effects`` and their parameters, params/wear_monitor.py) and
the covariance of the fitted K, effect parameters and A0 (models/wear/effects/registry.COVARIANCE_NAMES;
the gauge offset at T_ref is a linear function of the fitted c_T and offset at T_0, its rows by that Jacobian;
A0's row is the fitted A0's, or the initial offset's delta's, when the fit freed them, else zero).
The values an effect takes from the record come from its module (Effect.file_values: absolute times in seconds
since the stamps' epoch, references; Effect.record_references: the fit's reference load and retract direction).
Load it after the base file, the later overriding, as ROS merges several ``--params-file``:

    guide-health replay BAG --params config/bench_000.yaml --params DIR/model.yaml
    ros2 run guide_health wear_monitor --ros-args --params-file base.yaml --params-file DIR/model.yaml

The gauge's temperature term goes in as the correction (c_T and the absolute T_ref: the live model corrects each
measurement by c_T (T - T_ref) before the K update). The pass weighting's w maps the effective work of each pass
to straightness (effect_wear.EffectWear's pass work); a fitted initial offset is folded into A0.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from guide_health.analysis.discrepancy.model import in_decay_law
from guide_health.io.outputs.files import write_text
from guide_health.models.wear.effect_life import symmetrised
from guide_health.models.wear.effects.registry import (
    BY_ID,
    CONSISTENCY_ALTERNATIVES,
    COVARIANCE_ALIASES,
    COVARIANCE_INDEX,
    COVARIANCE_NAMES,
    EFFECT_PARAMETERS,
    FILE_VALUE_EFFECTS,
    LIVE_EFFECT_IDS,
    MATERIAL_EFFECTS,
    RECORD_REFERENCE_EFFECTS,
    SLIDING_DECAY,
)

# the model file's keys and covariance rows come from the effect registry: EFFECT_PARAMETERS (the fitted
# parameters each live effect carries, same names as the wear_monitor's), MATERIAL_EFFECTS (shared by machines
# of a type: the fleet prior pools them; the others belong to one machine's history or mounting),
# COVARIANCE_ALIASES (a fitted parameter's row when its name differs from the live one)
from guide_health.models.wear.form_average import RUNNING_IN_FORMS, bic_weights, running_in_form_life_s
from guide_health.params import validate_wear_params

__all__ = ["COVARIANCE_ALIASES", "EFFECT_PARAMETERS", "MATERIAL_EFFECTS", "model_parameters", "life_forms",
           "write_model_file"]


def duty_effect_parameters(problem, v: dict[str, float], live: list[str]) -> dict[str, Any]:
    """The absolute times and references of the named effects that come from the record (Effect.file_values, in
    the order model files have written them)."""
    t0_s = problem.cells.t0_ns * 1e-9
    out: dict[str, Any] = {}
    for effect in FILE_VALUE_EFFECTS:
        if effect.id in live:
            out.update(effect.file_values(problem, v, t0_s))
    return out


def model_parameters(problem, final, named: list[str]) -> dict[str, Any]:
    """The wear_monitor parameters of a fitted model (``problem``: WearProblem, ``final``: its FitResult)."""
    v = final.values
    a0 = v["straightness_initial_m"] if problem.a0_free else problem.a0_m     # a free A0 is always fitted
    a0 += sum(v.get(fitted, 0.0) for fitted, row in COVARIANCE_ALIASES.items() if row == "straightness_initial_m")
    live = [e for e in named if e in LIVE_EFFECT_IDS]
    out: dict[str, Any] = {
        "wear_coefficient": float(v["wear_coefficient"]),
        "straightness_initial_m": float(max(a0, 0.0)),
        "effects": ",".join(live),
    }
    for effect in RECORD_REFERENCE_EFFECTS:
        out.update(effect.record_references(problem))
    for e in live:
        for name in EFFECT_PARAMETERS.get(e, ()):
            out[name] = float(v[name])
    out.update(duty_effect_parameters(problem, v, live))
    cov = final.extra.get("covariance")
    n = len(COVARIANCE_NAMES)
    matrix = np.zeros((n, n))
    if cov is not None:
        # the file's parameters as linear functions of the fitted ones (jac), then jac Sigma jac' (a fitted
        # name the registry aliases takes its row: the initial offset's delta is A0's, A0 = the given A0 + delta)
        index = {COVARIANCE_ALIASES.get(name, name): i for i, name in enumerate(cov["names"])}
        jac = np.zeros((n, len(cov["names"])))
        for name in COVARIANCE_NAMES:
            if name in index and (name == "wear_coefficient" or name in out):
                jac[COVARIANCE_INDEX[name], index[name]] = 1.0
        for effect in FILE_VALUE_EFFECTS:     # rows that are linear functions of other fitted parameters
            if effect.id in live:
                for row, fitted, d in effect.file_jacobian(problem, out):
                    if fitted in index:
                        jac[COVARIANCE_INDEX[row], index[fitted]] = d
        fitted = np.asarray(cov["matrix"], dtype=float)
        matrix = symmetrised(jac @ np.where(np.isfinite(fitted), fitted, 0.0) @ jac.T)   # exactly, for the loader
    out["effect_covariance"] = [float(x) for x in matrix.ravel()]
    return out


def form_life_s(problem, values: dict[str, float], form: str, limit_m: float) -> float:
    """The remaining life [s] a fit forecasts from the last measurement: the steady rate (the model without
    running-in, over the record's last quarter: the present duty), the margin to the limit from the fitted
    present straightness, and the running-in's decay in ``form`` on the way when the fit has one
    (form_average.running_in_form_life_s) at the last quarter's sliding speed."""
    t, n, c = problem.t_s, problem.t_s.size, problem.cells
    j = max(0, int(0.75 * n) - 1)
    decays = all(name in values for name in SLIDING_DECAY.fitted_to_file)     # the fit holds the decay
    steady = problem.predict_m(SLIDING_DECAY.steady(values) if decays else values)
    rate = (steady[-1] - steady[j]) / max(t[-1] - t[j], 1e-9)
    distance = np.cumsum(np.bincount(np.clip(c.interval, 0, n), weights=c.distance_m, minlength=n + 1)[:n])
    speed = (distance[-1] - distance[j]) / max(t[-1] - t[j], 1e-9)
    ratio, s0 = SLIDING_DECAY.fitted_decay(values) if decays else (0.0, 1.0)
    return running_in_form_life_s(form, limit_m - float(problem.predict_m(values)[-1]), float(rate),
                                  ratio, s0, float(distance[-1]), float(speed))


def form_ln_life_sd(problem, fit, form: str, limit_m: float) -> float:
    """Delta-method sd of ln(:func:`form_life_s`) of a fit: g' Sigma g, g the central-difference gradient of
    ln(life) in each fitted parameter (step 1 % of its sd, at most a quarter of its value), Sigma the fit's
    covariance. NaN without a covariance or a finite life on each side."""
    cov = fit.extra.get("covariance")
    if cov is None:
        return math.nan
    names, sigma = cov["names"], np.asarray(cov["matrix"], dtype=float)
    grad = np.zeros(len(names))
    for i, name in enumerate(names):
        sd, value = math.sqrt(max(sigma[i, i], 0.0)), fit.values[name]
        step = min(0.01 * sd, 0.25 * abs(value)) if value != 0 else 0.01 * sd
        if not (step > 0 and math.isfinite(step)):
            continue
        ends = [form_life_s(problem, {**fit.values, name: value + h}, form, limit_m) for h in (step, -step)]
        if not all(math.isfinite(x) and x > 0 for x in ends):
            return math.nan
        grad[i] = (math.log(ends[0]) - math.log(ends[1])) / (2.0 * step)
    var = float(grad @ np.where(np.isfinite(sigma), sigma, 0.0) @ grad)
    return math.sqrt(var) if var > 0 else math.nan


def decay_stand_in(carried: list[str]) -> str | None:
    """The carried effect the running-in's decay laws are fitted in the place of: the running-in itself, or a
    carried effect whose consistency check has the decay with sliding distance as an alternative (the step in
    K); None: no form uncertainty to average."""
    if SLIDING_DECAY.id in carried:
        return SLIDING_DECAY.id
    return next((e for e in carried if SLIDING_DECAY.id in CONSISTENCY_ALTERNATIVES.get(e, ())), None)


def life_forms(problem, final, carried: list[str], limit_m: float) -> dict[str, list[float]]:
    """The model file's ``life_form_*`` lists (models/wear/form_average.py, LIFE_FORMS order): the carried
    model (``final``) first, then the running-in in each decay law, refitted on the same measurements in the
    place of :func:`decay_stand_in` (the carried law's slot, the exponential's when the file carries the
    running-in, weight 0): the BIC weights, the ln-life offsets from the carried model's forecast and the
    ratios of their delta-method ln-life sd to its. {} without a stand-in or a finite life of each."""
    stand_in = decay_stand_in(carried)
    if stand_in is None:
        return {}
    effects = tuple(e for e in carried if e != stand_in) + (SLIDING_DECAY.id,)
    own_form = RUNNING_IN_FORMS[0] if stand_in == SLIDING_DECAY.id else None
    lives = [form_life_s(problem, final.values, RUNNING_IN_FORMS[0], limit_m)]
    bics, sds = [final.bic], [form_ln_life_sd(problem, final, RUNNING_IN_FORMS[0], limit_m)]
    for form in RUNNING_IN_FORMS:
        if form == own_form:
            lives.append(lives[0])
            bics.append(math.inf)           # weight 0: it is the carried model
            sds.append(sds[0])
            continue
        with in_decay_law(problem, form):        # the fit and its forecasts in that law
            fit = problem.fit(effects, warm=final)
            lives.append(form_life_s(problem, fit.values, form, limit_m))
            bics.append(fit.bic)
            sds.append(form_ln_life_sd(problem, fit, form, limit_m))
    lives, sds = np.asarray(lives), np.asarray(sds)
    if not (np.all(np.isfinite(lives)) and np.all(lives > 0)):
        return {}
    # a form whose spread the delta method cannot give keeps the carried model's (ratio 1)
    ratios = (np.where(np.isfinite(sds) & (sds > 0), sds, sds[0]) / sds[0] if math.isfinite(sds[0]) and sds[0] > 0
              else np.ones(len(sds)))
    return {"life_form_weights": [float(w) for w in bic_weights(np.asarray(bics))],
            "life_form_ln_life_offsets": [float(x) for x in np.log(lives / lives[0])],
            "life_form_ln_life_sd_ratios": [float(min(x, 1e3)) for x in ratios]}


def live_parameter_text(model: dict[str, Any]) -> str:
    """"K = 4.457e-06 ± 6.1e-08, w = 0.59 ± 0.061" (by the parameters' names): the model file's K and effect
    parameters with their standard errors (the covariance's diagonal). These are refitted on every
    measurement, so they differ from the selection's values (fitted without the held-out span)."""
    n = len(COVARIANCE_NAMES)
    cov = np.asarray(model["effect_covariance"], dtype=float).reshape(n, n)
    effects = [e for e in str(model["effects"]).split(",") if e]
    names = ["wear_coefficient"] + [p for e in effects for p in EFFECT_PARAMETERS.get(e, ())]
    names += [name for e in effects if e in BY_ID for name in BY_ID[e].file_derived]
    a0 = COVARIANCE_INDEX["straightness_initial_m"]
    if cov[a0, a0] > 0:                  # A0 was fitted
        names.append("straightness_initial_m")
    parts = []
    for name in names:
        i = COVARIANCE_INDEX[name] if name in COVARIANCE_NAMES else None
        sd = math.sqrt(cov[i, i]) if i is not None and cov[i, i] > 0 else None
        parts.append(f"{name} = {model.get(name, 0.0):.4g}" + (f" ± {sd:.2g}" if sd is not None else ""))
    return ", ".join(parts)


def not_live_effects(named: list[str]) -> list[str]:
    """The named effects the live model does not apply (one whose fitted value the file folds into a row of
    its own, as the initial offset into A0, is applied)."""
    return [e for e in named if e not in LIVE_EFFECT_IDS and not BY_ID[e].fitted_aliases]


def write_model_file(path: Path, base_params: dict[str, Any], model: dict[str, Any], named: list[str],
                     source: str = "", unexplained: str = "", left_out: tuple[str, ...] = ()) -> None:
    """DIR/model.yaml; the merged parameters (base then model) are validated first. ``unexplained``: the
    unexplained-structure message, which then heads the file (its effects are fitted, not an explanation);
    ``left_out``: named effects the model does not carry (readings: consistency.model_effects)."""
    validate_wear_params({**base_params, **model})
    body = yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": model}}, sort_keys=False, width=200)
    header = _header(named, source, [unexplained] if unexplained else [])
    if left_out:
        header.append(f"# named but left out of this model (the record prefers another form): {', '.join(left_out)}")
    write_text(path, "\n".join(header) + "\n" + body)


def write_axes_model_file(path: Path, axes: dict[str, dict[str, Any]], models: dict[str, dict[str, Any]],
                          named: dict[str, list[str]], source: str = "",
                          unexplained: dict[str, str] | None = None) -> None:
    """DIR/model.yaml of a machine of several axes: each axis's model under its axis key (a per-axis override,
    params/machine.py); ``axes``: the axes' base parameters, each merged with its model and validated first."""
    for axis, model in models.items():
        validate_wear_params({**axes[axis], **model})
    notes = [f"axis {axis}: {text}" for axis, text in (unexplained or {}).items() if text]
    body = yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": models}}, sort_keys=False, width=200)
    all_named = [f"{axis}.{e}" for axis, effects in named.items() for e in effects]
    write_text(path, "\n".join(_header(all_named, source, notes)) + "\n" + body)


def _header(named: list[str], source: str, unexplained: list[str]) -> list[str]:
    """The comment lines that head model.yaml."""
    not_live = not_live_effects([e.rpartition(".")[2] for e in named])
    header = [f"# {text}" for text in unexplained]
    if unexplained:
        header.append("# The effects below are fitted, not an explanation: check the physics before "
                      "trusting the live remaining life they give.")
    header += [f"# guide-health diagnose {source}: the model it learnt, as wear_monitor parameters.",
               "# Load after the base parameters: --params BASE --params model.yaml (replay, diagnose) or",
               "# --params-file BASE --params-file model.yaml (wear_monitor); the later file overrides.",
               f"# effect_covariance: {len(COVARIANCE_NAMES)} x {len(COVARIANCE_NAMES)} row-major over "
               f"{', '.join(COVARIANCE_NAMES)}."]
    if not_live:
        header.append(f"# named but not integrated live: {', '.join(not_live)}")
    return header
