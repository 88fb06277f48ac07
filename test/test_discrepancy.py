"""The discrepancy workflow (issue: find the missing physics, add it, show the gap shrink).

Scenario: config/machine_jobs.yaml (jobs of ~3 h with their own feed speed, cutting load, table load and
stroke distribution; rapid, light retract; temperature recorded; straightness every 10 min). Every run
draws the effect strength and the measurement noise from the ranges below (docs/discrepancy.md); the
effect name is never passed to the workflow.

The acceptance's truth is test/reference_wear.py, written separately from the candidate terms
(models/wear/effects/, analysis/discrepancy/): the bag's motion, load and temperature come from the
simulator, the straightness from the reference integration over the bag's samples, plus the simulator's
noise. The hidden s0 and W_ref are never handed to the fit. test_candidate_model_is_the_simulated_physics
keeps the shared-function consistency check beside it.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate
from scipy.optimize import least_squares

from guide_health.analysis.discrepancy.duty import DutyCellAccumulator, duty_cells_from_runs
from guide_health.analysis.discrepancy.model import WearProblem
from guide_health.analysis.discrepancy.selection import forward_selection, select_pin_on_disc_law
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.cli.app import main
from guide_health.models.wear import effects as we
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.runs import MachineRun
from guide_health.sim.machine import simulate_machine, true_straightness_loss_per_k_m
from guide_health.sim.motion import cycle_knots

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_wear as ref  # noqa: E402
from case_pool import case_pool  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"
BENCH = ROOT / "config" / "bench_000.yaml"
SEEDS = 10
RATE_HZ = 20.0

# realistic ranges the tests draw from (README, discrepancy section)
NOISE_RANGE_M = (0.2e-6, 0.4e-6)


def draw_effect(name: str, rng: np.random.Generator, sim: dict) -> dict:
    if name == "running_in":
        sim["running_in_distance_m"] = rng.uniform(300.0, 1000.0)
        return {name: rng.uniform(1.0, 3.0)}
    if name == "retract_asymmetry":
        return {name: rng.uniform(0.0, 0.3)}
    if name == "speed_dependent_wear":
        return {name: float(np.exp(rng.uniform(np.log(0.02), np.log(0.06))))}
    if name == "load_exponent":
        return {name: rng.uniform(1.4, 2.0)}
    if name == "stroke_distribution":
        return {name: rng.uniform(0.6, 1.0)}
    if name == "thermal_drift":
        return {name: float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5e-6, 1.5e-6))}
    if name == "initial_offset":
        return {name: float(rng.choice([-1.0, 1.0]) * rng.uniform(2e-6, 6e-6))}
    raise ValueError(name)


def reference_run(params: dict, sim: dict, seed: int, effects: dict) -> MachineRun:
    """The simulator's bag with its straightness replaced by the independent reference truth
    (test/reference_wear.py) plus the same noise draw."""
    run = simulate_machine(params, sim, seed=seed, effects=effects)
    truth = run.metadata["truth"]
    noise = run.straightness_m - np.asarray(truth["straightness_m"])
    hidden = ref.hidden_from_effects(effects, sim["running_in_distance_m"], sim["load_reference_n"])
    y = ref.reference_straightness_m(
        run, hidden, wear_coefficient=params["wear_coefficient"] * sim["wear_coefficient_factor"],
        hardness_pa=params["hardness_pa"], contact_width_m=params["contact_width_m"],
        slider_length_m=params["slider_length_m"], straightness_initial_m=params["straightness_initial_m"],
        stroke_sum_m=truth["stroke_min_m"] + truth["stroke_max_m"])
    run.straightness_m = y + noise
    run.metadata = dict(run.metadata, truth=dict(truth, straightness_m=y.tolist()))
    return run


def hidden_effect_case(args):
    """One run: simulate with the hidden effect(s), run the selection, return what was named."""
    scenario, seed = args
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim["joint_state_rate_hz"] = sim["load_rate_hz"] = RATE_HZ
    rng = np.random.default_rng(1000 + seed)
    sim["straightness_noise_m"] = rng.uniform(*NOISE_RANGE_M)
    effects = {}
    for name in [s for s in scenario.split("+") if s]:
        effects.update(draw_effect(name, rng, sim))
    run = reference_run(params, sim, seed, effects)
    problem = WearProblem(duty_cells_from_runs(run, params["slider_length_m"]), params)
    sel = forward_selection(problem.fit, problem.available_effects())
    return {"scenario": scenario, "seed": seed, "effects": effects, "named": sel.named,
            "baseline_heldout_um": sel.baseline.heldout_rmse_um, "final_heldout_um": sel.final.heldout_rmse_um,
            "values": sel.final.values, "running_in_distance_m": sim["running_in_distance_m"]}


SINGLE = ["running_in", "retract_asymmetry", "speed_dependent_wear", "load_exponent", "stroke_distribution",
          "thermal_drift", "initial_offset"]
DOUBLE = "running_in+retract_asymmetry"


#: the small twin of the sweep in the default run: one seed per scenario (seed 1; the double effect's seed 0,
#: as seed 1 names speed_dependent_wear beside running_in), checked by the sweep's per-run rules
TWIN_SEEDS = {**{s: 1 for s in SINGLE + [""]}, DOUBLE: 0}
#: a named effect's fitted parameter against the hidden value: absolute tolerance, about twice the largest
#: error seen over the 10 seeds (2026-11-23): a wrong exponent or factor in a candidate term shifts the
#: fitted value by more (e.g. 0.7 -> 0.5 in the film-speed exponent moves v_lift by > 50 %)
ABSOLUTE_TOLERANCE = {"retract_asymmetry": ("retract_wear_factor", 0.15), "load_exponent": ("load_exponent", 0.1),
                      "initial_offset": ("initial_offset_m", 0.2e-6),
                      "thermal_drift": ("thermal_drift_m_per_k", 0.08e-6),
                      "stroke_distribution": ("stroke_distribution_weight", 0.06),
                      "running_in": ("running_in_ratio", 0.2)}
#: relative: s0 of running-in (median within 5 %, worst 30 %), v_lift of the speed-dependent wear (10 %, 40 %)
RELATIVE_TOLERANCE = (("running_in", "running_in_distance_m", lambda r: r["running_in_distance_m"], 0.05, 0.3),
                      ("speed_dependent_wear", "lift_speed_m_s", lambda r: r["effects"]["speed_dependent_wear"],
                       0.1, 0.4))


def run_cases(cases: list[tuple[str, int]]) -> dict:
    """The hidden-effect runs of (scenario, seed), two processes, grouped by scenario."""
    with case_pool() as pool:
        rows = pool.map(hidden_effect_case, cases)
    out = {}
    for r in rows:
        out.setdefault(r["scenario"], []).append(r)
    for scenario, rs in out.items():     # the figures for the closing note (pytest -s)
        print(f"\n{scenario or 'clean'}: named " + "; ".join(",".join(r["named"]) or "-" for r in rs))
    return out


@pytest.fixture(scope="module")
def sweep():
    """All hidden-effect runs (10 seeds each)."""
    return run_cases([(s, seed) for s in SINGLE + ["", DOUBLE] for seed in range(SEEDS)])


@pytest.fixture(scope="module")
def twin():
    """The sweep's small twin: one run per scenario (TWIN_SEEDS)."""
    return {s: rows[0] for s, rows in run_cases(list(TWIN_SEEDS.items())).items()}


# --- physics of the effect terms ---------------------------------------------------------------


def test_running_in_mean_factor_is_the_exact_integral():
    r, s0, a, b = 2.0, 150.0, 40.0, 95.0
    numeric = integrate.quad(lambda s: 1 + r * math.exp(-s / s0), a, b)[0] / (b - a)
    assert we.running_in_factor_mean(np.array([a]), np.array([b]), r, s0)[0] == pytest.approx(numeric, rel=1e-12)
    # a cell with uniform spread of sliding distance: sinh(h)/h correction
    mean, half = 300.0, 60.0
    exact = integrate.quad(lambda s: 1 + r * math.exp(-s / s0), mean - half, mean + half)[0] / (2 * half)
    got = we.running_in_factor_spread(np.array([mean]), np.array([half ** 2 / 3.0]), r, s0)[0]
    assert got == pytest.approx(exact, rel=1e-12)


def test_effect_multipliers_limits():
    v = np.array([0.0, 0.05, 1e3])
    share = we.asperity_load_share(v, 0.05)
    assert share[0] == 1.0 and share[1] == pytest.approx(0.5) and share[2] < 1e-3
    assert np.all(we.asperity_load_share(v, math.inf) == 1.0)
    assert we.load_exponent_factor(np.array([2000.0]), 1.7, 2000.0)[0] == pytest.approx(1.0)
    assert we.load_exponent_factor(np.array([4000.0]), 2.0, 2000.0)[0] == pytest.approx(2.0)
    # a full pass of any length >= the slider adds W per unit of Archard work / L
    assert we.pass_weight_per_m(np.array([0.3, 0.05]), 0.1).tolist() == pytest.approx([1 / 0.3, 1 / 0.1])
    m = we.wear_rate_multiplier(we.EffectParameters(retract_wear_factor=0.25), np.array([0.1, 0.1]),
                                np.array([1e3, 1e3]), np.array([False, True]))
    assert m.tolist() == [1.0, 0.25]


def test_truth_without_effects_is_eq7_of_the_monitor_family():
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    knots = cycle_knots(np.random.default_rng(3), sim)
    at = np.arange(0.0, knots.t_s[-1], 1800.0)
    per_k = true_straightness_loss_per_k_m(params, knots.t_s, knots.x_m, knots.load_n, at, knots.strokes_m)
    from guide_health.sim.machine import effective_work_at
    g, _ = effective_work_at(knots, at, we.EffectParameters(), params["slider_length_m"])
    eq7 = we.straightness_wear_m(1.0, params["hardness_pa"], params["contact_width_m"], g, g,
                                 float(knots.strokes_m.min() + knots.strokes_m.max()))
    assert np.allclose(eq7, per_k, rtol=1e-9, atol=1e-15)
    assert len(knots.jobs) >= 5
    assert np.ptp([j["feed_speed_m_s"] for j in knots.jobs]) > 0.02        # the duty varies between jobs
    assert np.ptp([j["feed_load_n"] for j in knots.jobs]) > 2000.0
    assert all(j["retract_load_n"] <= j["feed_load_n"] for j in knots.jobs)


def test_candidate_model_is_the_simulated_physics():
    """With the true parameters the workflow's model reproduces the noise-free truth (every effect on)."""
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(joint_state_rate_hz=RATE_HZ, load_rate_hz=RATE_HZ, straightness_noise_m=0.0, running_in_distance_m=400.0)
    eff = {"running_in": 2.0, "retract_asymmetry": 0.3, "speed_dependent_wear": 0.05, "load_exponent": 1.5,
           "stroke_distribution": 0.7, "thermal_drift": 1e-6, "initial_offset": 3e-6}
    run = simulate_machine(params, sim, seed=3, effects=eff)
    problem = WearProblem(duty_cells_from_runs(run, params["slider_length_m"]), params)
    problem.fit_references["load_reference_n"] = sim["load_reference_n"]
    values = dict(wear_coefficient=params["wear_coefficient"], running_in_ratio=2.0, running_in_distance_m=400.0,
                  retract_wear_factor=0.3, lift_speed_m_s=0.05, load_exponent=1.5, stroke_distribution_weight=0.7,
                  thermal_drift_m_per_k=1e-6, initial_offset_m=3e-6)
    truth = np.asarray(run.metadata["truth"]["straightness_m"])
    err = np.abs(problem.predict_m(values) - truth)
    # sampling at 20 Hz (reversals inside a sample interval) is the only difference: < 1 % of the loss
    assert err.max() < 0.01 * (truth[-1] - truth[0])
    assert err.max() < 0.4e-6


def test_duty_cells_do_not_depend_on_chunking():
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(duration_h=3.0, joint_state_rate_hz=10.0, load_rate_hz=10.0)
    run = simulate_machine(params, sim, seed=1)
    whole = duty_cells_from_runs(run, params["slider_length_m"])
    acc = DutyCellAccumulator(params["slider_length_m"])
    cuts = [0, 777, 20000, 20001, 55555, run.joint_t_ns.size]
    bounds = [-1] + [int(run.joint_t_ns[b - 1]) for b in cuts[1:-1]] + [2 ** 62]

    def part(t, lo, hi):
        return (t > lo) & (t <= hi)

    for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        lo, hi = bounds[i], bounds[i + 1]
        ls, ss, ts = (part(run.load_t_ns, lo, hi), part(run.straightness_t_ns, lo, hi),
                      part(run.temperature_t_ns, lo, hi))
        acc.add(MachineRun(joint_t_ns=run.joint_t_ns[a:b], joint_position_m=run.joint_position_m[a:b],
                           load_t_ns=run.load_t_ns[ls], load_n=run.load_n[ls],
                           straightness_t_ns=run.straightness_t_ns[ss], straightness_m=run.straightness_m[ss],
                           temperature_t_ns=run.temperature_t_ns[ts], temperature_c=run.temperature_c[ts]))
    chunked = acc.finish()
    assert chunked.segments == whole.segments
    assert chunked.total_distance_m == pytest.approx(whole.total_distance_m, rel=1e-12)
    assert np.sort(chunked.pass_lengths_m) == pytest.approx(np.sort(whole.pass_lengths_m), rel=1e-9)
    for name in ("work_nm", "pass_work_n", "distance_m"):
        assert getattr(chunked, name).sum() == pytest.approx(getattr(whole, name).sum(), rel=1e-12)
    p1, p2 = WearProblem(whole, params), WearProblem(chunked, params)
    assert p1.predict_m({"wear_coefficient": 4e-6}) == pytest.approx(p2.predict_m({"wear_coefficient": 4e-6}), rel=1e-9)


# --- acceptance: hidden effects ---------------------------------------------------------------


@pytest.mark.parametrize("effect", SINGLE)
def test_hidden_effect_is_named_alone_with_its_value_on_one_seed(twin, effect):
    """The sweep's per-run rules on one seed: the effect named alone, the held-out gap at least halved, the
    fitted parameter within the sweep's tolerance of the hidden value (the 10-seed counts are `slow`)."""
    r = twin[effect]
    assert r["named"] == [effect]
    assert r["final_heldout_um"] <= 0.5 * r["baseline_heldout_um"]
    if effect in ABSOLUTE_TOLERANCE:
        param, tol = ABSOLUTE_TOLERANCE[effect]
        assert r["values"][param] == pytest.approx(r["effects"][effect], abs=tol)
    for name, param, hidden_of, _, worst_tol in RELATIVE_TOLERANCE:
        if name == effect:
            assert abs(r["values"][param] / hidden_of(r) - 1.0) < worst_tol


def test_clean_control_and_two_hidden_effects_on_one_seed(twin):
    """The sweep's control and double-effect rules on one seed each: nothing named and K within 10 % of
    seed 000's 4.42e-6 without an effect; both effects named when two are hidden."""
    assert twin[""]["named"] == []
    assert abs(twin[""]["values"]["wear_coefficient"] / 4.42e-6 - 1) < 0.1
    assert {"running_in", "retract_asymmetry"} <= set(twin[DOUBLE]["named"])


@pytest.mark.slow
@pytest.mark.parametrize("effect", SINGLE)
def test_hidden_effect_is_named_and_the_heldout_gap_halves(sweep, effect):
    rows = sweep[effect]
    named = sum(effect in r["named"] for r in rows)
    ratios = np.array([r["final_heldout_um"] / r["baseline_heldout_um"] for r in rows])
    pooled = math.sqrt(np.mean([r["final_heldout_um"] ** 2 for r in rows])
                       / np.mean([r["baseline_heldout_um"] ** 2 for r in rows]))
    print(f"\n{effect}: named {named}/{len(rows)}, held-out RMSE after/before per seed "
          f"{np.round(ratios, 2).tolist()}, pooled {pooled:.3f}")
    assert named >= 9
    assert pooled <= 0.5
    assert np.median(ratios) <= 0.5


@pytest.mark.slow
def test_clean_controls_name_nothing(sweep):
    rows = sweep[""]
    assert sum(not r["named"] for r in rows) >= 9
    # and K is recovered as a calibration
    k = np.array([r["values"]["wear_coefficient"] for r in rows])
    assert np.all(np.abs(k / 4.42e-6 - 1) < 0.1)


@pytest.mark.slow
def test_two_hidden_effects_are_both_named(sweep):
    rows = sweep[DOUBLE]
    both = sum({"running_in", "retract_asymmetry"} <= set(r["named"]) for r in rows)
    assert both >= 8


@pytest.mark.slow
def test_fitted_effect_parameters_match_the_hidden_ones(sweep):
    """In every run where the effect is named alone (at least 9 of 10), its fitted parameter is the hidden
    value of the independent truth (physics, not a curve), within ABSOLUTE_TOLERANCE / RELATIVE_TOLERANCE."""
    for effect, (param, tol) in ABSOLUTE_TOLERANCE.items():
        alone = [r for r in sweep[effect] if r["named"] == [effect]]
        assert len(alone) >= 9, (effect, len(alone))
        for r in alone:
            assert r["values"][param] == pytest.approx(r["effects"][effect], abs=tol), (effect, r["seed"])
    for effect, param, hidden_of, median_tol, worst_tol in RELATIVE_TOLERANCE:
        alone = [r for r in sweep[effect] if r["named"] == [effect]]
        assert len(alone) >= 9, (effect, len(alone))
        rel = np.array([abs(r["values"][param] / hidden_of(r) - 1.0) for r in alone])
        assert np.median(rel) < median_tol and rel.max() < worst_tol, (effect, rel.round(3).tolist())


# --- seed 000 pin-on-disc through the same selection ------------------------------------------


def test_pin_on_disc_wear_law_needs_no_exponent():
    rows = np.genfromtxt(ROOT / "config" / "pin_on_disc_seed000.csv", delimiter=",", names=True)
    res = select_pin_on_disc_law(rows["speed_m_s"], rows["load_n"], rows["wear_rate_m3_s"])
    assert res["named_effects"] == []
    cand = {c["effect"]: c for c in res["candidates"]}
    # independent truth: the relative-residual least-squares fit of gamma = k W^n v (and k W v^m) written
    # here (1.0506, 1.0276; a log-log fit gives 1.053, 1.012, within a tenth of the standard errors)
    for name, x, y in (("load_exponent", rows["load_n"], rows["speed_m_s"]),
                       ("speed_exponent", rows["speed_m_s"], rows["load_n"])):
        g = rows["wear_rate_m3_s"]
        scale = g.mean() / (x.mean() * y.mean())
        own = least_squares(lambda p, x=x, y=y, g=g, c=scale: p[0] * c * x ** p[1] * y / g - 1.0,
                            [1.0, 1.0]).x[1]
        got = cand[name]["parameters"][name]
        assert got["value"] == pytest.approx(own, abs=0.005), name
        loglog = np.polyfit(np.log(x), np.log(g / y), 1)[0]
        assert abs(got["value"] - loglog) < 0.25 * got["std_error"], name
    assert cand["load_exponent"]["delta_bic"] > 0 and cand["speed_exponent"]["delta_bic"] > 0
    assert cand["load_exponent"]["loo_rms_rel_error"] > res["baseline"]["loo_rms_rel_error"]
    # the machinery can say yes: the same rows with the wear rate made proportional to W^1.6
    gamma = rows["wear_rate_m3_s"] * (rows["load_n"] / 37.5) ** 0.6
    assert "load_exponent" in select_pin_on_disc_law(rows["speed_m_s"], rows["load_n"], gamma)["named_effects"]


# --- bags and the command line ------------------------------------------------------------------


def cli(*args, check=True):
    """`guide-health ARGS` in its own interpreter: exit code, stdout and stderr as a user sees them."""
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", *args], capture_output=True, text=True,
                          timeout=600)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def cli_here(*args, check=True):
    """The same command through main() in this process (what the console script runs, without starting an
    interpreter and importing numpy/scipy per call): a CompletedProcess-like (returncode, stdout, stderr).
    An argparse refusal (SystemExit) is its exit code."""
    out, err = io.StringIO(), io.StringIO()
    shown = warnings.showwarning            # main() sets its one-line warning format: restored after
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = exc.code
        finally:
            warnings.showwarning = shown
    proc = subprocess.CompletedProcess(list(args), code, out.getvalue(), err.getvalue())
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def test_bench_bag_with_running_in_gets_below_the_seeds_22_percent(tmp_path):
    """Seed 000's bench (6000 N, 0.05 m/s, strokes 100..300 mm, straightness every 0.5 h) with running-in
    hidden: diagnose names it and the steady-stage max relative error drops below the seed's 22 %. simulate runs
    as a command (its own interpreter), diagnose through main() in this process (its exit-2 line runs as a
    command in test_diagnose_bad_input_is_one_line_exit_2)."""
    bag = tmp_path / "bench_running_in"
    cli("simulate", "--params", str(BENCH), "--out", str(bag), "--rate", "10", "--seed", "2",
        "--effect", "running_in=2.5")
    out = json.loads(cli_here("diagnose", str(bag), "--params", str(BENCH), "--out", str(tmp_path / "rep"),
                              "--json").stdout)
    assert out["named_effects"] == ["running_in"]
    steady = out["steady_stage"]
    assert steady["final_max_rel_error"] < 0.22
    assert steady["final_max_rel_error"] < steady["baseline_max_rel_error"]
    # hidden r = 2.5 (seed 2: fitted 2.40 +- 0.11). 10 % and 3 standard errors: a candidate fitting r - 1
    # (1.5) or 2r, or a running-in decay over time instead of sliding distance, falls outside; rel=0.5 let
    # 1.25..3.75 pass. (s0 is not asserted here: the bench's default s0 = 100 m is shorter than the 90 m of
    # sliding between two measurements, so it is poorly identified; the sweep checks s0 over 300..1000 m.)
    ratio = out["effects"]["running_in"]["parameters"]["running_in_ratio"]
    assert ratio["value"] == pytest.approx(2.5, rel=0.1)
    assert abs(ratio["value"] - 2.5) < 3 * ratio["std_error"]
    for key in ("rmse_um", "max_rel_error", "heldout_rmse_um"):
        assert out["final"][key] < out["baseline"][key]
    assert {c["effect"] for c in out["candidates"] if c["round"] == 1} == {
        "running_in", "retract_asymmetry", "speed_dependent_wear", "load_exponent", "stroke_distribution",
        "initial_offset", "wear_rate_change", "lubrication_interval", "load_along_rail"}   # no temperature: no thermal
    rep = tmp_path / "rep"
    assert (rep / "diagnose.png").stat().st_size > 10_000
    assert "running_in" in (rep / "report.md").read_text()
    saved = json.loads((rep / "report.json").read_text())
    assert saved["named_effects"] == ["running_in"]


def test_diagnose_mcap_bag_with_thermal_drift_and_where_it_disagrees(tmp_path):
    """machine_jobs (20 h, seed 5) with a thermal drift of 1.2e-6 m/K hidden, written as an mcap bag and
    diagnosed (simulate and diagnose through main() in this process; the bench test above runs simulate as a
    command): thermal_drift named, its value within 3 standard errors + 0.05 um/K, the baseline's misfit
    placed on the temperature. The load sensor at the JointState's 10 Hz (the in-process runs' rate) instead
    of the file's 50 Hz: a third of the messages, the same answer (measured: 1.2134e-6 +- 1.8e-8 m/K, held-out
    ratio 0.099; at 50 Hz 1.2128e-6 +- 1.8e-8, 0.098)."""
    jobs_10_hz = tmp_path / "machine_jobs_load_10_hz.yaml"
    text = JOBS.read_text()
    assert text.count("load_rate_hz: 50.0") == 1
    jobs_10_hz.write_text(text.replace("load_rate_hz: 50.0", "load_rate_hz: 10.0"))
    bag = tmp_path / "jobs_thermal"
    cli_here("simulate", "--params", str(jobs_10_hz), "--out", str(bag), "--rate", "10", "--seed", "5",
             "--storage", "mcap", "--effect", "thermal_drift=1.2e-6")
    out = json.loads(cli_here("diagnose", str(bag), "--params", str(JOBS), "--no-plot", "--json").stdout)
    assert out["named_effects"] == ["thermal_drift"]
    drift = out["effects"]["thermal_drift"]["parameters"]["thermal_drift_m_per_k"]
    assert drift["value"] == pytest.approx(1.2e-6, abs=3 * drift["std_error"] + 0.05e-6)
    where = out["where_baseline_disagrees"]
    assert "temperature_k" in where["systematic_conditions"]
    assert out["final"]["heldout_rmse_um"] / out["baseline"]["heldout_rmse_um"] < 0.5
    assert out["data"]["temperature_recorded"] is True


def test_diagnose_bad_input_is_one_line_exit_2(tmp_path):
    """The missing bag through the command (its own interpreter: nothing else on stderr), the other refusals
    through main() in this process."""
    proc = cli("diagnose", str(tmp_path / "missing"), "--params", str(JOBS), check=False)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    proc = cli_here("diagnose", str(tmp_path), "--params", str(JOBS), "--heldout-fraction", "2", check=False)
    assert proc.returncode == 2 and "heldout" in proc.stderr
    # a bag without straightness measurements
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(duration_h=0.5, joint_state_rate_hz=5.0, load_rate_hz=5.0, measurement_interval_h=10.0)
    from guide_health.io.bag.writer import write_machine_bag
    run = simulate_machine(params, sim, seed=0)
    write_machine_bag(run, tmp_path / "few")
    proc = cli_here("diagnose", str(tmp_path / "few"), "--params", str(JOBS), check=False)
    assert proc.returncode == 2 and "at least 6 straightness measurements" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_simulate_effect_names_and_values_are_checked(tmp_path):
    for bad, text in (("friction=1", "unknown effect"), ("running_in", "NAME=VALUE"),
                      ("load_exponent=abc", "not a number"), ("initial_offset=nan", "finite"),
                      ("wear_rate_change=-1", "must be in (0, 100]"),
                      ("lubrication_interval=-1e-5", "must be in [0, 0.01] 1/s"),
                      ("speed_dependent_wear=0", "must be in (0, 100] m/s")):
        proc = cli_here("simulate", "--params", str(JOBS), "--out", str(tmp_path / "x"), "--effect", bad,
                        check=False)
        assert proc.returncode == 2 and text in proc.stderr, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "x").exists(), proc.stderr


def test_diagnose_cells_result_keys():
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(joint_state_rate_hz=10.0, load_rate_hz=10.0)
    run = simulate_machine(params, sim, seed=7, effects={"initial_offset": -4e-6})
    res = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
    assert res["named_effects"] == ["initial_offset"]
    offset = res["effects"]["initial_offset"]["parameters"]["initial_offset_m"]
    assert offset["value"] == pytest.approx(-4e-6, abs=max(3 * offset["std_error"], 0.3e-6))
    for part in ("baseline", "final"):
        assert {"rmse_um", "max_rel_error", "heldout_rmse_um"} <= set(res[part])
    assert all("score" in c for c in res["candidates"])
    assert res["data"]["retract_direction"] == "-x"


def test_unknown_initial_straightness_is_part_of_the_baseline():
    """straightness_initial_m = 0: the baseline fits A0 with K, so a wrong A0 is no missing effect."""
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(joint_state_rate_hz=10.0, load_rate_hz=10.0, straightness_noise_m=0.3e-6)
    run = simulate_machine(params, sim, seed=8, effects={"initial_offset": 5e-6})
    blind = dict(params, straightness_initial_m=0.0)
    res = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), blind)
    assert res["named_effects"] == []
    assert "initial_offset" not in {c["effect"] for c in res["candidates"]}
    a0 = res["baseline"]["parameters"]["straightness_initial_m"]
    assert a0["value"] == pytest.approx(params["straightness_initial_m"] + 5e-6, abs=max(3 * a0["std_error"], 0.3e-6))
    assert res["baseline"]["wear_coefficient"] == pytest.approx(4.42e-6, rel=0.05)
