"""The effects added to the library in issue 15, each found on hidden data (>= 9/10 named, slow) whose truth
is written here, not with the package's terms: config/machine_jobs.yaml motion and load from the simulator,
straightness integrated sample by sample over the bag's JointState and load samples (zero-order hold):

- ``wear_rate_change``: K x f from t_c on (f 1.8..2.5, t_c 4..11 h of 20 h: contamination);
- ``lubrication_interval``: K (1 + a tau / T), tau the time since the last relubrication at 0, T, 2T, ...
  (T 6..9 h, a 1..2);
- ``load_along_rail``: the load W (1 + g x) at rail position x (g +-1.5..3 per m: a misaligned rail);
- ``thermal_drift`` with a reference temperature T_ref = T_0 + d (d +-2..5 K) other than the first
  measurement's: the fitted dT_ref recovers d, and no surrogate initial_offset is named.

The total wear is scaled to the plain Archard wear of the run. Noise 0.3 um.

And ``lubrication_interval`` with the relubrications recorded in the bag (``relubricate`` maintenance events
at irregular times): the bag is written with them and ``guide-health diagnose`` must use them as the time
base (m = 1 + b tau, tau the time since the last) and recover b.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
from case_pool import case_pool  # noqa: E402

JOBS = Path(__file__).resolve().parents[1] / "config" / "machine_jobs.yaml"
RATE_HZ = 10.0
HOURS = 30.0            # the experiments: 30 h at 10 Hz
NOISE_M = 0.3e-6


def draw(effect: str, rng: np.random.Generator) -> dict:
    if effect == "wear_rate_change":
        return {"t_c_h": rng.uniform(4.0, 11.0), "factor": rng.uniform(1.8, 2.5)}
    if effect == "lubrication_interval":
        return {"interval_h": rng.uniform(6.0, 9.0), "growth": rng.uniform(1.0, 2.0)}
    if effect == "load_along_rail":
        return {"gradient_per_m": float(rng.choice([-1.0, 1.0]) * rng.uniform(1.5, 3.0))}
    if effect == "thermal_drift":
        return {"c_m_per_k": float(rng.choice([-1.0, 1.0]) * rng.uniform(0.8e-6, 1.5e-6)),
                "d_k": float(rng.choice([-1.0, 1.0]) * rng.uniform(2.0, 5.0))}
    return {}


def hidden_truth(run, effect: str, h: dict, params: dict, stroke_sum_m: float) -> np.ndarray:
    """Noise-free straightness [m] at the measurement stamps (this file's own integration)."""
    t_ns = np.asarray(run.joint_t_ns, dtype=np.int64)
    t_h = (t_ns - t_ns[0]) * 1e-9 / 3600.0
    x = np.asarray(run.joint_position_m, dtype=float)
    ds = np.abs(np.diff(x))
    held = np.searchsorted(run.load_t_ns, t_ns[1:], side="right") - 1
    load = np.where(held >= 0, np.asarray(run.load_n)[np.clip(held, 0, None)], 0.0)
    plain = load * ds
    t_mid = 0.5 * (t_h[1:] + t_h[:-1])
    if effect == "wear_rate_change":
        work = plain * np.where(t_mid >= h["t_c_h"], h["factor"], 1.0)
    elif effect == "lubrication_interval":
        since = t_mid - h["interval_h"] * np.floor(t_mid / h["interval_h"])
        work = plain * (1.0 + h["growth"] * since / h["interval_h"])
    elif effect == "load_along_rail":
        work = plain * (1.0 + h["gradient_per_m"] * 0.5 * (x[1:] + x[:-1]))
    else:
        work = plain
    work = work * plain.sum() / work.sum()
    g = np.concatenate(([0.0], np.cumsum(work)))
    at_h = (np.asarray(run.straightness_t_ns, dtype=np.int64) - t_ns[0]) * 1e-9 / 3600.0
    y = params["straightness_initial_m"] + params["wear_coefficient"] / (
        params["hardness_pa"] * params["contact_width_m"]) * 2.0 * np.interp(at_h, t_h, g) / stroke_sum_m
    if effect == "thermal_drift":
        temp = np.interp(np.asarray(run.straightness_t_ns, dtype=float), np.asarray(run.temperature_t_ns, float),
                         run.temperature_c)
        y = y + h["c_m_per_k"] * (temp - (temp[0] + h["d_k"]))
    return y


def case(args):
    effect, seed = args
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=HOURS, joint_state_rate_hz=RATE_HZ, load_rate_hz=RATE_HZ)
    run = simulate_machine(params, sim, seed=seed)
    h = draw(effect, np.random.default_rng(700 + seed))
    truth = run.metadata["truth"]
    y = hidden_truth(run, effect, h, params, truth["stroke_min_m"] + truth["stroke_max_m"])
    run.straightness_m = y + np.random.default_rng(900 + seed).normal(0.0, NOISE_M, y.size)
    result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
    values = {k: p["value"] for e in result["named_effects"] for k, p in result["effects"][e]["parameters"].items()}
    return {"effect": effect, "seed": seed, "hidden": h, "named": result["named_effects"], "values": values,
            "flag": result["unexplained_structure"]["present"],
            "heldout_ratio": result["gap"]["heldout_rmse_ratio"]}


def run_cases(effects, seeds):
    with case_pool() as pool:
        rows = pool.map(case, [(e, s) for e in effects for s in seeds])
    for r in rows:
        print(f"{r['effect']} seed {r['seed']}: named {r['named']} flag {r['flag']} "
              f"held-out ratio {r['heldout_ratio']:.2f} {r['hidden']} -> "
              + ", ".join(f"{k} {v:.4g}" for k, v in r["values"].items()))
    return rows


def check_parameters(r):
    """The named effect's parameters are the hidden ones (tolerances: physics, not a curve)."""
    v, h = r["values"], r["hidden"]
    if r["effect"] == "wear_rate_change":
        assert abs(v["wear_rate_change_time_s"] / 3600.0 - h["t_c_h"]) < 0.5, r
        assert v["wear_rate_change_factor"] == pytest.approx(h["factor"], rel=0.15), r
    elif r["effect"] == "lubrication_interval":
        assert v["lubrication_interval_s"] / 3600.0 == pytest.approx(h["interval_h"], rel=0.05), r
    elif r["effect"] == "load_along_rail":
        assert math.copysign(1.0, v["load_gradient_per_m"]) == math.copysign(1.0, h["gradient_per_m"]), r
    elif r["effect"] == "thermal_drift":
        assert v["thermal_reference_offset_k"] == pytest.approx(h["d_k"], abs=1.0), r
        assert "initial_offset" not in r["named"], r


EFFECTS = ["wear_rate_change", "lubrication_interval", "load_along_rail", "thermal_drift"]


def test_new_effects_default():
    """Default suite: seed 0 of each new effect is named, with its hidden parameters."""
    for r in run_cases(EFFECTS, [0]):
        assert r["effect"] in r["named"], r
        check_parameters(r)


@pytest.mark.slow
def test_new_effects_named_in_9_of_10():
    """Measured 2026-11-23 (30 h, 10 Hz): wear_rate_change 10/10, lubrication_interval 10/10 (often with a
    second effect; seed 2 alone at twice the interval, flagged), load_along_rail 10/10, thermal_drift 10/10
    with dT_ref within 0.3 K. ~6 min."""
    rows = run_cases(EFFECTS, range(10))
    for effect in EFFECTS:
        mine = [r for r in rows if r["effect"] == effect]
        named = [r for r in mine if effect in r["named"]]
        assert len(named) >= 9, (effect, [r["named"] for r in mine])
        for r in named:
            if r["named"] == [effect] and not r["flag"]:     # explained by the effect alone
                check_parameters(r)


# --- lubrication_interval with the relubrications recorded in the bag (maintenance events) -----------------

def relube_case(seed: int, tmp: Path) -> dict:
    """machine_jobs (30 h, 5 Hz) relubricated at irregular times (gaps 2.5..8 h, drawn), wear K (1 + b tau),
    tau the time since the last relubrication (the record's start before the first), b 0.12..0.3 per hour;
    the times go into the bag as `relubricate` maintenance events; `guide-health diagnose` reads the bag."""
    import contextlib
    import io
    import json
    import warnings

    from guide_health.cli.app import main
    from guide_health.cli.simulate import event_series
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.models.wear.maintenance import MaintenanceEvent

    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=HOURS, joint_state_rate_hz=5.0, load_rate_hz=5.0)
    run = simulate_machine(params, sim, seed=seed)
    rng = np.random.default_rng(800 + seed)
    relube_h = np.cumsum(rng.uniform(2.5, 8.0, 12))
    relube_h = relube_h[relube_h < HOURS - 1.0]
    growth_per_h = float(rng.uniform(0.12, 0.3))
    t_ns = np.asarray(run.joint_t_ns, dtype=np.int64)
    t_h = (t_ns - t_ns[0]) * 1e-9 / 3600.0
    ds = np.abs(np.diff(np.asarray(run.joint_position_m, dtype=float)))
    held = np.searchsorted(run.load_t_ns, t_ns[1:], side="right") - 1
    load = np.where(held >= 0, np.asarray(run.load_n)[np.clip(held, 0, None)], 0.0)
    t_mid = 0.5 * (t_h[1:] + t_h[:-1])
    last = np.array([max([0.0] + [r for r in relube_h if r <= t]) for t in t_mid[::50]])   # every 50th: cheap
    tau_h = t_mid - np.repeat(last, 50)[:t_mid.size]
    work = load * ds * (1.0 + growth_per_h * tau_h)
    work = work * (load * ds).sum() / work.sum()
    g = np.concatenate(([0.0], np.cumsum(work)))
    stroke = run.metadata["truth"]["stroke_min_m"] + run.metadata["truth"]["stroke_max_m"]
    at_h = (np.asarray(run.straightness_t_ns, dtype=np.int64) - t_ns[0]) * 1e-9 / 3600.0
    y = params["straightness_initial_m"] + params["wear_coefficient"] / (
        params["hardness_pa"] * params["contact_width_m"]) * 2.0 * np.interp(at_h, t_h, g) / stroke
    run.straightness_m = y + np.random.default_rng(900 + seed).normal(0.0, NOISE_M, y.size)
    events = [MaintenanceEvent(int(t_ns[0] + round(h * 3600e9)), "relubricate", params["joint"], source="test")
              for h in relube_h]
    bag = tmp / f"relube_{seed}"
    write_machine_bag(run, bag, extra=event_series(events, params["machine_id"]))
    # `guide-health diagnose` through main() in this process (the command's exit codes and one-line errors are
    # test_discrepancy.py's): reading the bag's maintenance events is what this checks
    err, shown = io.StringIO(), warnings.showwarning       # main() sets its warning format: restored after
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            code = main(["diagnose", str(bag), "--params", str(JOBS), "--out", str(tmp / f"diag_{seed}"),
                         "--no-plot"])
        finally:
            warnings.showwarning = shown
    assert code == 0, err.getvalue()
    result = json.loads((tmp / f"diag_{seed}" / "report.json").read_text())
    values = {k: p["value"] for e in result["named_effects"] for k, p in result["effects"][e]["parameters"].items()}
    se = {k: p["std_error"] for e in result["named_effects"] for k, p in result["effects"][e]["parameters"].items()}
    return {"seed": seed, "relube_h": relube_h.round(2).tolist(), "growth_per_h": growth_per_h, "se": se,
            "named": result["named_effects"], "values": values, "recorded": result["data"]["relubrications_recorded"],
            "flag": result["unexplained_structure"]["present"]}


def check_relube(r: dict) -> None:
    """Named, with the recorded events as its time base, and the hidden law b recovered: within 3 of its
    standard errors and 20 % (measured over seeds 0-9: 0.91..1.14 x the hidden b, mean 1.02)."""
    assert r["recorded"] == len(r["relube_h"]), r
    assert "lubrication_interval" in r["named"], r
    assert "lubrication_interval_s" not in r["values"], r          # no interval fitted: the events are the times
    b_h = r["values"]["lubrication_wear_growth_per_s"] * 3600.0
    assert abs(b_h - r["growth_per_h"]) < 3.0 * r["se"]["lubrication_wear_growth_per_s"] * 3600.0, r
    assert b_h == pytest.approx(r["growth_per_h"], rel=0.20), r


def test_lubrication_from_recorded_relubrications(tmp_path):
    """Default suite: seed 0 (irregular relubrications at the drawn times) is named with its law."""
    r = relube_case(0, tmp_path)
    print(r)
    check_relube(r)


def _relube_case_in(args):
    seed, tmp = args
    return relube_case(seed, Path(tmp))


@pytest.mark.slow
def test_lubrication_from_recorded_relubrications_9_of_10(tmp_path):
    """Seeds 0-9: named with the recorded time base in >= 9/10, the law b within 3 se and 20 % when named alone
    (measured 2026-11-23: named alone 10/10, unflagged, b 0.91-1.14x the hidden one). ~4 min."""
    with case_pool() as pool:
        rows = pool.map(_relube_case_in, [(s, str(tmp_path)) for s in range(10)])
    for r in rows:
        print(r)
    named = [r for r in rows if "lubrication_interval" in r["named"]]
    assert len(named) >= 9, rows
    for r in named:
        if r["named"] == ["lubrication_interval"] and not r["flag"]:
            check_relube(r)
