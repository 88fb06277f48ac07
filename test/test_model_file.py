"""The model file (issue 15): what ``diagnose`` learns drives the live monitor's remaining life.

- the live effect integration (models/wear/effect_wear.py inside PrecisionMonitor) against the independent
  reference integration of test/reference_wear.py (shares no function with the package);
- the seed 000 bench with running-in (``--effect running_in=2.5``, s0 = 300 m), diagnosed on its 20 h and
  replayed with the model file: remaining life against the noise-free truth's, with and without the file;
- the CLI: diagnose --out DIR writes DIR/model.yaml, replay --params BASE --params DIR/model.yaml loads it.

Truth remaining life: the noise-free straightness of the simulator (bag metadata "truth") extrapolated
linearly from its last 5 h (the running-in has decayed to e^-12 by then) to the 100 um limit.
"""
from __future__ import annotations

import dataclasses
import functools
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import stdtrit

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.errors import InputError
from guide_health.models.wear.input_rules import InputLimits
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_wear as ref  # noqa: E402
from live_feed import feed_per_sample  # noqa: E402

from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
JOBS = ROOT / "config" / "machine_jobs.yaml"


def cli(*args, check=True):
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def true_remaining_life_h(run, limit_m: float) -> float:
    """From the noise-free truth: the last 5 h's straight line extrapolated to the limit."""
    truth = run.metadata["truth"]
    t = np.asarray(truth["straightness_t_s"])
    y = np.asarray(truth["straightness_m"])
    last = t >= t[-1] - 5 * 3600.0
    slope = np.polyfit(t[last], y[last], 1)[0]
    return (limit_m - y[-1]) / slope / 3600.0


def bench_running_in(seed: int, rate_hz: float = 10.0):
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), joint_state_rate_hz=rate_hz, load_rate_hz=2.0)
    return params, simulate_machine(params, sim, seed=seed, effects={"running_in": 2.5})


def replay_life(params: dict, run, fit: list | None = None) -> tuple[float, float, float]:
    """(life, low, high) [h] of the replayed run; ``fit``: gets its model_fit appended."""
    monitor = PrecisionMonitor(wear_axis_params(params))
    monitor.process_run(run)
    r = monitor.report()
    if fit is not None:
        fit.append(r["model_fit"])
    return r["remaining_life_h"], r["remaining_life_h_low"], r["remaining_life_h_high"]


@functools.cache
def diagnosed_running_in(seed: int) -> tuple[dict, object, dict]:
    """(params, run, diagnose's result) of the running-in bench at 10 Hz, its duty cells as diagnose reads a
    bag (input limits, deadband); built once per seed for the tests that judge different parts of it."""
    params, run = bench_running_in(seed)
    cells = duty_cells_from_runs(run, params["slider_length_m"],
        limits=InputLimits.from_params(wear_axis_params(params)),
        sliding_deadband_m=params["sliding_deadband_m"])
    return params, run, diagnose_cells(cells, params)


def coverage(seeds) -> list[dict]:
    rows = []
    for seed in seeds:
        params, run, result = diagnosed_running_in(seed)
        truth = true_remaining_life_h(run, params["straightness_limit_m"])
        fit: list = []
        with_file = replay_life({**params, **result["model_file"]}, run, fit)
        plain = replay_life(params, run, fit)
        rows.append({"seed": seed, "named": result["named_effects"], "truth_h": truth, "model": with_file,
                     "plain": plain, "model_file": result["model_file"], "model_fit": fit})
    return rows


def covers(interval, truth) -> bool:
    return interval[1] <= truth <= interval[2]


# --- the live effect integration against the independent reference -------------------------------

@pytest.mark.parametrize("effects, live", [
    ({"retract_asymmetry": 0.3}, {"effects": "retract_asymmetry", "retract_wear_factor": 0.3}),
    ({"load_exponent": 1.6}, {"effects": "load_exponent", "load_exponent": 1.6}),
    ({"speed_dependent_wear": 0.03}, {"effects": "speed_dependent_wear", "lift_speed_m_s": 0.03}),
    ({"running_in": 2.0}, {"effects": "running_in", "running_in_ratio": 2.0}),
    ({"running_in": 1.5, "retract_asymmetry": 0.5, "load_exponent": 1.4},
     {"effects": "running_in,retract_asymmetry,load_exponent", "running_in_ratio": 1.5, "retract_wear_factor": 0.5,
      "load_exponent": 1.4}),
    ({"stroke_distribution": 0.7}, {"effects": "stroke_distribution", "stroke_distribution_weight": 0.7}),
    ({"stroke_distribution": 0.5, "running_in": 2.0, "retract_asymmetry": 0.4},
     {"effects": "stroke_distribution,running_in,retract_asymmetry", "stroke_distribution_weight": 0.5,
      "running_in_ratio": 2.0, "retract_wear_factor": 0.4}),
])
def test_live_effects_integrate_the_independent_reference(effects, live):
    """machine_jobs (varying feed speed, cutting load, rapid light retract): the monitor's straightness at
    every measurement with the true K and effect parameters equals reference_wear's sample integration
    (feed +x, retract -x, zero-order-hold load) to 0.2 % of the wear; with the plain model it does not."""
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=4.0, joint_state_rate_hz=20.0, straightness_noise_m=0.0)
    run = simulate_machine(params, sim, seed=4, effects=effects)
    stroke = (float(run.metadata["truth"]["stroke_min_m"]), float(run.metadata["truth"]["stroke_max_m"]))
    fixed = {**params, "stroke_min_m": stroke[0], "stroke_max_m": stroke[1], "sliding_deadband_m": 0.0,
             "running_in_distance_m": sim["running_in_distance_m"], "load_reference_n": sim["load_reference_n"],
             "retract_direction": "-x"}
    k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    hidden = ref.hidden_from_effects(effects, sim["running_in_distance_m"], sim["load_reference_n"])
    expected = ref.reference_straightness_m(
        run, hidden, wear_coefficient=k, hardness_pa=params["hardness_pa"], contact_width_m=params["contact_width_m"],
        slider_length_m=params["slider_length_m"], straightness_initial_m=params["straightness_initial_m"],
        stroke_sum_m=sum(stroke))
    wear_ref = expected - params["straightness_initial_m"]
    for extra, should_match in ((live, True), ({}, False)):
        monitor = PrecisionMonitor(wear_axis_params({**fixed, **extra}))
        monitor.process_run(run)
        got = monitor.straightness_m(k, monitor.measurement_losses_per_k_m()) - params["straightness_initial_m"]
        assert got.size == wear_ref.size
        err = np.max(np.abs(got - wear_ref)[1:] / wear_ref[1:])
        assert (err < 2e-3) == should_match, (extra, err)


def test_live_per_sample_path_equals_the_vectorised_path():
    """The node's per-sample callbacks and process_run give the same effective work and life (one model
    object, two input paths). 2 Hz joints and loads: the callbacks cost per sample, the equality holds at any
    rate."""
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=1.0, joint_state_rate_hz=2.0, load_rate_hz=2.0)
    run = simulate_machine(params, sim, seed=2, effects={"running_in": 1.0, "retract_asymmetry": 0.4})
    p = {**params, "effects": "running_in,retract_asymmetry,stroke_distribution", "running_in_ratio": 1.0,
         "running_in_distance_m": 300.0, "retract_wear_factor": 0.4, "stroke_distribution_weight": 0.6,
         "effect_covariance": list(np.diag([1e-14, 0.01, 100.0, 0.001, 0, 0, 0, 0, 0, 0.01, 0, 0, 0]).ravel())}
    offline = PrecisionMonitor(wear_axis_params(p))
    offline.process_run(run)
    live = PrecisionMonitor(wear_axis_params(p))
    feed_per_sample(live, run)
    a, b = offline.report(), live.report()
    assert live.effect_wear.effective_work_nm == pytest.approx(offline.effect_wear.effective_work_nm, rel=1e-9)
    # stroke_distribution's passes: one segment per call live, whole arrays offline
    assert live.effect_wear.pass_work_now_n() == pytest.approx(offline.effect_wear.pass_work_now_n(), rel=1e-9)
    assert live.effect_wear.measurement_pass_work_n == pytest.approx(offline.effect_wear.measurement_pass_work_n,
                                                                     rel=1e-9)
    assert live.effect_wear.window_sums(live.integrator.last_t_ns) == pytest.approx(
        offline.effect_wear.window_sums(offline.integrator.last_t_ns), rel=1e-9)
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
                "wear_coefficient"):
        assert b[key] == pytest.approx(a[key], rel=1e-6), key
    # persisted and restored, the effect state goes on identically
    again = PrecisionMonitor(wear_axis_params(p))
    again.restore(json.loads(json.dumps(offline.state())))
    assert again.report()["remaining_life_h"] == pytest.approx(a["remaining_life_h"], rel=1e-9)


# --- the running-in bench: remaining life with and without the model file -----------------------------

def test_running_in_remaining_life_with_the_model_file_default_seeds():
    """Seeds 1-3 (default suite, ~10 s): with the model file the point estimate is within 10 % of the true
    remaining life and its 90 % interval contains it; without, the life is < 50 % of the truth (the issue's
    measurement: 1.75 h [1.16, 2.37] h against 4.18 h) and the fit test says the model is broken (the
    interval, widened by the innovations' spread, is then [0, 4.27] h for seed 1)."""
    for row in coverage(range(1, 4)):
        assert row["named"] == ["running_in"]
        assert abs(row["model"][0] / row["truth_h"] - 1.0) < 0.10, row
        assert covers(row["model"], row["truth_h"]), row
        # without it the fit test finds the model broken (models/wear/fit_watch.py), and the interval widens
        assert row["plain"][0] < 0.5 * row["truth_h"] and row["model_fit"] == ["ok", "broken"], row


@pytest.mark.slow
def test_running_in_remaining_life_coverage_seeds_0_to_9():
    """Seeds 0-9 (~40 s): point estimate within 10 % in every seed; coverage measured 7/10 with the file; without
    it 10/10 since the fit test finds the model broken and widens its interval (docs/model_file.md). The
    interval is calibrated (next test; seeds 100-159: 56/60); seeds 0, 8 and 9 miss because their last
    measurements' noise is extreme (last-ten means +0.39, -0.35, +0.31 um: 2.0 to 2.4 sigma), which moves
    the fitted present straightness by 0.3-0.5 um: errors of 2.0-2.6 predicted sd, none beyond 3."""
    rows = coverage(range(10))
    hits = sum(covers(r["model"], r["truth_h"]) for r in rows)
    plain_hits = sum(covers(r["plain"], r["truth_h"]) for r in rows)
    print(f"coverage with the model file {hits}/10, without {plain_hits}/10")
    assert all(abs(r["model"][0] / r["truth_h"] - 1.0) < 0.10 for r in rows), rows
    # without the file the fit test finds the model broken and widens the interval (it may then reach the truth)
    assert hits >= 7 and all(r["model_fit"] == ["ok", "broken"] for r in rows), rows
    for r in rows:        # every error within 3 predicted sd (interval: life x exp(+-t sd), t_40 = 1.684)
        life, _, high = r["model"]
        assert abs(math.log(r["truth_h"] / life)) < 3.0 * math.log(high / life) / 1.684, r


@pytest.mark.slow
def test_running_in_life_interval_is_calibrated_on_noise_redraws():
    """The interval's statistics without the luck of ten bags: seed 0's motion (5 Hz) with 120 fresh draws of
    the 0.5 um measurement noise, each fitted with running_in on every measurement (the model file's fit) and
    replayed with the file: the predicted sd of ln(life) (from the interval) equals the empirical spread of
    ln(life / true life) to 20 %, and the 90 % interval covers the true life in 82-97 % of the draws (90 %
    +- 2.5 binomial sd for 120). Measured (10 Hz, 400 draws, before the profiled-K fix): predicted 0.0243
    against 0.0210 empirical (the online K spread was counted twice), 94 % covered; after it, seed 9's motion,
    150 draws: 0.0215 against 0.0212, 88 % covered. ~90 s."""
    from guide_health.analysis.discrepancy.model import WearProblem
    from guide_health.analysis.discrepancy.model_file import model_parameters

    params, run = bench_running_in(0, rate_hz=5.0)
    truth_m = np.asarray(run.metadata["truth"]["straightness_m"])
    truth_h = true_remaining_life_h(run, params["straightness_limit_m"])
    cells = duty_cells_from_runs(run, params["slider_length_m"],
        limits=InputLimits.from_params(wear_axis_params(params)),
        sliding_deadband_m=params["sliding_deadband_m"])
    rng = np.random.default_rng(2026)
    errors, sds, hits = [], [], 0
    for _ in range(120):
        measured = truth_m + rng.normal(0.0, 0.5e-6, truth_m.size)
        problem = WearProblem(dataclasses.replace(cells, measurement_m=measured), params, heldout_fraction=0.0)
        model = model_parameters(problem, problem.fit(("running_in",)), ["running_in"])
        life = replay_life({**params, **model}, dataclasses.replace(run, straightness_m=measured))
        errors.append(math.log(truth_h / life[0]))
        sds.append(math.log(life[2] / life[0]) / 1.684)
        hits += covers(life, truth_h)
    ratio = float(np.mean(sds)) / float(np.std(errors))
    print(f"predicted sd {np.mean(sds):.4f}, empirical {np.std(errors):.4f}, covered {hits}/120")
    assert 0.8 < ratio < 1.2, ratio
    assert 98 <= hits <= 116, hits


def test_a_fitted_a0_goes_into_the_model_file_with_its_covariance():
    """A0 not given (straightness_initial_m 0): the fit frees it and the file's A0 is the fitted one, its
    covariance row the fit's (with K and running-in). A0 given and initial_offset named: the file's A0 is
    A0 + delta and its row is delta's. A0 given, no initial_offset: A0 is known, its row zero. diagnose's text
    shows A0 with its sd when fitted."""
    from types import SimpleNamespace

    from guide_health.analysis.discrepancy.model_file import live_parameter_text, model_parameters
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    n = len(COVARIANCE_NAMES)
    k, r, a = (COVARIANCE_NAMES.index(x) for x in ("wear_coefficient", "running_in_ratio", "straightness_initial_m"))
    sd = np.array([0.02 * 4.4e-6, 0.2, 40.0, 0.4e-6])
    corr = np.eye(4)
    corr[1, 3] = corr[3, 1] = -0.7
    corr[0, 3] = corr[3, 0] = 0.2
    sigma = corr * np.outer(sd, sd)
    base = dict(fit_references={"load_reference_n": 5000.0}, retract_sign=-1, cells=SimpleNamespace(t0_ns=0),
                temperature_first_c=20.0)
    for a0_free, extra_name, a0_file in ((True, "straightness_initial_m", 14.6e-6),
                                         (False, "initial_offset_m", 15e-6 - 0.4e-6)):
        values = {"wear_coefficient": 4.4e-6, "running_in_ratio": 2.4, "running_in_distance_m": 310.0,
                  extra_name: 14.6e-6 if a0_free else -0.4e-6}
        names = ["wear_coefficient", "running_in_ratio", "running_in_distance_m", extra_name]
        final = SimpleNamespace(values=values, extra={"covariance": {"names": names, "matrix": sigma}})
        problem = SimpleNamespace(a0_free=a0_free, a0_m=0.0 if a0_free else 15e-6, **base)
        named = ["running_in"] if a0_free else ["running_in", "initial_offset"]
        model = model_parameters(problem, final, named)
        cov = np.asarray(model["effect_covariance"]).reshape(n, n)
        assert model["straightness_initial_m"] == pytest.approx(a0_file, rel=1e-12)
        assert cov[a, a] == pytest.approx(sigma[3, 3], rel=1e-12)
        assert cov[a, r] == pytest.approx(sigma[1, 3], rel=1e-12) and cov[k, a] == pytest.approx(sigma[0, 3], rel=1e-12)
        assert model["effects"] == "running_in"
        text = live_parameter_text(model)
        assert f"straightness_initial_m = {a0_file:.4g} ± {0.4e-6:.2g}" in text, text
    known = model_parameters(SimpleNamespace(a0_free=False, a0_m=15e-6, **base), SimpleNamespace(
        values={"wear_coefficient": 4.4e-6, "running_in_ratio": 2.4, "running_in_distance_m": 310.0},
        extra={"covariance": {"names": names[:3], "matrix": sigma[:3, :3]}}), ["running_in"])
    cov = np.asarray(known["effect_covariance"]).reshape(n, n)
    assert known["straightness_initial_m"] == 15e-6 and not cov[a].any()
    assert "straightness_initial_m" not in live_parameter_text(known)


def test_the_life_interval_carries_a0_as_a_rerun_moves_the_life():
    """A0's share of the interval (its variance alone in the covariance, less the interval with none) equals
    the life's change when the whole monitor is rerun with A0 moved by that sd (5 %): A0 moves the straightness
    now and every measured rise over A0, so the K update moves with it."""
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    params, run = bench_running_in(2, rate_hz=5.0)
    n, a = len(COVARIANCE_NAMES), COVARIANCE_NAMES.index("straightness_initial_m")
    live = {**params, "effects": "running_in", "running_in_ratio": 2.5, "running_in_distance_m": 300.0}
    sd = 0.4e-6

    def life(extra: dict, variance: float) -> tuple[float, float, float]:
        cov = np.zeros((n, n))
        cov[a, a] = variance
        return replay_life({**live, **extra, "effect_covariance": cov.ravel().tolist()}, run)

    none, one = life({}, 0.0), life({}, sd ** 2)
    assert one[0] == pytest.approx(none[0], rel=1e-12)
    monitor = PrecisionMonitor(wear_axis_params(live))
    monitor.process_run(run)
    t90 = float(stdtrit(monitor.estimator.count - 1, 0.95))      # the interval's quantile
    half_none, half_one = (math.log(x[2] / x[0]) for x in (none, one))   # t90 x the sd of ln(life)
    predicted = math.sqrt(half_one ** 2 - half_none ** 2) / t90        # A0's share of the sd of ln(life)
    up, down = (life({"straightness_initial_m": params["straightness_initial_m"] + s}, 0.0)[0] for s in (sd, -sd))
    rerun = abs(math.log(up / down)) / 2.0
    print(f"A0: delta method {predicted:.5f}, rerun {rerun:.5f}")
    assert predicted == pytest.approx(rerun, rel=0.05)
    assert predicted > 0.2 * half_none / t90          # not negligible against K's own spread


@pytest.mark.slow
def test_a_fitted_a0_life_interval_is_calibrated_on_noise_redraws():
    """As the running-in calibration test, with A0 not given (the fit frees it): seeds 0 and 9's motions (5 Hz),
    100 noise draws each. The file's A0 row (correlation -0.8 with running_in_ratio, 0.55 with s0) keeps the interval
    calibrated: predicted sd of ln(life) within 20 % of the empirical spread, coverage 82-97 %. Without it
    (A0 held, r and s0 with their A0-free marginal variance) the interval is > 1.2x too wide. Measured
    2026-11-24, 200 draws: seed 0 predicted 0.0220, empirical 0.0217, covered 182/200 (without A0's row: 0.0297,
    192/200); seed 9 0.0220, 0.0217, 183/200 (0.0297, 192/200)."""
    from guide_health.analysis.discrepancy.model import WearProblem
    from guide_health.analysis.discrepancy.model_file import model_parameters
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    n, a = len(COVARIANCE_NAMES), COVARIANCE_NAMES.index("straightness_initial_m")
    for seed in (0, 9):
        params, run = bench_running_in(seed, rate_hz=5.0)
        truth_m = np.asarray(run.metadata["truth"]["straightness_m"])
        truth_h = true_remaining_life_h(run, params["straightness_limit_m"])
        cells = duty_cells_from_runs(run, params["slider_length_m"],
            limits=InputLimits.from_params(wear_axis_params(params)),
            sliding_deadband_m=params["sliding_deadband_m"])
        free = {**params, "straightness_initial_m": 0.0}
        rng = np.random.default_rng(2026 + seed)
        errors, sds, held_sds, hits = [], [], [], 0
        for _ in range(100):
            measured = truth_m + rng.normal(0.0, 0.5e-6, truth_m.size)
            problem = WearProblem(dataclasses.replace(cells, measurement_m=measured), free, heldout_fraction=0.0)
            model = model_parameters(problem, problem.fit(("running_in",)), ["running_in"])
            cov = np.asarray(model["effect_covariance"]).reshape(n, n)
            assert cov[a, a] > 0
            noisy = dataclasses.replace(run, straightness_m=measured)
            life = replay_life({**params, **model}, noisy)
            cov = cov.copy()
            cov[a, :] = cov[:, a] = 0.0
            held = replay_life({**params, **model, "effect_covariance": cov.ravel().tolist()}, noisy)
            errors.append(math.log(truth_h / life[0]))
            sds.append(math.log(life[2] / life[0]) / 1.684)
            held_sds.append(math.log(held[2] / held[0]) / 1.684)
            hits += covers(life, truth_h)
        ratio, held_ratio = (float(np.mean(x)) / float(np.std(errors)) for x in (sds, held_sds))
        print(f"seed {seed}: predicted {np.mean(sds):.4f}, empirical {np.std(errors):.4f}, covered {hits}/100; "
              f"A0 held {np.mean(held_sds):.4f}")
        assert 0.8 < ratio < 1.2, ratio
        assert held_ratio > 1.2, held_ratio
        assert 82 <= hits <= 97, hits


# --- running-in of forms the library does not hold -------------------------------------------------------

#: K(s) / K of running-in forms other than the library's 1 + r e^(-s/s0), as the effective sliding distance
#: int_0^s K(u) / K du in closed form (written here, not from effects.py), and the s0 [m] each is run with
#: (linear: 600 m, so its whole extra distance r s0 / 2 is the library bench's r s0 = 750 m)
RUNNING_IN_FORMS = {
    "hyperbolic": (lambda s, r, s0: s + r * s0 * np.log1p(s / s0), 300.0),             # 1 + r / (1 + s/s0)
    "linear": (lambda s, r, s0: s + r * np.where(s < s0, s - s * s / (2 * s0), s0 / 2), 600.0),  # 1 + r (1 - s/s0)+
    "inverse_square": (lambda s, r, s0: s + r * s0 * (s / s0) / (1 + s / s0), 300.0),  # 1 + r (1 + s/s0)^-2
    # 1 + r exp(-sqrt(s/s0)): int_0^s = 2 s0 (1 - (1 + q) e^-q), q = sqrt(s/s0); s0 = 150 m, so that its extra
    # distance 2 r s0 is the library bench's r s0
    "stretched_exponential": (lambda s, r, s0: s + 2 * r * s0 * (1 - (1 + np.sqrt(s / s0)) * np.exp(-np.sqrt(s / s0))),
                              150.0),
    # 1 + r (1 + s/s0)^-0.5 (a decay without end, slower than any fitted form): int_0^s = 2 r s0 (sqrt(1 + s/s0) - 1);
    # s0 = 5 m, so that its extra distance over the bench's 20 h (~4.8 km) is about the library bench's r s0
    "power_law": (lambda s, r, s0: s + 2 * r * s0 * (np.sqrt(1 + s / s0) - 1), 5.0),
    # two stages, 1 + 0.8 r e^(-s/s0) + 0.2 r e^(-s/(20 s0)): the asperities run in over s0, the conformity of
    # the surfaces over 20 s0 (2 km, still 4.5 % above the steady rate at the bench's 4.8 km);
    # int_0^s = 0.8 r s0 (1 - e^(-s/s0)) + 4 r s0 (1 - e^(-s/(20 s0)))
    "two_stage": (lambda s, r, s0: s + 0.8 * r * s0 * -np.expm1(-s / s0) + 4.0 * r * s0 * -np.expm1(-s / (20 * s0)),
                  100.0),
}


def running_in_of_form(form: str, seed: int, rate_hz: float, r: float = 2.5):
    """The bench (constant load and stroke, so the wear is proportional to the sliding distance s) with a
    running-in of ``form`` hidden: straightness A0 + c s_eff(s) at each measurement, c set so that the
    straightness at the end equals the library-form bench's (r 2.5, s0 300 m), noise 0.5 um. The true
    remaining life slides on at the last 5 h's mean speed until A0 + c s_eff = the limit."""
    from scipy.optimize import brentq

    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), joint_state_rate_hz=rate_hz, load_rate_hz=2.0, straightness_noise_m=0.0)
    run = simulate_machine(params, sim, seed=seed)
    a0, limit = params["straightness_initial_m"], params["straightness_limit_m"]
    t = np.asarray(run.joint_t_ns)
    s = np.concatenate(([0.0], np.cumsum(np.abs(np.diff(np.asarray(run.joint_position_m))))))
    s_at = np.interp(np.asarray(run.straightness_t_ns), t, s)
    plain_per_m = np.polyfit(s_at, np.asarray(run.straightness_m) - a0, 1)[0]      # wear per metre slid
    s_eff, s0_m = RUNNING_IN_FORMS[form]
    c = plain_per_m * (s_at[-1] + 2.5 * 300.0) / s_eff(s_at[-1], r, s0_m)
    truth = a0 + c * s_eff(s_at, r, s0_m)
    noisy = dataclasses.replace(run, straightness_m=truth + np.random.default_rng(seed).normal(0, 0.5e-6, truth.size))
    last = t >= t[-1] - 5 * 3600e9
    speed = (s[last][-1] - s[last][0]) / ((t[last][-1] - t[last][0]) * 1e-9)
    s_limit = brentq(lambda q: a0 + c * s_eff(q, r, s0_m) - limit, s_at[-1], 100 * s_at[-1])
    return params, noisy, (s_limit - s_at[-1]) / speed / 3600.0


def other_form_rows(forms, seeds, rate_hz: float) -> list[dict]:
    rows = []
    for form in forms:
        for seed in seeds:
            params, run, truth_h = running_in_of_form(form, seed, rate_hz)
            cells = duty_cells_from_runs(run, params["slider_length_m"],
                limits=InputLimits.from_params(wear_axis_params(params)),
                sliding_deadband_m=params["sliding_deadband_m"])
            result = diagnose_cells(cells, params)
            rows.append({"form": form, "seed": seed, "named": result["named_effects"], "truth_h": truth_h,
                         "flag": bool(result["unexplained_structure"]["present"]),
                         "model": replay_life({**params, **result["model_file"]}, run),
                         "plain": replay_life(params, run)})
    return rows


def check_other_forms(rows: list[dict]) -> None:
    """Each run: the model file's life within 15 % of the truth and nearer to it than the plain model's, and an
    interval that misses the truth only under the unexplained-structure flag."""
    for r in rows:
        print(r["form"], r["seed"], r["named"], "flag" if r["flag"] else "", f"truth {r['truth_h']:.2f} h",
              "model {:.2f} [{:.2f}, {:.2f}]".format(*r["model"]), f"plain {r['plain'][0]:.2f}")
        assert abs(r["model"][0] / r["truth_h"] - 1.0) < 0.15, r
        assert abs(math.log(r["model"][0] / r["truth_h"])) < abs(math.log(r["plain"][0] / r["truth_h"])), r
        assert r["flag"] or covers(r["model"], r["truth_h"]), r


def test_running_in_of_other_forms_gives_the_life_or_the_flag():
    """Running-in whose K(s) is not the library's exponential (hyperbolic, linear to zero at s0; seed 1, 5 Hz;
    the truth written here): diagnose names what approximates it, and the model file's life is within 15 % of
    the true one; where its interval misses, the result carries the unexplained-structure flag."""
    check_other_forms(other_form_rows(("hyperbolic", "linear"), (1,), 5.0))


@pytest.mark.slow
def test_running_in_of_other_forms_10_seeds():
    """Seeds 0-9 of three forms (10 Hz, ~1 min). Measured 2026-11-24: flagged 30/30. Hyperbolic: named
    running_in (seed 0 with wear_rate_change), r 1.4-1.5 (hidden 2.5: the exponential takes the start of the
    long tail), life 2-9 % short, covered 3/10; linear: wear_rate_change 8/10 (the kink at s0 as a change
    point), running_in 2/10, life within 4 %, covered 10/10; inverse square: running_in, life 0-6 % short,
    covered 6/10. The plain model: 0.36-0.52 of the truth."""
    check_other_forms(other_form_rows(tuple(f for f in RUNNING_IN_FORMS if f != "power_law"), range(10), 10.0))


# --- the CLI ----------------------------------------------------------------------------------------

def test_diagnose_writes_a_model_file_that_replay_loads(tmp_path):
    """simulate (20 h, 5 Hz, running-in) -> diagnose --out DIR -> DIR/model.yaml (a wear_monitor ROS 2 parameters
    file) -> replay --params BASE --params DIR/model.yaml: the remaining life moves from < 50 % of the truth
    to within 10 %. The bag's loads at 1 Hz (the bench's constant 6000 N: the 10 Hz stream's work with 60 %
    fewer messages for simulate to write and diagnose and replay to read)."""
    bag = tmp_path / "bench"
    scenario = yaml.safe_load(BENCH.read_text())
    scenario["guide_health_simulation"]["ros__parameters"]["load_rate_hz"] = 1.0
    sim_file = tmp_path / "bench_1hz_loads.yaml"
    sim_file.write_text(yaml.safe_dump(scenario))
    cli("simulate", "--params", str(sim_file), "--out", str(bag), "--rate", "5", "--seed", "3",
        "--effect", "running_in=2.5")
    out = tmp_path / "diag"
    text = cli("diagnose", str(bag), "--params", str(BENCH), "--out", str(out), "--no-plot").stdout
    model = yaml.safe_load((out / "model.yaml").read_text())["/**/wear_monitor"]["ros__parameters"]
    # what goes live, with its standard errors, in the text and in report.md
    sd = math.sqrt(model["effect_covariance"][14])     # [1, 1] of the 13 x 13
    line = f"running_in_ratio = {model['running_in_ratio']:.4g} ± {sd:.2g}"
    assert line in text and line in (out / "report.md").read_text(), text
    assert model["effects"] == "running_in"
    assert "the effects the live monitor integrates: running_in." in (out / "report.md").read_text()
    assert (out / "model.yaml").read_text().startswith("# guide-health diagnose")     # explained: no warning
    assert model["running_in_ratio"] == pytest.approx(2.5, rel=0.2)
    assert model["running_in_distance_m"] == pytest.approx(300.0, rel=0.2)
    assert len(model["effect_covariance"]) == 169 and model["effect_covariance"][0] > 0
    merged = wear_monitor_params([BENCH, out / "model.yaml"])
    assert merged["effects"] == "running_in" and merged["contact_width_m"] == 0.040    # base kept, model over it
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(sim_file), joint_state_rate_hz=5.0)
    truth = true_remaining_life_h(simulate_machine(params, sim, seed=3, effects={"running_in": 2.5}),
                                  params["straightness_limit_m"])
    lives = {}
    for name, extra in (("plain", []), ("model", ["--params", str(out / "model.yaml")])):
        rep = json.loads(cli("replay", str(bag), "--params", str(BENCH), *extra, "--out", str(tmp_path / name),
                             "--no-plot", "--json").stdout)
        lives[name] = rep["remaining_life_h"]
    assert lives["plain"] < 0.5 * truth
    assert abs(lives["model"] / truth - 1.0) < 0.10, (lives, truth)


def test_a_model_file_from_before_the_duty_effects_still_loads(tmp_path):
    """A stop-10 model file holds a 6 x 6 effect_covariance, a stop-11 one a 9 x 9 (stop 12's first commit a
    10 x 10, stop 12's a 12 x 12): each loads as the leading block of the 13 x 13 (zeros elsewhere), the same
    life and interval as the file written with the 13 x 13; 37 numbers are refused."""
    cov6 = np.diag([(0.02 * 4.4e-6) ** 2, 0.1 ** 2, 30.0 ** 2, 0.05 ** 2, 0.0, 0.0])
    cov6[0, 1] = cov6[1, 0] = 0.3 * (0.02 * 4.4e-6) * 0.1
    body = {"wear_coefficient": 4.4e-6, "effects": "running_in,retract_asymmetry", "running_in_ratio": 2.0,
            "running_in_distance_m": 300.0, "retract_wear_factor": 0.5}
    files = {}
    for size in (6, 9, 10, 12, 13):
        cov = np.zeros((size, size))
        cov[:6, :6] = cov6
        files[size] = tmp_path / f"cov{size}.yaml"
        files[size].write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {
            **body, "effect_covariance": cov.ravel().tolist()}}}))
    loaded = {size: wear_monitor_params([BENCH, f]) for size, f in files.items()}
    assert all(loaded[size]["effect_covariance"] == loaded[13]["effect_covariance"] for size in (6, 9, 10, 12))
    assert len(loaded[6]["effect_covariance"]) == 169
    params, run = bench_running_in(2, rate_hz=5.0)
    assert replay_life(loaded[6], run) == pytest.approx(replay_life(loaded[13], run), rel=1e-12)
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {**body, "effect_covariance": [0.0] * 37}}}))
    with pytest.raises(InputError, match="effect_covariance must be a list of 169 numbers"):
        wear_monitor_params([BENCH, bad])


@pytest.mark.parametrize("entries, message", [
    ({(1, 1): -0.01}, "the variance of running_in_ratio is negative"),
    ({(1, 1): 0.01, (2, 2): 100.0, (1, 2): 0.5}, "is not symmetric: (running_in_ratio, running_in_distance_m) 0.5"),
    ({(1, 1): 0.01, (2, 2): 100.0, (1, 2): 1.5, (2, 1): 1.5},
     "is not positive semidefinite (largest correlation: running_in_ratio with running_in_distance_m 1.5)"),
])
def test_a_model_file_covariance_that_is_no_covariance_is_one_line(tmp_path, capsys, entries, message):
    """A negative variance, an asymmetric matrix or correlations beyond +-1 (a hand-edited file) would give a
    narrowed or NaN interval without a word: one line naming the parameters, from the loader and the CLI."""
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    n = len(COVARIANCE_NAMES)
    cov = np.zeros((n, n))
    for (i, j), v in entries.items():
        cov[i, j] = v
    bad = tmp_path / "model.yaml"
    bad.write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {
        "effects": "running_in", "running_in_ratio": 2.0, "running_in_distance_m": 300.0,
        "effect_covariance": cov.ravel().tolist()}}}))
    with pytest.raises(InputError, match=re.escape(message)):
        wear_monitor_params([BENCH, bad])
    # the command's main() in this process (test_a_bad_model_file_is_one_line runs the refusal as a subprocess)
    from guide_health.cli.app import main

    code = main(["replay", str(tmp_path / "nobag"), "--params", str(BENCH), "--params", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert message in err


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(1, 13), st.integers(0, 2**32 - 1))
def test_covariance_rule_accepts_every_covariance_and_refuses_a_negative_direction(rank, seed):
    """covariance_problem: A A' (any rank, scales from 1e-14 to 1e4 as K's and s0's) passes; the same with
    one eigenvalue made negative by more than the tolerance is refused."""
    from guide_health.models.wear.effect_life import covariance_problem
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    n = len(COVARIANCE_NAMES)
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-7, 2, n)                  # sd of each parameter
    a = rng.normal(size=(n, rank)) * scale[:, None]
    cov = a @ a.T
    assert covariance_problem(cov.ravel()) == ""
    corr_sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(corr_sd, corr_sd)
    w, v = np.linalg.eigh(corr)
    w[0] = -0.01                                        # one direction of negative variance
    bent = (v * w) @ v.T * np.outer(corr_sd, corr_sd)
    bent = (bent + bent.T) / 2
    assert covariance_problem(bent.ravel()) != ""


def test_a_bad_model_file_is_one_line(tmp_path):
    bad = tmp_path / "model.yaml"
    bad.write_text("wear_monitor:\n  ros__parameters:\n    effects: running_in,initial_offset\n")
    with pytest.raises(InputError, match="not live effect 'initial_offset'"):
        wear_monitor_params([BENCH, bad])
    bad.write_text("wear_monitor:\n  ros__parameters:\n    running_in_ratio: -1.0\n")
    proc = cli("replay", str(tmp_path / "nobag"), "--params", str(BENCH), "--params", str(bad), check=False)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "running_in_ratio" in proc.stderr
    assert math.isfinite(wear_monitor_params([BENCH])["wear_coefficient"])


# --- live == offline with a model file -------------------------------------------------------------------

@pytest.mark.ros
def test_live_node_with_several_params_files_matches_replay(tmp_path, ros_test_env):
    """wear_monitor --params-file BASE --params-file model.yaml against replay --params BASE --params model.yaml
    on the same bag (1.5 h, running-in and retract asymmetry): same samples, straightness and remaining life
    with its interval to 0.5 %."""
    pytest.importorskip("rclpy")
    from guide_health.analysis.replay import analyse
    from guide_health.io.bag.reader import read_machine_bag
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.nodes.session import bag_counts, settled_status_after_bag

    env = ros_test_env()
    base = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=1.5, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    run = simulate_machine(base, sim, seed=7, effects={"running_in": 2.0, "retract_asymmetry": 0.5})
    bag = tmp_path / "bench"
    write_machine_bag(run, bag)
    model = tmp_path / "model.yaml"
    cov = np.diag([(0.02 * 4.4e-6) ** 2, 0.1 ** 2, 30.0 ** 2, 0.05 ** 2, 0.0, 0.0, 0.0, 0.0, 0.0]).ravel().tolist()
    model.write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {
        "wear_coefficient": 4.4e-6, "effects": "running_in,retract_asymmetry", "running_in_ratio": 2.0,
        "running_in_distance_m": 300.0, "retract_wear_factor": 0.5, "retract_direction": "-x",
        "effect_covariance": cov}}}))
    offline = analyse(read_machine_bag(bag, joint="x"), wear_monitor_params([BENCH, model]))[1]
    live = settled_status_after_bag("guide_health.nodes.wear_monitor", [BENCH, model],
                                    {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25}, env,
                                    bag, "bench_000/wear_monitor: x precision", tmp_path / "node.log",
                                    collector_name="test_collector_model", counts=bag_counts(offline))
    values = {k: float(v) for k, v in live["values"].items()
              if k not in ("lubrication_regime", "load_source", "model_fit") and "_utc" not in k}   # the numbers
    assert values["samples"] == offline["samples"]
    assert values["measurements"] == offline["measurements"]
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
                "wear_coefficient"):
        assert values[key] == pytest.approx(offline[key], rel=0.005), key
    plain = analyse(read_machine_bag(bag, joint="x"), base)[1]
    assert abs(plain["wear_coefficient"] / offline["wear_coefficient"] - 1.0) > 0.05    # the file matters


# --- the forecast plot ------------------------------------------------------------------------------------

def test_forecast_reaches_the_limit_at_the_remaining_life_and_diagnose_agrees(tmp_path):
    """Seed 1 of the running-in bench: the replay forecast (with the model file) reaches the limit at the
    remaining life, its band edges at the interval's ends, the date is the bag's stamp + life; diagnose's own
    forecast (fitted model, last quarter's rate) agrees with the replay's life to 3 % and with the truth to
    10 %; both PNGs are written."""
    from guide_health.analysis.discrepancy.report import write_report
    from guide_health.analysis.replay import analyse, write_outputs
    from guide_health.analysis.report_plots import when_text

    params, run, result = diagnosed_running_in(1)       # the diagnose of the default-seeds test
    truth = true_remaining_life_h(run, params["straightness_limit_m"])
    monitor, report = analyse(run, {**params, **result["model_file"]})
    fc = monitor.forecast()
    life = report["remaining_life_h"]
    assert np.interp(params["straightness_limit_m"] * 1e6 - 1e-9, fc["mid_um"], fc["horizon_h"]) == \
        pytest.approx(life, abs=fc["horizon_h"][1])      # to one grid step
    assert fc["fast_um"][np.searchsorted(fc["horizon_h"], report["remaining_life_h_low"]) - 1] < 100.0
    assert fc["slow_um"][-1] == pytest.approx(100.0)
    assert fc["now_h"] == pytest.approx(20.0, abs=0.01)
    assert when_text(fc["now_ns"], life).endswith("UTC")
    assert result["forecast"]["life_h"] == pytest.approx(life, rel=0.03)
    assert result["forecast"]["life_h"] == pytest.approx(truth, rel=0.10)
    assert result["forecast"]["life_low_h"] < result["forecast"]["life_h"] < result["forecast"]["life_high_h"]
    files = write_outputs(tmp_path / "replay", monitor, report, plot=True)
    assert Path(files["png"]).stat().st_size > 10_000
    files = write_report(result, tmp_path / "diag", bag="bench", with_plot=True)
    assert Path(files["png"]).stat().st_size > 10_000


# --- a regrind: the new surface runs in again ---------------------------------------------------------------

def _tail_from(run, t_ns: int):
    """The run from its last joint sample at or before ``t_ns`` (the new guide's first sample), with the load
    then in force; straightness measurements stamped after ``t_ns``."""
    j = int(np.searchsorted(run.joint_t_ns, t_ns, side="right")) - 1
    ld = int(np.searchsorted(run.load_t_ns, run.joint_t_ns[j], side="right")) - 1
    st = int(np.searchsorted(run.straightness_t_ns, t_ns, side="right"))
    return dataclasses.replace(
        run, joint_t_ns=run.joint_t_ns[j:], joint_position_m=run.joint_position_m[j:],
        joint_velocity_m_s=run.joint_velocity_m_s[j:], load_t_ns=run.load_t_ns[ld:], load_n=run.load_n[ld:],
        straightness_t_ns=run.straightness_t_ns[st:], straightness_m=run.straightness_m[st:])


def test_a_regrind_restarts_running_in_as_on_a_new_guide():
    """Bench with running-in (3 h, 2 Hz), reground at 1.7 h to 20 um: after the regrind the effect-aware model
    (AxisMonitor, the node's and replay's object, event from the bag) equals a new guide's model built
    independently (prior K = the old surface's posterior, A0 = 20 um known, fed from the regrind on) to 1e-9: the
    running-in distance counts from the regrind, and the file's A0 variance, which moves the interval before
    the regrind, no longer applies after it (A0 measured). The per-sample path gives the same. Control: the new
    surface's effective work is > 1.3x its Archard work (running-in is visible, so a kept counter would be
    seen)."""
    from guide_health.models.wear.axis import AxisMonitor, split_run
    from guide_health.models.wear.maintenance import MaintenanceEvent

    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=3.0, joint_state_rate_hz=2.0, load_rate_hz=1.0)
    run = simulate_machine(params, sim, seed=5, effects={"running_in": 2.5})
    variances = [(0.01 * 4.42e-6) ** 2, 0.1 ** 2, 20.0 ** 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, (0.4e-6) ** 2]
    live = {**params, "stroke_min_m": 0.1, "stroke_max_m": 0.3, "effects": "running_in", "running_in_ratio": 2.5,
            "running_in_distance_m": 300.0, "effect_covariance": np.diag(variances).ravel().tolist()}
    # the file's A0 (fitted, sd 0.4 um) is replaced by the measured 20 um: its variance no longer applies
    a0_known = {**live, "effect_covariance": np.diag(variances[:-1] + [0.0]).ravel().tolist()}
    t_regrind = int(run.joint_t_ns[0]) + int(1.7 * 3600e9) + 123_456_789
    event = MaintenanceEvent(t_regrind, "regrind", params["joint"], straightness_m=20e-6)
    axis = AxisMonitor(wear_axis_params(live))
    axis.schedule(event)
    axis.process_run(run)
    reground = axis.primary
    old = PrecisionMonitor(wear_axis_params(live))
    old.process_run(split_run(run, t_regrind)[0])
    k, k_sd, _ = old.estimator.posterior(old.measurement_losses_per_k_m())
    before = PrecisionMonitor(wear_axis_params(a0_known))
    before.process_run(split_run(run, t_regrind)[0])
    assert old.report()["remaining_life_h_high"] != pytest.approx(before.report()["remaining_life_h_high"], rel=1e-3)
    new = PrecisionMonitor(wear_axis_params({**a0_known, "wear_coefficient": k,
                                             "wear_coefficient_prior_rel_sd": k_sd / k,
                                             "straightness_initial_m": 20e-6}))
    new.process_run(_tail_from(run, t_regrind))
    assert new.estimator.count == 3 and reground.estimator.count == 3
    assert reground.effect_wear.effective_work_nm == pytest.approx(new.effect_wear.effective_work_nm, rel=1e-9)
    assert new.effect_wear.effective_work_nm > 1.3 * new.integrator.archard_work_nm
    a, b = reground.report(), new.report()
    for key in ("straightness_um", "wear_volume_mm3", "remaining_life_h", "remaining_life_h_low",
                "remaining_life_h_high", "wear_coefficient"):
        assert a[key] == pytest.approx(b[key], rel=1e-9), key
    # live: the node's per-sample path over the same bag and event
    per_sample = AxisMonitor(wear_axis_params(live))
    per_sample.schedule(event)
    feed_per_sample(per_sample, run)
    c = per_sample.primary.report()
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"):
        assert c[key] == pytest.approx(a[key], rel=1e-6), key


def test_simulated_regrind_runs_in_again_as_the_live_model():
    """The simulator's truth after a regrind (simulate_machine new_surface_t_s + apply_maintenance_truth, as
    `simulate --effect running_in=2.5 --maintenance regrind:x@2.3h=15um`) and the live model with the true K
    and effect, reground by the same event, agree at every measurement after it to 0.3 % of the wear since
    (the exact motion against 50 Hz samples: measured 0.16 %); a truth whose running-in went on (no new
    surface) does not (measured 103 %)."""
    from guide_health.models.wear.axis import AxisMonitor
    from guide_health.models.wear.maintenance import MaintenanceEvent
    from guide_health.sim.machine import START_TIME_NS, apply_maintenance_truth

    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=4.0, joint_state_rate_hz=50.0, load_rate_hz=1.0,
               straightness_noise_m=0.0)
    t_regrind = START_TIME_NS + int(2.3 * 3600e9)
    event = MaintenanceEvent(t_regrind, "regrind", params["joint"], straightness_m=15e-6)
    k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    errors = {}
    for restart in (True, False):
        run = simulate_machine(params, sim, seed=2, effects={"running_in": 2.5},
                               new_surface_t_s=[2.3 * 3600.0] if restart else ())
        apply_maintenance_truth(run, [event], params)
        truth = run.metadata["truth"]
        live = {**params, "stroke_min_m": truth["stroke_min_m"], "stroke_max_m": truth["stroke_max_m"],
                "sliding_deadband_m": 0.0, "effects": "running_in", "running_in_ratio": 2.5,
                "running_in_distance_m": sim["running_in_distance_m"]}
        axis = AxisMonitor(wear_axis_params(live))
        axis.schedule(event)
        axis.process_run(run)
        monitor = axis.primary
        got = monitor.straightness_m(k, monitor.measurement_losses_per_k_m())
        after = np.asarray(truth["straightness_m"])[-got.size:]
        assert got.size == 4
        errors[restart] = float(np.max(np.abs(got - after) / (after - 15e-6)))
    assert errors[True] < 3e-3 < errors[False], errors


def test_every_fitted_effect_value_passes_the_live_schema():
    """diagnose's fit bounds (analysis/discrepancy/model.py ParamSpec) against the wear_monitor ranges: a
    model file from any fit loads (a lubrication growth of -0.31 made `diagnose --out` exit 2 before stop
    11). Each live parameter at both ends of its fit bounds is accepted by the schema."""
    from guide_health.analysis.discrepancy.duty import duty_cells_from_runs as cells_of
    from guide_health.analysis.discrepancy.model import WearProblem, _effect_specs
    from guide_health.analysis.discrepancy.model_file import COVARIANCE_ALIASES, EFFECT_PARAMETERS
    from guide_health.params import validate_wear_params

    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=4.0, joint_state_rate_hz=5.0, load_rate_hz=5.0)
    run = simulate_machine(params, sim, seed=1)
    for relube in (None, [3600.0]):
        problem = WearProblem(cells_of(run, params["slider_length_m"]), params, relubrication_t_s=relube)
        for effect, specs in _effect_specs(problem).items():
            live = set(EFFECT_PARAMETERS.get(effect, ())) | ({"lubrication_wear_growth"} if effect ==
                                                             "lubrication_interval" else set())
            for spec in specs:
                name = COVARIANCE_ALIASES.get(spec.name, spec.name)
                if name not in live:
                    continue
                for value in (spec.lower, spec.upper):
                    validate_wear_params({**params, name: value})
