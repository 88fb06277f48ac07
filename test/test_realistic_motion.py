"""Realistic motion (issue 15): jerk-limited moves, joint_states at 250 Hz with 1 um encoder noise, guide/load on
its own clock (``simulate --motion realistic``, params/simulation.py REALISTIC_MOTION).

- The double-S profile against its closed forms (length, limits, duration of a long move).
- The simulator's true straightness (exact per move: each move is monotonic under one load) against the
  independent reference integration (test/reference_wear.py) over the noise-free twin of the bag's samples.
- The stamps: 250 Hz joint_states, 100 Hz loads never on a joint stamp, drifting against them.
- The sliding deadband: the standstill noise adds < 0.1 % phantom sliding (without it, more).
- Acceptance on config/machine_jobs.yaml with the realistic motion: load_exponent and retract_asymmetry
  named with their parameter within test_discrepancy's tolerances (0.1 and 0.15) in >= 9/10 seeds, and clean
  controls name nothing and raise no flag in >= 9/10 (slow); a cheap version runs in the default suite.
"""
from __future__ import annotations

import multiprocessing as mp
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.params.simulation import REALISTIC_MOTION
from guide_health.sim.machine import simulate_machine
from guide_health.sim.motion import s_curve, s_curve_progress

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_wear as ref  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"
NOISE_RANGE_M = (0.2e-6, 0.4e-6)                       # test_discrepancy.py's measurement noise range
RATE_50 = {"joint_state_rate_hz": 50.0}       # the cheap runs: 50 Hz, a fifth of the preset's samples
PARAM_TOL = {"load_exponent": ("load_exponent", 0.1), "retract_asymmetry": ("retract_wear_factor", 0.15)}


def realistic(**over) -> tuple[dict, dict]:
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), **REALISTIC_MOTION)
    sim.update(over)
    return params, sim


# --- the profile ----------------------------------------------------------------------------------


def test_double_s_profile_closed_forms():
    a, j = 2.0, 40.0
    length = np.array([0.3, 0.05, 0.002, 0.2])
    speed = np.array([0.2, 0.2, 0.08, 0.01])
    curve = s_curve(length, speed, a, j)
    # a long move at 0.2 m/s: Tj = a/j, Ta = a/j + v/a, T = L/v + Ta (Biagiotti & Melchiorri eq. 3.31)
    assert curve.duration_s[0] == pytest.approx(0.3 / 0.2 + a / j + 0.2 / a, rel=1e-12)
    # 2 mm cannot reach 80 mm/s nor 2 m/s^2: v' = (L sqrt(j) / 2)^(2/3)
    assert curve.v_m_s[2] == pytest.approx((0.001 * j ** 0.5) ** (2 / 3), rel=1e-12)
    for i in range(length.size):
        t = np.linspace(0.0, curve.duration_s[i], 400_001)
        s, v = s_curve_progress(curve, np.full(t.size, i), t)
        assert s[0] == 0.0 and s[-1] == pytest.approx(length[i], rel=1e-12)
        assert np.all(np.diff(s) >= 0) and v.max() <= speed[i] * (1 + 1e-12)
        # the speed is the derivative of the distance (trapezoid rule over the fine grid)
        assert np.abs(np.diff(s) - 0.5 * (v[1:] + v[:-1]) * np.diff(t)).max() < 1e-9 * length[i]
        acc = np.diff(v) / np.diff(t)
        assert np.abs(acc).max() <= a * (1 + 1e-3)
        assert np.abs(np.diff(acc) / np.diff(t)[1:]).max() <= j * (1 + 1e-2)


# --- the truth and the bag ----------------------------------------------------------------------------


@pytest.mark.parametrize("effects", [{"load_exponent": 1.7}, {"retract_asymmetry": 0.2},
                                     {"speed_dependent_wear": 0.04}, {"running_in": 2.0}])
def test_true_straightness_is_the_independent_integration_of_the_motion(effects):
    """The simulator's truth (per move, exact; the speed effect by Gauss-Legendre over the profile) equals
    reference_wear's sample-by-sample integration over the noise-free 1 kHz twin of the motion to 1e-4 of
    the wear (measured 1.2e-5 at 250 Hz: the reference's zero-order-hold load and sampled speed are the
    difference); a constant-speed truth would be off by the profile's speed variation for the speed effect."""
    params, sim = realistic(duration_h=0.5, encoder_noise_m=0.0, joint_state_rate_hz=1000.0,
                            running_in_distance_m=50.0)
    run = simulate_machine(params, sim, seed=3, effects=effects)
    truth = run.metadata["truth"]
    hidden = ref.hidden_from_effects(effects, sim["running_in_distance_m"], sim["load_reference_n"])
    y = ref.reference_straightness_m(
        run, hidden, wear_coefficient=params["wear_coefficient"], hardness_pa=params["hardness_pa"],
        contact_width_m=params["contact_width_m"], slider_length_m=params["slider_length_m"],
        straightness_initial_m=params["straightness_initial_m"],
        stroke_sum_m=truth["stroke_min_m"] + truth["stroke_max_m"])
    exact = np.asarray(truth["straightness_m"])
    assert np.abs(y - exact).max() < 1e-4 * (exact[-1] - exact[0])
    # the sampled distance is the exact one but for the sample interval around each reversal: the axis stops
    # there, so it cuts off at most 2 x j dt^3 / 6 (jerk phase from rest) per reversal
    sampled = np.abs(np.diff(run.joint_position_m)).sum()
    reversals = 2 * truth["sliding_distance_m"] / (truth["stroke_min_m"] + truth["stroke_max_m"]) * 4
    assert 0 <= truth["sliding_distance_m"] - sampled <= reversals * 2 * sim["max_jerk_m_s3"] * 1e-9 / 6


def test_realistic_bag_stamps_and_standstill():
    params, sim = realistic(duration_h=0.5)
    run = simulate_machine(params, sim, seed=1)
    jt, lt = run.joint_t_ns, run.load_t_ns
    assert np.diff(jt).tolist() == [4_000_000] * (jt.size - 1)                        # 250 Hz
    assert np.all(np.diff(lt) > 0) and abs(np.median(np.diff(lt)) - 10_000_000) < 1_000   # 100 Hz
    assert not np.isin(lt, jt).any()                                                  # never on a joint stamp
    phase = (lt - jt[0]) % 4_000_000
    assert np.ptp(phase) > 2_000_000                                                  # the clocks drift apart
    clean = simulate_machine(params, dict(sim, encoder_noise_m=0.0), seed=1)
    noise = run.joint_position_m - clean.joint_position_m
    assert noise.std() == pytest.approx(1e-6, rel=0.02)
    assert np.array_equal(run.straightness_m, clean.straightness_m)                   # the same run otherwise
    assert np.array_equal(run.load_t_ns, clean.load_t_ns)
    # the axis stops at every reversal: the velocity is 0 there and never above the job's speeds
    assert np.abs(run.joint_velocity_m_s).max() <= sim["retract_speed_m_s"] * (1 + 1e-9)


def test_sliding_deadband_keeps_standstill_noise_out():
    """1 h of realistic motion: with the default deadband the duty cells' sliding distance is within 0.1 %
    of the true distance (measured +0.003 %, seed 3); without it the standstill noise adds phantom sliding
    (+0.15 %) and 1.8x the cells."""
    params, sim = realistic(duration_h=1.0)
    run = simulate_machine(params, sim, seed=3)
    true_m = run.metadata["truth"]["sliding_distance_m"]
    cells = duty_cells_from_runs(run, params["slider_length_m"], sliding_deadband_m=params["sliding_deadband_m"])
    raw = duty_cells_from_runs(run, params["slider_length_m"], sliding_deadband_m=0.0)
    print(f"\ntrue {true_m:.3f} m, deadband {cells.total_distance_m:.3f} m, none {raw.total_distance_m:.3f} m; "
          f"cells {cells.cells} vs {raw.cells}")
    assert abs(cells.total_distance_m / true_m - 1) < 1e-3
    assert raw.total_distance_m / true_m - 1 > 1e-3
    assert raw.cells > 1.3 * cells.cells


def test_simulate_motion_realistic_cli(tmp_path, capsys):
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", "simulate", "--params", str(JOBS), "--out",
                           str(tmp_path / "bag"), "--hours", "0.01", "--motion", "realistic", "--json"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert '"motion_profile": "jerk_limited"' in proc.stdout and '"joint_state_rate_hz": 250.0' in proc.stdout
    # the refusal in-process (the same main() the command runs; the subprocess above covers the command)
    from guide_health.cli.app import main
    try:
        code = main(["simulate", "--params", str(JOBS), "--out", str(tmp_path / "bad"), "--motion", "jerky"])
    except SystemExit as exc:             # argparse's refusal of a choice
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and 1 <= len(err.strip().splitlines()) <= 2 and "jerky" in err, err
    assert not (tmp_path / "bad").exists()


# --- acceptance ---------------------------------------------------------------------------------------


def realistic_case(args):
    """One realistic-motion run of machine_jobs with a hidden effect (drawn as in test_discrepancy.py),
    diagnosed with the default deadband; what was named, the fitted parameter and the flag."""
    effect, seed, over = args
    params, sim = realistic(**over)
    rng = np.random.default_rng(1000 + seed)
    sim["straightness_noise_m"] = rng.uniform(*NOISE_RANGE_M)
    effects = {}
    if effect == "load_exponent":
        effects = {effect: rng.uniform(1.4, 2.0)}
    elif effect == "retract_asymmetry":
        effects = {effect: rng.uniform(0.0, 0.3)}
    run = simulate_machine(params, sim, seed=seed, effects=effects)
    cells = duty_cells_from_runs(run, params["slider_length_m"], sliding_deadband_m=params["sliding_deadband_m"])
    res = diagnose_cells(cells, params)
    param, _ = PARAM_TOL.get(effect, (None, 0.0))
    fitted = res["final"]["parameters"].get(param, {}).get("value") if param else None
    return {"effect": effect, "seed": seed, "hidden": effects.get(effect), "named": res["named_effects"],
            "fitted": fitted, "flag": res["unexplained_structure"]["present"],
            "phantom": cells.total_distance_m / run.metadata["truth"]["sliding_distance_m"] - 1}


def run_realistic(effects, seeds, over):
    cases = [(e, s, over) for e in effects for s in seeds]
    with mp.get_context("spawn").Pool(2) as pool:
        rows = pool.map(realistic_case, cases)
    for r in rows:
        print(f"{r['effect'] or 'clean'} seed {r['seed']}: hidden {r['hidden']}, named {r['named']}, "
              f"fitted {r['fitted']}, flag {r['flag']}, phantom sliding {r['phantom']:+.4%}")
    return rows


def named_right(r) -> bool:
    param, tol = PARAM_TOL[r["effect"]]
    return r["effect"] in r["named"] and abs(r["fitted"] - r["hidden"]) <= tol


def test_realistic_motion_acceptance_cheap():
    """Default suite (two 20 h runs at 50 Hz, one per process): load_exponent seed 0 (hidden 1.76, fitted
    1.715 at 50, 100 and 200 Hz, 1.72 at 250 Hz in the slow test) and retract_asymmetry seed 5 (hidden 0.28,
    fitted 0.258 at 50 Hz, 0.259 at 100 and 200 Hz) are named with their parameter; phantom sliding +3e-6 and
    +4e-6 at 50 Hz (1e-5 to 2e-5 at 100 Hz). Shorter records do not identify the retract factor
    (10 h of 1.5 h jobs: seeds 0 and 1 not named), so the default suite runs two full-length cases at the
    lowest rate that keeps the fitted parameters: the simulation and the duty cells scale with the samples,
    the fit with the cells."""
    with mp.get_context("spawn").Pool(2) as pool:
        rows = pool.map(realistic_case, [("load_exponent", 0, RATE_50), ("retract_asymmetry", 5, RATE_50)])
    for r in rows:
        print(r)
        assert named_right(r), r
        assert abs(r["phantom"]) < 1e-3


@pytest.mark.slow
def test_realistic_motion_acceptance_10_seeds():
    """config/machine_jobs.yaml, 20 h, realistic motion, seeds 0-9 (26 min on the loaded two-core machine).
    Measured 2026-11-23: load_exponent 10/10 named, largest |n - hidden| 0.047; retract_asymmetry 10/10,
    largest |rho - hidden| 0.096; clean: nothing named 10/10, flagged 1/10 (seed 2); phantom sliding
    <= +0.003 %."""
    rows = run_realistic(["load_exponent", "retract_asymmetry", ""], range(10), {})
    for effect in ("load_exponent", "retract_asymmetry"):
        assert sum(named_right(r) for r in rows if r["effect"] == effect) >= 9, effect
    clean = [r for r in rows if not r["effect"]]
    assert sum(not r["named"] and not r["flag"] for r in clean) >= 9
    assert max(abs(r["phantom"]) for r in rows) < 1e-3
