"""stroke_distribution live (issue 15: the live model integrates every effect diagnose names).

The straightness of a worn guide is A0 + K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] (models/wear/effects.py
straightness_wear_m): G the effective work, P the work of each pass over max(pass length, slider length),
w the weight. Live, EffectWear keeps P pass by pass (a pass ends at a change of direction; the open pass counts
with its length so far), the duty window's pass work for the rate, and P at each measurement for the K update.
Its integration is checked against test/reference_wear.py (shares no function with the package) in
test_model_file.py, the per-sample path against the vectorised one there too, the state in test_state_store.py.

Here: hidden data. machine_jobs (jobs of about 3 h, each with its own stroke mean, 80..300 mm, slider 100 mm),
20 h at 10 Hz, noise 0.3 um, w hidden uniform in 0.5..0.9 by the simulator. The stroke mix changes from job
to job, so the present duty's pass work per work differs from the history's: K alone cannot absorb w, and the
plain model's life is off. The oracle: the same monitor with the true w on the noise-free truth.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"


def hidden_case(seed: int, hours: float = 20.0, rate_hz: float = 10.0):
    """(run, base parameters, the true live parameters, noise-free truth [m])."""
    params = wear_monitor_params(JOBS)
    w = float(np.random.default_rng(6000 + seed).uniform(0.5, 0.9))
    sim = dict(simulation_params(JOBS), duration_h=hours, joint_state_rate_hz=rate_hz, load_rate_hz=rate_hz,
               straightness_noise_m=0.3e-6)
    run = simulate_machine(params, sim, seed=seed, effects={"stroke_distribution": w})
    truth = np.asarray(run.metadata["truth"]["straightness_m"])
    return run, params, {"effects": "stroke_distribution", "stroke_distribution_weight": w}, truth


def lives(seed: int) -> dict:
    run, params, true, truth = hidden_case(seed)
    result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)

    def report(p, r):
        monitor = PrecisionMonitor(p)
        monitor.process_run(r)
        return monitor.report()

    oracle = report({**params, **true}, type(run)(**{**vars(run), "straightness_m": truth}))
    return {"named": result["named_effects"], "model_file": result["model_file"], "true": true,
            "oracle": oracle["remaining_life_h"], "file": report({**params, **result["model_file"]}, run),
            "plain": report(params, run)}


def covers(report: dict, life_h: float) -> bool:
    return report["remaining_life_h_low"] <= life_h <= report["remaining_life_h_high"]


@pytest.mark.parametrize("seed", [1, 3])
def test_model_file_with_stroke_distribution_drives_the_live_life(seed, tmp_path):
    """diagnose names stroke_distribution, the model file carries w (within 0.03 of the hidden one) and the
    monitor with base + model file gives a life within 3 % of the oracle's, inside its 90 % interval; the
    plain model is more than 30 % off (measured: seed 1 oracle 16.20 h, file 16.16 h, plain 10.31 h; seed 3
    9.66, 9.64, 5.87 h). The file goes through the schema as the later --params file."""
    from guide_health.analysis.discrepancy.model_file import write_model_file

    r = lives(seed)
    assert r["named"] == ["stroke_distribution"], r["named"]
    w = r["model_file"]["stroke_distribution_weight"]
    assert w == pytest.approx(r["true"]["stroke_distribution_weight"], abs=0.03)
    path = tmp_path / "model.yaml"
    write_model_file(path, wear_monitor_params(JOBS), r["model_file"], r["named"])
    merged = wear_monitor_params([JOBS, path])
    assert merged["effects"] == "stroke_distribution" and merged["stroke_distribution_weight"] == w
    assert "not integrated live" not in path.read_text()
    assert abs(r["file"]["remaining_life_h"] / r["oracle"] - 1.0) < 0.03
    assert covers(r["file"], r["oracle"])
    assert abs(r["plain"]["remaining_life_h"] / r["oracle"] - 1.0) > 0.3


@pytest.mark.slow
def test_model_file_with_stroke_distribution_10_seeds():
    """Seeds 0-9 (~25 s). Measured 2026-11-23: named 9/10 (seed 0: nothing named; its plain life 44.8 h against
    the oracle's 34.4 h); where named the life is within 1.5 % of the oracle and the interval contains it 9/9;
    the plain life is 0.61-1.70x the oracle's."""
    named = covered = 0
    for seed in range(10):
        r = lives(seed)
        if "stroke_distribution" in r["named"]:
            named += 1
            assert abs(r["file"]["remaining_life_h"] / r["oracle"] - 1.0) < 0.05, (seed, r)
            covered += covers(r["file"], r["oracle"])
        print(f"seed {seed}: named {r['named']}, oracle {r['oracle']:.2f} h, file {r['file']['remaining_life_h']:.2f} "
              f"h, plain {r['plain']['remaining_life_h']:.2f} h")
    assert named >= 9 and covered >= named - 1
