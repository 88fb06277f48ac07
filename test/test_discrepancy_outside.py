"""Honest selection on physics outside the effect library (issue 15).

The truth of these runs is written here, independently of guide_health (no import of the effect terms):
the simulator's motion and load of config/machine_jobs.yaml, with the straightness integrated sample by
sample over the bag's JointState and load samples (zero-order hold of the load) under a wear law that no
candidate models:

- ``speed_squared``: wear rate proportional to W ds (v / v_ref)^2 (a wear rate growing with the square of
  the sliding speed, e.g. frictional heating), v_ref the run's median sample speed;
- ``position_sine``: wear rate proportional to W ds (1 + a sin(2 pi x / lambda)), a = 0.8, lambda = 0.2 m
  (a foundation whose stiffness varies along the rail);
- ``k_drift``: K rising linearly in time, by 80 % over the record (a lubricant slowly degrading).

All are scaled so that the run's total wear equals the plain Archard wear (the same straightness range).
Whiteness of the residuals after the fit is judged here by a Ljung-Box test over lags 1-3 (chi-square,
p < 0.01), written here: whenever it is not white, a named effect must come with the
``unexplained_structure`` flag; clean runs raise the flag in at most 1 of 10.

Measured 2026-11-23 (seeds 0-9, named / flagged / both): speed_squared 10 / 9 / 9 (the unflagged run has
Ljung-Box p = 0.053); position_sine 8 / 7 / 6 (before the held-out forecast check: 8 / 1 / 1; the two named
and unflagged have white residuals, Ljung-Box p 0.035 and 0.74, and forecast p 0.055 and 0.056: the wrong
effect absorbs the sine within the noise); k_drift 10 / 5 / 5 (before: 10 / 0 / 0; the unflagged have
Ljung-Box p >= 0.11); clean 0 / 0 / 0.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.report import write_report
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.cli.diagnose import format_text
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
from case_pool import case_pool  # noqa: E402

JOBS = Path(__file__).resolve().parents[1] / "config" / "machine_jobs.yaml"
RATE_HZ = 10.0
HOURS = 20.0


def ljung_box_p(residual: np.ndarray, lags: int = 3) -> float:
    """Ljung-Box Q = n (n + 2) sum_k r_k^2 / (n - k), chi-square with ``lags`` degrees of freedom."""
    r = residual - residual.mean()
    n = r.size
    denom = float(r @ r)
    q = n * (n + 2) * sum((float(r[k:] @ r[:-k]) / denom) ** 2 / (n - k) for k in range(1, lags + 1))
    return float(stats.chi2.sf(q, lags))


def outside_truth(run, law: str, params: dict, stroke_sum_m: float) -> np.ndarray:
    """Noise-free straightness [m] at the measurement stamps under a wear law outside the library."""
    t = np.asarray(run.joint_t_ns, dtype=np.int64)
    x = np.asarray(run.joint_position_m, dtype=float)
    ds = np.abs(np.diff(x))
    dt = np.diff(t) * 1e-9
    v = ds / dt
    held = np.searchsorted(run.load_t_ns, t[1:], side="right") - 1
    load = np.where(held >= 0, np.asarray(run.load_n)[np.clip(held, 0, None)], 0.0)
    plain = load * ds
    if law == "speed_squared":
        v_ref = float(np.median(v[v > 0]))
        work = plain * (v / v_ref) ** 2
    elif law == "position_sine":
        mid = 0.5 * (x[1:] + x[:-1])
        work = plain * (1.0 + 0.8 * np.sin(2.0 * math.pi * mid / 0.2))
    elif law == "k_drift":
        t_mid = 0.5 * (t[1:] + t[:-1]) - t[0]
        work = plain * (1.0 + 0.8 * t_mid / (t[-1] - t[0]))
    else:
        work = plain
    work = work * plain.sum() / work.sum()
    g = np.concatenate(([0.0], np.cumsum(work)))
    at = (np.asarray(run.straightness_t_ns, dtype=np.int64) - t[0]) * 1e-9
    g_at = np.interp(at, (t - t[0]) * 1e-9, g)
    k = params["wear_coefficient"]
    return params["straightness_initial_m"] + k / (params["hardness_pa"] * params["contact_width_m"]) * 2.0 * g_at \
        / stroke_sum_m


def outside_diagnosis(law: str, seed: int) -> dict:
    """diagnose_cells of a run (``seed``: motion and noise of 0.3 um) whose straightness follows ``law``."""
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=HOURS, joint_state_rate_hz=RATE_HZ, load_rate_hz=RATE_HZ)
    run = simulate_machine(params, sim, seed=seed)
    truth = run.metadata["truth"]
    noise = np.random.default_rng(500 + seed).normal(0.0, 0.3e-6, run.straightness_m.size)
    run.straightness_m = outside_truth(run, law, params, truth["stroke_min_m"] + truth["stroke_max_m"]) + noise
    return diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)


def outside_case(args):
    law, seed = args
    result = outside_diagnosis(law, seed)
    s = result["series"]
    fit = ~np.asarray(s["heldout"], dtype=bool)
    residual = (np.asarray(s["measured_um"]) - np.asarray(s["final_um"]))
    return {"law": law, "seed": seed, "named": result["named_effects"],
            "flag": result["unexplained_structure"]["present"], "explained": result["explained"],
            "forecast_p": result["residuals_after"]["heldout_forecast"].get("p_value", math.nan),
            "white_p": ljung_box_p(residual[fit]), "result": {k: v for k, v in result.items() if k != "series"}
            if seed == 0 else None}


def run_cases(cases):
    with case_pool() as pool:
        rows = pool.map(outside_case, cases)
    for r in rows:
        print(f"{r['law'] or 'clean'} seed {r['seed']}: named {r['named']}, flag {r['flag']}, "
              f"Ljung-Box p {r['white_p']:.2g}, held-out forecast p {r['forecast_p']:.2g}")
    for law in dict.fromkeys(r["law"] for r in rows):
        mine = [r for r in rows if r["law"] == law]
        print(f"{law or 'clean'}: named {sum(bool(r['named']) for r in mine)} / flagged "
              f"{sum(r['flag'] for r in mine)} / both {sum(bool(r['named']) and r['flag'] for r in mine)} "
              f"of {len(mine)}")
    return rows


def check_honesty(rows):
    for r in rows:
        if r["named"] and r["white_p"] < 0.01:
            assert r["flag"] and not r["explained"], r
        if r["flag"]:
            assert not r["explained"]


def test_outside_the_library_default():
    """Default suite (~20 s): no named effect without the flag when the residuals are not white (Ljung-Box
    here). Speed squared seed 1: a wrong name, flagged by the time-order tests; position sine seed 3: a wrong
    name with white residuals (Ljung-Box p 0.11), flagged only by the held-out forecast's drift (p ~ 1e-17);
    the clean run (seed 1, whose held-out noise happens to be 1.6x the fit span's: no drift) is not flagged."""
    rows = run_cases([("speed_squared", 1), ("position_sine", 3), ("", 1)])
    check_honesty([r for r in rows if r["law"]])
    assert rows[0]["named"] and rows[0]["flag"]
    assert rows[1]["named"] and rows[1]["flag"] and rows[1]["white_p"] > 0.01 and rows[1]["forecast_p"] < 1e-6
    assert not rows[2]["flag"]


@pytest.mark.slow
def test_outside_the_library_and_clean_controls_10_seeds():
    laws = ["speed_squared", "position_sine", "k_drift", ""]
    rows = run_cases([(law, seed) for law in laws for seed in range(10)])
    check_honesty([r for r in rows if r["law"]])
    clean = [r for r in rows if not r["law"]]
    assert sum(r["flag"] for r in clean) <= 1
    # the held-out forecast check flags the wrong names that absorb the sine on the fit span (measured 7/10)
    assert sum(r["flag"] for r in rows if r["law"] == "position_sine") >= 6


def test_flag_comes_first_in_every_output(tmp_path):
    """A speed-squared run flagged (seed 0, its noise included): the text summary's first line, report.md's
    first paragraph, the JSON's first key and the PNG title carry it."""
    full = outside_diagnosis("speed_squared", 0)
    assert full["unexplained_structure"]["present"], "seed 0 of speed_squared is flagged (measured)"
    params = wear_monitor_params(JOBS)
    files = write_report(full, tmp_path, bag="speed_squared", with_plot=False)
    md = (tmp_path / "report.md").read_text().splitlines()
    assert md[2].startswith("> **UNEXPLAINED STRUCTURE")
    live = md.index("## The live model (model.yaml)")
    if full["model_file"]["effects"]:
        assert "fitted, not an explanation" in " ".join(md[live:live + 6])
    from guide_health.analysis.discrepancy.model_file import write_model_file
    write_model_file(tmp_path / "model.yaml", params, full["model_file"], full["named_effects"], source="bag",
                     unexplained=full["unexplained_structure"]["message"])
    head = (tmp_path / "model.yaml").read_text().splitlines()
    assert head[0].startswith("# UNEXPLAINED STRUCTURE") and "fitted, not an explanation" in head[1]
    body = json.loads((tmp_path / "report.json").read_text())
    assert next(iter(body)) == "unexplained_structure" and body["explained"] is False
    full.update(messages=0, read_s=0.0, files=files)
    assert format_text(full).splitlines()[0].startswith("UNEXPLAINED STRUCTURE")
