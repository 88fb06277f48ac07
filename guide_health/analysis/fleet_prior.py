"""`guide-health fleet prior`: the K prior of a machine type from its replayed or diagnosed machines.

Per bag (a ``fleet.json`` of ``fleet replay`` or ``fleet diagnose``) the data-only estimate of K and its
standard error: diagnose's least-squares K ± s.e. as they are; replay's posterior (mean, 90 % interval)
divided by the prior it was computed with (models/fleet.py ``likelihood_from_posterior``), so the default
prior is not counted once per machine. Bags of one machine are combined (inverse variance on log K). The
machines' log K then give the population (mu, tau) by REML, and the new machine's prior is the lognormal
predictive's mean and relative sd (``wear_coefficient_prior``), written as a wear_monitor params file.
Named effects' parameters (diagnose) get the same population fit on their own scale; a material effect the
live model integrates (model_file.MATERIAL_EFFECTS: not a change time, a relubrication plan or one rail's
misalignment, which belong to one machine) that at least half of the diagnosed bags named goes into the
params file at its population mean, its predictive variance on the diagonal of ``effect_covariance``.
"""
from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

from guide_health.analysis.discrepancy.model_file import EFFECT_PARAMETERS, MATERIAL_EFFECTS
from guide_health.errors import InputError
from guide_health.io.bag.metadata import one_line
from guide_health.io.outputs.files import write_text
from guide_health.io.outputs.json_text import number
from guide_health.models.fleet import (
    combine_estimates,
    likelihood_from_posterior,
    random_effects_fit,
    wear_coefficient_prior,
)
from guide_health.models.wear.calibration import z90_for_measurements
from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

PRIOR_SECTION = "/**/wear_monitor"          # rcl applies it to a wear_monitor in any namespace


def load_fleet_results(paths: list[str]) -> list[dict[str, Any]]:
    """The bag entries of ``fleet.json`` files (or their directories), each with the run's summary. The
    files are strict JSON: a null number is read with io/json_text.number (inf for a bound or standard error)."""
    entries = []
    for text in paths:
        path = Path(text)
        path = path / "fleet.json" if path.is_dir() else path
        try:
            data = json.loads(path.read_text())
            summary, bags = data["summary"], data["bags"]
            missing = [k for k in ("command", "machine_type", "prior") if k not in summary]
            if missing or not isinstance(bags, list):
                raise KeyError(f"summary without {', '.join(missing)}" if missing else "bags")
        except FileNotFoundError:
            raise InputError(f"fleet results not found: {path}") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{path}: not a fleet.json of `guide-health fleet replay|diagnose` "
                             f"({one_line(exc)}); run it again") from None
        entries += [dict(e, summary=summary) for e in bags if e.get("ok")]
    return entries


def bag_log_k(entry: dict[str, Any]) -> tuple[float, float]:
    """(log K, its standard error) of one bag from its data alone; (nan, inf) without information."""
    r = entry["result"]
    if entry["summary"]["command"] == "diagnose":
        k, se = number(r["final"]["wear_coefficient"]), number(r["final"]["wear_coefficient_std_error"], math.inf)
    else:
        n = int(r["measurements"])
        if n == 0:
            return math.nan, math.inf
        z = z90_for_measurements(n)                      # the z of the replay's K interval
        sd_post = (number(r["wear_coefficient_high"], math.inf) - number(r["wear_coefficient_low"])) / (2.0 * z)
        prior = entry["summary"]["prior"]
        k, se = likelihood_from_posterior(number(r["wear_coefficient"]), sd_post, prior["wear_coefficient"],
                                          prior["wear_coefficient_prior_rel_sd"] * prior["wear_coefficient"])
    if not (math.isfinite(k) and k > 0 and math.isfinite(se)):
        return math.nan, math.inf
    return math.log(k), se / k                                            # delta method: sd(log K) = sd(K)/K


def fleet_prior(entries: list[dict[str, Any]], machine_type: str | None, min_machines: int = 3) -> dict[str, Any]:
    """The population of log K (and of named effects' parameters) of ``machine_type``'s machines."""
    types = sorted({e["summary"].get("machine_type", "") for e in entries})
    if machine_type is None:
        if len(types) != 1:
            raise InputError(f"the results hold machine types {types}: choose one with --machine-type")
        machine_type = types[0]
    if not machine_type:
        raise InputError("machine type is empty: a fleet prior belongs to a machine type; set machine_type in "
                         "the machines' params files and run fleet replay|diagnose again")
    chosen = [e for e in entries if e["summary"].get("machine_type", "") == machine_type]
    per_machine: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for e in chosen:
        per_machine[e["machine"]].append(bag_log_k(e))
    machines = {m: combine_estimates([v for v, _ in est], [s for _, s in est]) for m, est in per_machine.items()}
    usable = {m: v for m, v in machines.items() if math.isfinite(v[0])}
    if len(usable) < min_machines:
        raise InputError(f"machine type '{machine_type}': {len(usable)} machines with a K estimate "
                         f"(of {len(machines)}); the fleet prior needs at least {min_machines}")
    fit = random_effects_fit([v for v, _ in usable.values()], [s for _, s in usable.values()])
    k0, rel_sd = wear_coefficient_prior(fit)
    return {"machine_type": machine_type, "machines": len(usable), "bags": len(chosen),
            "log_k": {"mean": fit.mean, "tau": fit.tau, "mean_std_error": fit.mean_std_error,
                      "predictive_sd": fit.predictive_sd},
            "wear_coefficient_median": math.exp(fit.mean), "wear_coefficient": k0,
            "wear_coefficient_prior_rel_sd": rel_sd,
            "per_machine": {m: {"wear_coefficient": math.exp(v), "log_k_std_error": s} for m, (v, s) in usable.items()},
            "effects": effect_populations(chosen)}


def effect_populations(entries: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per named effect parameter (diagnose), the population mean, tau and predictive sd over the machines
    that named it (at least 2)."""
    values: dict[str, list[tuple[float, float]]] = defaultdict(list)
    diagnosed = [e for e in entries if e["summary"]["command"] == "diagnose"]
    for e in diagnosed:
        for effect, spec in e["result"].get("effects", {}).items():
            for name, p in spec["parameters"].items():
                values[f"{effect}.{name}"].append((number(p["value"]), number(p["std_error"], math.inf)))
    out = {}
    for key, pairs in values.items():
        try:
            fit = random_effects_fit([v for v, _ in pairs], [s for _, s in pairs])
        except ValueError:
            continue
        out[key] = {"mean": fit.mean, "tau": fit.tau, "predictive_sd": fit.predictive_sd, "machines": fit.machines,
                    "of_bags": len(diagnosed)}
    return out


def live_effect_parameters(effects: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """wear_monitor parameters of the effects the live model integrates that at least half of the diagnosed
    bags named (every parameter with a population): ``effects``, each parameter at its population mean and
    ``effect_covariance`` with the predictive variances on the diagonal (K's entry 0: the K prior covers K).
    {} when none qualifies."""
    chosen = [e for e, names in EFFECT_PARAMETERS.items() if e in MATERIAL_EFFECTS
              and all(f"{e}.{n}" in effects and 2 * effects[f"{e}.{n}"]["machines"] >= effects[f"{e}.{n}"]["of_bags"]
                     for n in names)]
    if not chosen:
        return {}
    out: dict[str, Any] = {"effects": ",".join(chosen)}
    cov = [0.0] * len(COVARIANCE_NAMES) ** 2
    for e in chosen:
        for n in EFFECT_PARAMETERS[e]:
            pop = effects[f"{e}.{n}"]
            out[n] = float(f"{pop['mean']:.6g}")
            i = COVARIANCE_NAMES.index(n)
            cov[i * len(COVARIANCE_NAMES) + i] = float(f"{pop['predictive_sd'] ** 2:.6g}")
    out["effect_covariance"] = cov
    return out


def write_prior_params(path: Path, prior: dict[str, Any]) -> None:
    """A ROS 2 params file of the prior keys only: its ``/**/wear_monitor`` section (applied in any
    namespace) holds machine_type, wear_coefficient, wear_coefficient_prior_rel_sd and the named live
    effects, nothing of a machine's identity or geometry, so loaded after a new machine's own file it
    changes only the prior. Commented with the fit."""
    import yaml

    section = {"machine_type": prior["machine_type"], "wear_coefficient": float(f"{prior['wear_coefficient']:.6g}"),
               "wear_coefficient_prior_rel_sd": float(f"{prior['wear_coefficient_prior_rel_sd']:.4g}"),
               **live_effect_parameters(prior["effects"])}
    data = {PRIOR_SECTION: {"ros__parameters": section}}
    lk = prior["log_k"]
    header = [f"# fleet prior of machine type '{prior['machine_type']}' (guide-health fleet prior): "
              f"{prior['machines']} machines, {prior['bags']} bags",
              f"# log K ~ N(mu = {lk['mean']:.4f}, tau = {lk['tau']:.4f}); se(mu) = {lk['mean_std_error']:.4f}; "
              f"median K = {prior['wear_coefficient_median']:.4g}",
              "# wear_coefficient / wear_coefficient_prior_rel_sd: mean and relative sd of the lognormal predictive"]
    header += [f"# effect {k}: mean {v['mean']:.4g}, tau {v['tau']:.3g}, predictive sd {v['predictive_sd']:.3g} "
               f"({v['machines']} machines)" for k, v in prior["effects"].items()]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, "\n".join(header) + "\n" + yaml.safe_dump(data, sort_keys=False))
