"""Calibration of the remaining-life interval with a model file, per running-in form (docs/discrepancy.md).

    .venv/bin/python bench/life_calibration.py [--seeds 30] [--rate 5] [--forms exponential,linear,...] [--workers 2]
        [--cache FILE.json [--cached-only]] [--write-docs]

For each form and seed: seed 000's bench (config/bench_000.yaml, 20 h) with a running-in hidden, its truth
written by the independent writer of test/test_model_file.py (``running_in_of_form``: the effective sliding
distance in closed form, no package function; ``exponential`` is the library's form, through the simulator
with ``--effect running_in=2.5``), diagnosed on its 20 h, replayed with the model file, and the 90 % interval
of the remaining life compared with the true life. ``linear``, ``stretched_exponential``, ``power_law`` ((1 +
s/s0)^-0.5, between two of the fitted exponents) and ``two_stage`` (two exponentials) are shapes the workflow does
not fit with (it fits the exponential and the power laws p = 2, 1, 2/3, 1/3: models/wear/form_average.py).
Prints per run, then per form: seeds, covered (with the 95 % Clopper-Pearson
interval of the coverage), median interval width (relative to the life), median |ln(life / truth)|, what was
named, and from the same runs the coverage of the carried model's interval alone and of the mixture joined with it
(the union: [min of the lows, max of the highs]). Nominal 90 %: accepted 83-96 %. ``--cache``: rows already
computed (same form, seed and rate) are read from the file and new ones added; ``--write-docs``: the table into
docs/discrepancy.md between its markers.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import multiprocessing as mp
import statistics
import sys
from collections import Counter
from pathlib import Path

from scipy.stats import beta

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test"))

FORMS = ("exponential", "linear", "stretched_exponential", "power_law", "two_stage")
MARKERS = ("<!-- life calibration table: bench/life_calibration.py -->", "<!-- end of the life calibration table -->")


def one_run(args: tuple[str, int, float]) -> dict:
    import test_model_file as t

    from guide_health.models.wear.planning import life_interval

    form, seed, rate_hz = args
    if form == "exponential":
        params, run = t.bench_running_in(seed, rate_hz=rate_hz)
        truth_h = t.true_remaining_life_h(run, params["straightness_limit_m"])
    else:
        params, run, truth_h = t.running_in_of_form(form, seed, rate_hz)
    cells = t.duty_cells_from_runs(run, params["slider_length_m"],
                                   limits=t.InputLimits.from_params(t.wear_axis_params(params)),
                                   sliding_deadband_m=params["sliding_deadband_m"])
    result = t.diagnose_cells(cells, params)
    model = result["model_file"]
    monitor = t.PrecisionMonitor(t.wear_axis_params({**params, **model}))
    monitor.process_run(run)
    report = monitor.report()
    life = tuple(report[k] for k in ("remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"))
    # the carried model's interval alone: the same replay's life inputs without the forms
    named_only = tuple(x / 3600.0 for x in life_interval(dataclasses.replace(monitor.axis.life_inputs("guide"),
                                                                               forms=None)))
    return {"form": form, "seed": seed, "rate_hz": rate_hz, "named": result["named_effects"],
            "status": {e: c["status"] for e, c in result["consistency"].items()},
            "alternatives": {e: {a["form"]: a["delta_bic"] for a in c["alternatives"]}
                             for e, c in result["consistency"].items()},
            "model_effects": result["model_file_effects"], "truth_h": truth_h, "life": list(life),
            "named_only": list(named_only),
            "flag": bool(result["unexplained_structure"]["present"]),
            "weights": result["model_file"].get("life_form_weights"),
            "offsets": result["model_file"].get("life_form_ln_life_offsets"),
            "sd_ratios": result["model_file"].get("life_form_ln_life_sd_ratios"),
            "interval": result["model_file"].get("life_form_interval", "mixture")}


def covers(interval, truth: float) -> bool:
    return interval[1] <= truth <= interval[2]


def union(r: dict) -> tuple[float, float, float]:
    """The mixture's interval joined with the carried model's alone."""
    return r["life"][0], min(r["life"][1], r["named_only"][1]), max(r["life"][2], r["named_only"][2])


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    """The exact 95 % interval of a binomial proportion k / n."""
    return (float(beta.ppf(0.025, k, n - k + 1)) if k > 0 else 0.0,
            float(beta.ppf(0.975, k + 1, n - k)) if k < n else 1.0)


def _names(mine: list[dict], key: str = "named") -> str:
    """How often each effect set was named (or carried by the model file), e.g. "running_in 25, wear_rate_change 5"."""
    count = Counter(" + ".join(r[key]) or "none" for r in mine)
    return ", ".join(f"{k} {v}" for k, v in count.most_common())


def table(rows: list[dict]) -> list[str]:
    out = ["| running-in form | seeds | covered | coverage (95 % CI) | median width / life "
           "| median abs ln(life / truth) | named | model file carries | flagged | carried model alone "
           "| joined with the carried model's |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for form in dict.fromkeys(r["form"] for r in rows):
        mine = [r for r in rows if r["form"] == form]
        n = len(mine)
        hit = sum(covers(r["life"], r["truth_h"]) for r in mine)
        low, high = clopper_pearson(hit, n)
        width = statistics.median((r["life"][2] - r["life"][1]) / r["life"][0] for r in mine)
        err = statistics.median(abs(math.log(r["life"][0] / r["truth_h"])) for r in mine)
        alone = sum(covers(r["named_only"], r["truth_h"]) for r in mine)
        joined = sum(covers(union(r), r["truth_h"]) for r in mine)
        out.append(f"| {form}{' (library)' if form == FORMS[0] else ' (not fitted)'} | {n} | {hit} | "
                   f"{hit / n:.0%} ({low:.0%}-{high:.0%}) | {width:.3f} | {err:.3f} | {_names(mine)} | "
                   f"{_names(mine, 'model_effects')} | "
                   f"{sum(r['flag'] for r in mine)} | {alone} ({alone / n:.0%}) | {joined} ({joined / n:.0%}) |")
    return out


def write_docs(lines: list[str]) -> None:
    doc = ROOT / "docs" / "discrepancy.md"
    text = doc.read_text()
    start, end = text.index(MARKERS[0]) + len(MARKERS[0]), text.index(MARKERS[1])
    doc.write_text(text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--first-seed", type=int, default=100)
    ap.add_argument("--rate", type=float, default=5.0, help="joint_states rate [Hz]")
    ap.add_argument("--forms", default=",".join(FORMS[:3]), help=f"of {', '.join(FORMS)}")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", type=Path, help="JSON rows: read, and each new run added")
    ap.add_argument("--write-docs", action="store_true")
    ap.add_argument("--cached-only", action="store_true", help="the table of the cache's rows, no new runs")
    a = ap.parse_args()
    cached = json.loads(a.cache.read_text()) if a.cache and a.cache.exists() else []
    done = {(r["form"], r["seed"], r["rate_hz"]): r for r in cached}
    # seed by seed over the forms: a run cut short still has as many seeds of each form
    jobs = [(form, seed, a.rate) for seed in range(a.first_seed, a.first_seed + a.seeds)
            for form in a.forms.split(",")]
    rows = [done[j] for j in jobs if j in done]
    with mp.get_context("spawn").Pool(a.workers) as pool:
        for r in pool.imap(one_run, [j for j in jobs if j not in done and not a.cached_only]):
            rows.append(r)
            if a.cache:
                cached.append(r)
                a.cache.write_text(json.dumps(cached))
            print(f"{r['form']} seed {r['seed']}: named {r['named']} {r['status']}{' FLAG' if r['flag'] else ''}, "
                  f"truth {r['truth_h']:.3f} h, life {r['life'][0]:.3f} [{r['life'][1]:.3f}, {r['life'][2]:.3f}] h, "
                  f"weights {r['weights']}, offsets {r['offsets']}", flush=True)
    rows.sort(key=lambda r: (FORMS.index(r["form"]) if r["form"] in FORMS else 99, r["seed"]))
    lines = table(rows)
    print("\n".join(lines))
    if a.write_docs:
        write_docs(lines)


if __name__ == "__main__":
    main()
