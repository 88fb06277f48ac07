"""Power and false-flag rate of the unexplained-structure flag (docs/discrepancy.md, "The flag's power").

    .venv/bin/python bench/flag_power.py [--seeds 5] [--clean-seeds 20] [--hours 30] [--workers 2] [--write-docs]

Clean runs of two motions of config/machine_jobs.yaml (``jobs``: the simulator's constant-speed strokes at
10 Hz; ``s_curve``: jerk-limited moves, params/simulation.py REALISTIC_MOTION, at 20 Hz without encoder noise)
get structures of 0.5, 1 and 2 um of four shapes (ramp and periodic in clock time, position-dependent, step)
from the independent writer test/independent_structure.py (plain Archard truth of test/reference_wear.py, noise
0.3 um), and each run goes through the workflow's entry over duty cells (duty_cells_from_runs ->
diagnose_cells: the same selection and flag as ``guide-health diagnose BAG``, without the bag's I/O).
Prints per run, then per shape x amplitude the detection rate (flag raised) and how often an effect was named
without the flag, the false-flag rate on the clean runs, and the flag's statistic (the smallest of its tests'
p-values, analysis.flag_statistic) at several levels: the level FLAG_ALPHA is the largest of those whose
false-flag rate on the clean runs is <= 5 %. ``--write-docs`` puts the tables into docs/discrepancy.md
between its flag-power markers.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test"))

AMPLITUDES_M = (0.5e-6, 1e-6, 2e-6)
MOTIONS = ("jobs", "s_curve")
LEVELS = (0.01, 0.003, 0.001)
NOISE_M = 0.3e-6
ROW = "row "
MARKERS = ("<!-- flag power table: bench/flag_power.py --write-docs -->", "<!-- end of the flag power table -->")


def simulated(motion: str, seed: int, hours: float):
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.params.simulation import REALISTIC_MOTION
    from guide_health.sim.machine import simulate_machine

    jobs = ROOT / "config" / "machine_jobs.yaml"
    params = wear_monitor_params(jobs)
    sim = dict(simulation_params(jobs), duration_h=hours, joint_state_rate_hz=10.0, load_rate_hz=10.0)
    if motion == "s_curve":
        sim.update(REALISTIC_MOTION, joint_state_rate_hz=20.0, load_rate_hz=10.0, encoder_noise_m=0.0)
    return params, simulate_machine(params, sim, seed=seed)


def one_run(args: tuple[str, str, float, int, float]) -> dict:
    import independent_structure as gen

    from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
    from guide_health.analysis.discrepancy.workflow import diagnose_cells

    motion, shape, amplitude_m, seed, hours = args
    params, run = simulated(motion, seed, hours)
    truth = run.metadata["truth"]
    run.straightness_m = gen.measured_m(run, params, truth["stroke_min_m"] + truth["stroke_max_m"], shape,
                                        amplitude_m, NOISE_M, seed)
    cells = duty_cells_from_runs(run, params["slider_length_m"], sliding_deadband_m=params["sliding_deadband_m"])
    res = diagnose_cells(cells, params)
    s = res["unexplained_structure"]
    oracle = (res["final"]["bic"] - oracle_bic(cells, params, gen.structure_m(shape, 1.0, run))) if shape else None
    return {"motion": motion, "shape": shape, "amplitude_um": amplitude_m * 1e6, "seed": seed,
            "named": res["named_effects"], "flag": s["present"], "min_p": s["statistic"]["min_p"],
            "outside": sorted(s.get("outside_library", {})), "oracle_dbic": oracle,
            "tests": {k: v for k, v in s["statistic"].items() if k != "min_p"}}


def oracle_bic(cells, params: dict, form_m_per_m) -> float:
    """BIC of a fit that knows the hidden structure's true form: the wear of K (linear in K) + a x the writer's
    form at unit amplitude (a free), + the response to A0 where the workflow frees A0; on the workflow's fit span
    and in its convention (n ln(RSS/n) + k ln n, RSS in um^2). The workflow's final BIC minus this is how well
    the data could tell the true form from the named model (>= BIC_THRESHOLD: as well as the workflow needs to
    name an effect). The columns are the model's own responses (predict_m at two values), so no fit is run."""
    import math

    import numpy as np

    from guide_health.analysis.discrepancy.model import WearProblem

    problem = WearProblem(cells, params)
    fit = problem.fit_mask
    k0 = float(params["wear_coefficient"])
    at = {"wear_coefficient": k0, **({"straightness_initial_m": 0.0} if problem.a0_free else {})}
    p1 = problem.predict_m(at)
    per_k0 = problem.predict_m({**at, "wear_coefficient": 2.0 * k0}) - p1          # the wear of K0
    columns = [per_k0[fit], np.asarray(form_m_per_m, dtype=float)[fit]]
    if problem.a0_free:                                                             # the response to 1 um of A0
        columns.append((problem.predict_m({**at, "straightness_initial_m": 1e-6}) - p1)[fit])
    x = np.column_stack(columns)
    y = problem.y_m[fit] - (p1 - per_k0)[fit]
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    r_um = (x @ coef - y) * 1e6
    n, k = x.shape
    return n * math.log(float(r_um @ r_um) / n) + k * math.log(n)


def flagged_at(r: dict, level: float) -> bool:
    """The flag at ``level``: its statistic below it, or a named effect found to absorb structure outside the
    library (consistency.outside_library: a decision at AMBIGUOUS_BIC, whatever the level)."""
    return r["min_p"] < level or bool(r.get("outside"))


def upper_bound_95(k: int, n: int) -> float:
    """The one-sided 95 % Clopper-Pearson upper bound of a rate seen k times in n (0 of n: 1 - 0.05^(1/n))."""
    from scipy import special
    return 1.0 if k >= n else float(special.betaincinv(k + 1, n - k, 0.95))


def tables(rows: list[dict], alpha: float) -> list[str]:
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD

    out = ["| shape | amplitude [um] | runs | flagged | named without the flag | of those, the true form "
           f"better by >= {BIC_THRESHOLD:g} in BIC |", "|---|---|---|---|---|---|"]
    for shape in dict.fromkeys(r["shape"] for r in rows if r["shape"]):
        for amp in sorted({r["amplitude_um"] for r in rows if r["shape"] == shape}):
            mine = [r for r in rows if r["shape"] == shape and r["amplitude_um"] == amp]
            flagged = sum(flagged_at(r, alpha) for r in mine)
            silent = [r for r in mine if r["named"] and not flagged_at(r, alpha)]
            separable = [r for r in silent if (r.get("oracle_dbic") or 0.0) >= BIC_THRESHOLD]
            margins = ", ".join(f"{r['oracle_dbic']:+.1f}" for r in silent if r.get("oracle_dbic") is not None)
            out.append(f"| {shape} | {amp:g} | {len(mine)} | {flagged} ({flagged / len(mine):.0%}) | {len(silent)}"
                       f"{f' (dBIC {margins})' if margins else ''} | {len(separable)} |")
    clean = [r for r in rows if not r["shape"]]
    if clean:
        flagged = sum(flagged_at(r, alpha) for r in clean)
        named = sum(bool(r["named"]) for r in clean)
        out.append(f"| clean | 0 | {len(clean)} | {flagged} ({flagged / len(clean):.0%}): the false-flag rate, "
                   f"95 % upper bound {upper_bound_95(flagged, len(clean)):.1%} | {named} named |")
    out += ["", "| level of the flag's statistic | false flags (clean) | detected (all structured runs) |",
            "|---|---|---|"]
    structured = [r for r in rows if r["shape"]]
    for level in LEVELS:
        ff = sum(flagged_at(r, level) for r in clean)
        det = sum(flagged_at(r, level) for r in structured)
        out.append(f"| {level:g} | {ff} of {len(clean)} ({ff / max(len(clean), 1):.0%}) | {det} of "
                   f"{len(structured)} ({det / max(len(structured), 1):.0%}) |")
    return out


def chosen_level(rows: list[dict]) -> float:
    """The largest level whose false-flag rate on the clean runs is <= 5 %."""
    clean = [r for r in rows if not r["shape"]]
    ok = [lv for lv in LEVELS if sum(flagged_at(r, lv) for r in clean) <= 0.05 * len(clean)]
    return max(ok) if ok else min(LEVELS)


def write_docs(lines: list[str]) -> None:
    doc = ROOT / "docs" / "discrepancy.md"
    text = doc.read_text()
    start, end = text.index(MARKERS[0]) + len(MARKERS[0]), text.index(MARKERS[1])
    doc.write_text(text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:])


def main() -> None:
    from guide_health.analysis.discrepancy.analysis import FLAG_ALPHA

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds per motion, shape and amplitude")
    ap.add_argument("--clean-seeds", type=int, default=20, help="clean runs per motion")
    ap.add_argument("--hours", type=float, default=30.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--write-docs", action="store_true")
    ap.add_argument("--from-log", help="the tables from the rows a run printed (stopped early or finished)")
    a = ap.parse_args()
    import independent_structure as gen

    # each motion its own seeds (its own jobs, loads and noise draws): the runs are independent; seeds outermost,
    # so that a run stopped early (--from-log) still has every shape, amplitude and motion
    jobs = []
    for s in range(max(a.seeds, a.clean_seeds)):
        for i, m in enumerate(MOTIONS):
            if s < a.clean_seeds:
                jobs.append((m, "", 0.0, 200 + 1000 * i + s, a.hours))
            if s < a.seeds:
                jobs += [(m, shape, amp, 300 + 1000 * i + s, a.hours) for shape in gen.SHAPES for amp in AMPLITUDES_M]
    if a.from_log:
        rows = [json.loads(line[len(ROW):]) for line in Path(a.from_log).read_text().splitlines()
                if line.startswith(ROW)]
    else:
        rows = []
        with mp.get_context("spawn").Pool(a.workers) as pool:
            for r in pool.imap_unordered(one_run, jobs):
                rows.append(r)
                print(ROW + json.dumps(r), flush=True)
    level = chosen_level(rows)
    lines = [f"Measured with `bench/flag_power.py --hours {a.hours:g}` ({len(rows)} runs of the {len(MOTIONS)} "
             f"motions, seeds {sorted({r['seed'] for r in rows})[0]}.., noise {NOISE_M * 1e6:g} um, a measurement "
             f"every 10 min), at the flag's level {FLAG_ALPHA:g}:", ""] + tables(rows, FLAG_ALPHA)
    lines += ["", f"The largest level with <= 5 % false flags on these clean runs: {level:g}."]
    print("\n".join(lines))
    if a.write_docs:
        write_docs(lines)


if __name__ == "__main__":
    main()
