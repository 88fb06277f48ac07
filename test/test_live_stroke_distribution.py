"""stroke_distribution live (issue 15: the live model integrates every effect diagnose names).

The straightness of a worn guide is A0 + K / (H b) [(1 - w) 2 G / (l_min + l_max) + w P] (models/wear/effects/
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
from hypothesis import given, settings
from hypothesis import strategies as st

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.params.typed import wear_axis_params
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
        monitor = PrecisionMonitor(wear_axis_params(p))
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


# --- the pass bookkeeping does not depend on how the segments arrive ---------------------------------------


@settings(max_examples=60, deadline=None, derandomize=True)
@given(steps=st.lists(st.floats(-0.05, 0.05).filter(lambda v: abs(v) > 1e-6), min_size=2, max_size=120),
       cuts=st.lists(st.integers(1, 119), max_size=8), slider=st.sampled_from([0.0, 0.02, 0.1]))
def test_pass_work_is_the_same_whatever_the_segments_chunking(steps, cuts, slider):
    """Any sequence of sliding steps (reversals anywhere, any lengths), fed to EffectWear all at once, one
    segment per call (the node) or in arbitrary chunks: the same P, open pass and window pass sums (1e-12),
    and P equals the closed form sum over passes of work / max(L, L_s) with the passes cut at sign changes."""
    from guide_health.models.wear.effect_wear import PASS_SUM, EffectWear
    from guide_health.models.wear.effects import EffectParameters

    dx = np.asarray(steps)
    x = np.concatenate(([0.0], np.cumsum(dx)))
    n = dx.size
    t = 1_700_000_000 * 10 ** 9 + np.arange(n + 1, dtype=np.int64) * 700_000_000   # 0.7 s: several buckets
    load = 1000.0 + 500.0 * np.sin(np.arange(n))
    effects = EffectParameters(effects=("stroke_distribution",), stroke_distribution_weight=0.5, slider_length_m=slider)

    def fed(bounds) -> EffectWear:
        ew = EffectWear(effects, 2.0, 1000)
        for a, b in zip(bounds[:-1], bounds[1:]):
            if b > a:
                ew.add_segments(t[a:b], t[a + 1:b + 1], x[a:b], x[a + 1:b + 1], load[a:b], np.zeros(b - a))
        return ew

    whole = fed([0, n])
    single = fed(list(range(n + 1)))
    chunked = fed(sorted({0, n, *[c for c in cuts if c < n]}))
    # the closed form: passes are runs of one sign of dx
    sign = np.sign(dx)
    starts = np.concatenate(([0], np.flatnonzero(sign[1:] != sign[:-1]) + 1))
    lengths = np.add.reduceat(np.abs(dx), starts)
    works = np.add.reduceat(load * np.abs(dx), starts)
    expected = float(np.sum(works / np.maximum(lengths, slider)))
    for ew in (whole, single, chunked):
        assert ew.pass_work_now_n() == pytest.approx(expected, rel=1e-12)
        assert ew.pass_length_m == pytest.approx(lengths[-1], rel=1e-12)
        # the duty window (here the whole record) holds the same pass work, bucket by bucket the same
        assert ew.window_sums(int(t[-1]))[PASS_SUM] == pytest.approx(expected, rel=1e-12)
        assert {b: pytest.approx(r[PASS_SUM], rel=1e-12, abs=1e-9) for b, r in whole.buckets.items()} == {
            b: r[PASS_SUM] for b, r in ew.buckets.items()}
