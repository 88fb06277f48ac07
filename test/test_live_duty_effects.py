"""The duty effects diagnose names (load_along_rail, wear_rate_change, lubrication_interval) integrated live
(models/wear/effect_wear.py, issue 15: "the live model integrates with the effects").

- The monitor's straightness at every measurement, with the true K and effect parameters, equals (1e-9) this
  file's own sample-by-sample integration (written here: no import of the effect terms) of machine_jobs motion and
  load: W ds m, m the effect's multiplier at the segment's middle, the load held from its last sample.
- The recorded form of lubrication_interval takes the bag's relubricate maintenance events through the
  AxisMonitor (as replay and the node do), and survives a state round trip.
- diagnose -> model file -> replay: on hidden data written here (20 h, noise 0.3 um) the model file's life
  is within 10 % of an oracle's (the same monitor with the true parameters and noise-free measurements),
  and a wear-rate change no longer hides in an averaged K.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.workflow import diagnose_cells
from guide_health.errors import InputError
from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.maintenance import MaintenanceEvent
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, validate_wear_params, wear_monitor_params
from guide_health.params.typed import as_dict, wear_axis_params
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
from live_feed import feed_per_sample  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"
H = 3600.0


def jobs_run(hours: float, rate_hz: float, seed: int):
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=hours, joint_state_rate_hz=rate_hz, load_rate_hz=rate_hz,
               straightness_noise_m=0.0)
    return params, simulate_machine(params, sim, seed=seed)


def own_multiplier(case: dict, t_s: np.ndarray, x_m: np.ndarray, relube_s: list[float]) -> np.ndarray:
    """The effects' multipliers as this file writes them (t: s since the stamps' epoch)."""
    m = np.ones_like(t_s)
    if "g" in case:
        m *= np.clip(1.0 + case["g"] * (x_m - case["x_ref"]), 0.0, None)
    if "f" in case:
        m *= np.where(t_s >= case["t_c"], case["f"], 1.0)
    if "T" in case:
        since = np.clip(t_s - case["t_ref"], 0.0, None)
        m *= 1.0 + case["a"] * (since - case["T"] * np.floor(since / case["T"])) / case["T"]
    if "b" in case:
        last = np.array([max([case["t_first"]] + [r for r in relube_s if r <= t]) for t in t_s])
        m *= np.clip(1.0 + case["b"] * (t_s - last), 0.0, None)     # no negative wear
    return m


def own_straightness_m(run, params: dict, k: float, stroke_sum_m: float, case: dict,
                       relube_s: list[float]) -> np.ndarray:
    """A0 + 2 K sum(W ds m) / (H b (l_min + l_max)) at each measurement (seed 000 Eq. 7, Eq. 10)."""
    t = np.asarray(run.joint_t_ns, dtype=np.int64)
    x = np.asarray(run.joint_position_m, dtype=float)
    held = np.searchsorted(run.load_t_ns, t[1:], side="right") - 1
    load = np.where(held >= 0, np.asarray(run.load_n)[np.clip(held, 0, None)], 0.0)
    t_mid = 0.5 * (t[1:] + t[:-1]) * 1e-9
    work = load * np.abs(np.diff(x)) * own_multiplier(case, t_mid, 0.5 * (x[1:] + x[:-1]), relube_s)
    g = np.concatenate(([0.0], np.cumsum(work)))
    at = np.searchsorted(t, np.asarray(run.straightness_t_ns, dtype=np.int64), side="right") - 1
    return params["straightness_initial_m"] + 2.0 * k * g[at] / (params["hardness_pa"] * params["contact_width_m"]
                                                                * stroke_sum_m)


CASES = {
    "load_along_rail": ({"g": 2.5, "x_ref": 0.12}, {"effects": "load_along_rail", "load_gradient_per_m": 2.5,
                                                     "load_reference_position_m": 0.12}),
    "wear_rate_change": ({"f": 2.2, "t_c_h": 1.37}, {"effects": "wear_rate_change", "wear_rate_change_factor": 2.2}),
    "lubrication_interval": ({"a": 1.4, "T": 1.1 * H, "t_ref_h": 0.3},
                             {"effects": "lubrication_interval", "lubrication_wear_growth": 1.4,
                              "lubrication_interval_s": 1.1 * H}),
    "lubrication_recorded": ({"b": 0.5 / H, "relube_h": [0.8, 2.45]},
                             {"effects": "lubrication_interval", "lubrication_wear_growth": 0.5 / H,
                              "lubrication_interval_s": 0.0}),
    # wear falling after a relubrication (diagnose fits growth down to -0.9 per gap), past the point where
    # the line would cross zero: no wear, never negative
    "lubrication_negative": ({"b": -0.5 / H, "relube_h": [0.8]},
                             {"effects": "lubrication_interval", "lubrication_wear_growth": -0.5 / H,
                              "lubrication_interval_s": 0.0}),
    "all_three": ({"g": -1.5, "x_ref": 0.1, "f": 0.6, "t_c_h": 2.2, "a": 0.8, "T": 1.7 * H,
                                   "t_ref_h": 0.0},
                                  {"effects": "load_along_rail,wear_rate_change,lubrication_interval",
                                   "load_gradient_per_m": -1.5, "load_reference_position_m": 0.1,
                                   "wear_rate_change_factor": 0.6, "lubrication_wear_growth": 0.8,
                                   "lubrication_interval_s": 1.7 * H}),
}


def monitored(case_id: str, hours: float = 4.0, rate_hz: float = 20.0, seed: int = 4):
    """(expected straightness, monitor) of one case; the recorded lubrication through an AxisMonitor."""
    params, run = jobs_run(hours, rate_hz, seed)
    case, live = CASES[case_id]
    case = dict(case)
    t0_s = int(run.joint_t_ns[0]) * 1e-9
    stroke = (float(run.metadata["truth"]["stroke_min_m"]), float(run.metadata["truth"]["stroke_max_m"]))
    fixed = {**params, "stroke_min_m": stroke[0], "stroke_max_m": stroke[1], "sliding_deadband_m": 0.0}
    live = dict(live)
    if "t_c_h" in case:
        case["t_c"] = t0_s + case["t_c_h"] * H
        live["wear_rate_change_stamp_s"] = case["t_c"]
    if "t_ref_h" in case:
        case["t_ref"] = t0_s + case["t_ref_h"] * H
        live["lubrication_reference_stamp_s"] = case["t_ref"]
    relube_s = [t0_s + h * H for h in case.get("relube_h", [])]
    if relube_s:         # the diagnosed record's last relubrication is the file's reference
        case["t_first"] = t0_s
        live["lubrication_reference_stamp_s"] = relube_s[-1]
    k = params["wear_coefficient"]
    expected = own_straightness_m(run, params, k, sum(stroke), case, relube_s)
    run.straightness_m = expected                     # the gauge reads this truth, noise-free
    validate_wear_params({**fixed, **live})
    axis = AxisMonitor(wear_axis_params({**fixed, **live}))
    for t in relube_s:
        axis.schedule(MaintenanceEvent(int(round(t * 1e9)), "relubricate", params["joint"], source="test"))
    axis.process_run(run)
    return expected, axis.primary, run, fixed, k, relube_s


@pytest.mark.parametrize("case_id", list(CASES))
def test_live_duty_effects_integrate_this_files_reference(case_id):
    expected, monitor, run, fixed, k, _ = monitored(case_id)
    got = monitor.straightness_m(k, monitor.measurement_losses_per_k_m())
    a0 = fixed["straightness_initial_m"]
    rel = np.abs(got - expected)[1:] / (expected - a0)[1:]
    assert got.size == expected.size and np.max(rel) < 1e-9, (case_id, np.max(rel))
    plain = PrecisionMonitor(wear_axis_params(fixed))
    plain.process_run(run)
    off = np.abs(plain.straightness_m(k, plain.measurement_losses_per_k_m()) - expected)[1:] / (expected - a0)[1:]
    assert np.max(off) > 0.02, (case_id, np.max(off))      # the effect is not a rounding of the plain model
    # the online K update, fed the noise-free measurements of this truth, recovers the true K
    assert monitor.report()["wear_coefficient"] == pytest.approx(k, rel=1e-9)


def test_recorded_relubrication_time_base_survives_a_state_round_trip():
    """Stopped at 2 h (between the relubrications) and restored: the rest of the run gives the same wear
    as without the stop (the last relubrication and the first stamp are in the state)."""
    params, run = jobs_run(4.0, 10.0, 6)
    _, live = CASES["lubrication_recorded"]
    t0 = int(run.joint_t_ns[0])
    stroke = (float(run.metadata["truth"]["stroke_min_m"]), float(run.metadata["truth"]["stroke_max_m"]))
    p = {**params, **live, "stroke_min_m": stroke[0], "stroke_max_m": stroke[1],
         "lubrication_reference_stamp_s": (t0 + 2.45 * H * 1e9) * 1e-9}
    events = [MaintenanceEvent(t0 + int(h * H * 1e9), "relubricate", params["joint"], source="test")
              for h in (0.8, 2.45)]

    def split(run, t_ns):
        from guide_health.runs import MachineRun
        out = []
        for keep in (lambda a: a <= t_ns, lambda a: a > t_ns):
            j, ld, s = keep(run.joint_t_ns), keep(run.load_t_ns), keep(run.straightness_t_ns)
            out.append(MachineRun(joint_t_ns=run.joint_t_ns[j], joint_position_m=run.joint_position_m[j],
                                  load_t_ns=run.load_t_ns[ld], load_n=run.load_n[ld],
                                  straightness_t_ns=run.straightness_t_ns[s], straightness_m=run.straightness_m[s]))
        return out

    whole = AxisMonitor(wear_axis_params(p))
    for e in events:
        whole.schedule(e)
    whole.process_run(run)
    first, second = split(run, t0 + int(2.0 * H * 1e9))
    a = AxisMonitor(wear_axis_params(p))
    for e in events:
        a.schedule(e)
    a.process_run(first)
    state = a.primary.state()
    assert state["effects"]["last_relubrication_t_ns"] == events[0].t_ns
    b = AxisMonitor(wear_axis_params(p))
    b.primary.restore(state)
    b.restore_maintenance(a.maintenance_state())
    b.process_run(second)
    assert b.primary.work_nm() == pytest.approx(whole.primary.work_nm(), rel=1e-9)
    assert b.primary.report()["remaining_life_h"] == pytest.approx(whole.primary.report()["remaining_life_h"],
                                                                   rel=1e-9)


def test_duty_effect_parameters_are_checked():
    """Out-of-range duty-effect parameters and a covariance of the wrong size are one-line errors."""
    params = wear_monitor_params(JOBS)
    for bad, name in (({"wear_rate_change_factor": 0.0}, "wear_rate_change_factor"),
                      ({"lubrication_interval_s": -1.0}, "lubrication_interval_s"),
                      ({"load_gradient_per_m": float("nan")}, "load_gradient_per_m"),
                      ({"thermal_drift_m_per_k": 0.0}, "thermal_drift needs thermal_drift_m_per_k"),
                      ({"wear_rate_change_stamp_s": 0.0}, "wear_rate_change needs wear_rate_change_stamp_s")):
        with pytest.raises(InputError, match=name):
            validate_wear_params({**params, "effects": "wear_rate_change,lubrication_interval,load_along_rail,"
                                  "thermal_drift", "thermal_drift_m_per_k": 1e-6,
                                  "wear_rate_change_stamp_s": 1.7e9, **bad})


def test_per_sample_callbacks_equal_the_vectorised_path_with_the_duty_effects():
    """The node's per-sample path (on_joint / on_load / on_straightness) and process_run give the same
    effective work, life and interval with all three duty effects and their covariance (one model object,
    two input paths); the interval is wider with the covariance than without."""
    import json

    expected, offline, run, fixed, k, _ = monitored("all_three", hours=2.0, rate_hz=5.0)
    _, live_p = CASES["all_three"]
    p = as_dict(offline.params)
    sd = np.array([0.05 * k, 0, 0, 0, 0, 0, 1.0, 0.3, 0.5, 0, 0, 0, 0])
    p["effect_covariance"] = np.diag(sd ** 2).ravel().tolist()
    run.straightness_m = expected + np.random.default_rng(3).normal(0.0, 0.3e-6, expected.size)
    a_mon = PrecisionMonitor(wear_axis_params(p))
    a_mon.process_run(run)
    b_mon = PrecisionMonitor(wear_axis_params(p))
    feed_per_sample(b_mon, run)
    a, b = a_mon.report(), b_mon.report()
    assert b_mon.work_nm() == pytest.approx(a_mon.work_nm(), rel=1e-9)
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"):
        assert b[key] == pytest.approx(a[key], rel=1e-6), key
    narrow = PrecisionMonitor(wear_axis_params({**p, "effect_covariance": [0.0] * 169}))
    narrow.process_run(run)
    n = narrow.report()
    assert n["remaining_life_h"] == pytest.approx(a["remaining_life_h"], rel=1e-9)
    assert a["remaining_life_h_high"] - a["remaining_life_h_low"] > 1.2 * (n["remaining_life_h_high"]
                                                                           - n["remaining_life_h_low"])
    again = PrecisionMonitor(wear_axis_params(p))
    again.restore(json.loads(json.dumps(a_mon.state())))
    assert again.report()["remaining_life_h"] == pytest.approx(a["remaining_life_h"], rel=1e-9)


# --- diagnose -> model file -> replay on hidden data ------------------------------------------------------

def hidden_case(effect: str, seed: int, hours: float = 20.0, rate_hz: float = 10.0):
    """machine_jobs with a duty effect hidden by this file's integration, noise 0.3 um; returns the run, the
    base parameters, the true live parameters and the noise-free truth."""
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=hours, joint_state_rate_hz=rate_hz, load_rate_hz=rate_hz)
    run = simulate_machine(params, sim, seed=seed)
    rng = np.random.default_rng(4000 + seed)
    t0_s = int(run.joint_t_ns[0]) * 1e-9
    if effect == "wear_rate_change":
        case = {"f": float(rng.uniform(1.5, 2.2)), "t_c": t0_s + float(rng.uniform(6.0, 12.0)) * H}
        true = {"effects": effect, "wear_rate_change_factor": case["f"], "wear_rate_change_stamp_s": case["t_c"]}
    else:
        x = np.asarray(run.joint_position_m)
        g = float(rng.choice([-1.0, 1.0]) * rng.uniform(2.0, 3.0))
        case = {"g": g, "x_ref": float(np.mean(x))}
        true = {"effects": effect, "load_gradient_per_m": g, "load_reference_position_m": case["x_ref"]}
    stroke = run.metadata["truth"]["stroke_min_m"] + run.metadata["truth"]["stroke_max_m"]
    # after a doubling the machine would pass the limit within 20 h at the configured K: it wears at 0.6 x
    # (the online update finds it); the rail's gradient needs the full wear range to be told from noise
    k_true = (0.6 if effect == "wear_rate_change" else 1.0) * params["wear_coefficient"]
    truth = own_straightness_m(run, params, k_true, stroke, case, [])
    run.straightness_m = truth + np.random.default_rng(5000 + seed).normal(0.0, 0.3e-6, truth.size)
    return run, params, true, truth


def life_of(params: dict, run) -> dict:
    monitor = PrecisionMonitor(wear_axis_params(params))
    monitor.process_run(run)
    return monitor.report()


@pytest.mark.parametrize("effect, seed", [("wear_rate_change", 1), ("load_along_rail", 2)])
def test_model_file_of_a_duty_effect_drives_the_live_life(effect, seed, tmp_path):
    """diagnose names the hidden effect and writes it to the model file (absolute change time, x_ref); the
    monitor with base + model file gives a life within 10 % of the oracle's (the same monitor with the true
    parameters and the noise-free truth as measurements) and its 90 % interval contains it; the file passes the
    schema and loads as the later --params file."""
    from guide_health.analysis.discrepancy.model_file import write_model_file

    run, params, true, truth = hidden_case(effect, seed)
    result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
    assert effect in result["named_effects"], result["named_effects"]
    model = result["model_file"]
    assert effect in model["effects"].split(",")
    path = tmp_path / "model.yaml"
    write_model_file(path, params, model, result["named_effects"])
    merged = wear_monitor_params([JOBS, path])
    oracle_run = type(run)(**{**vars(run), "straightness_m": truth})
    oracle = life_of({**params, **true}, oracle_run)["remaining_life_h"]
    with_file = life_of(merged, run)
    plain = life_of(params, run)
    print(f"{effect} seed {seed}: oracle {oracle:.2f} h, with the file {with_file['remaining_life_h']:.2f} h "
          f"[{with_file['remaining_life_h_low']:.2f}, {with_file['remaining_life_h_high']:.2f}], plain "
          f"{plain['remaining_life_h']:.2f} h")
    assert abs(with_file["remaining_life_h"] / oracle - 1.0) < 0.10
    assert with_file["remaining_life_h_low"] <= oracle <= with_file["remaining_life_h_high"]
    if effect == "wear_rate_change":     # the change hides in an averaged K without the file: life too long
        assert true["wear_rate_change_stamp_s"] == pytest.approx(model["wear_rate_change_stamp_s"], abs=0.5 * H)
        assert plain["remaining_life_h"] > 1.2 * oracle
    else:
        assert model["load_reference_position_m"] == pytest.approx(true["load_reference_position_m"], abs=0.02)


@pytest.mark.slow
def test_model_file_of_a_duty_effect_10_seeds():
    """Seeds 0-9 per effect (~70 s). Measured 2026-11-23: wear_rate_change named 10/10, the oracle's life
    within 10 % and inside the 90 % interval 10/10, plain life 1.34-1.94x the oracle's; load_along_rail named
    9/10 (seed 0: nothing named, the file is the plain model), covered 9/10."""
    for effect in ("wear_rate_change", "load_along_rail"):
        covered = named = 0
        for seed in range(10):
            run, params, true, truth = hidden_case(effect, seed)
            result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
            oracle_run = type(run)(**{**vars(run), "straightness_m": truth})
            oracle = life_of({**params, **true}, oracle_run)["remaining_life_h"]
            w = life_of({**params, **result["model_file"]}, run)
            if effect in result["named_effects"]:
                named += 1
                assert abs(w["remaining_life_h"] / oracle - 1.0) < 0.10, (effect, seed)
            covered += w["remaining_life_h_low"] <= oracle <= w["remaining_life_h_high"]
        print(f"{effect}: named {named}/10, covered {covered}/10")
        assert named >= 9 and covered >= 8


# --- thermal_drift: the gauge correction ----------------------------------------------------------------

def thermal_case(seed: int, hours: float, rate_hz: float, noise_m: float, c_m_per_k: float, d_k: float):
    """machine_jobs (guide temperature at 0.1 Hz) whose gauge reads A + c_T (T - T_ref), T_ref = T at the
    first measurement + d, T the reading in force at the measurement's stamp (this file's own sum)."""
    params, run = jobs_run(hours, rate_hz, seed)
    truth = run.metadata["truth"]
    stroke = truth["stroke_min_m"] + truth["stroke_max_m"]
    params = {**params, "stroke_min_m": float(truth["stroke_min_m"]), "stroke_max_m": float(truth["stroke_max_m"]),
              "sliding_deadband_m": 0.0}
    wear = own_straightness_m(run, params, params["wear_coefficient"], stroke, {}, [])
    st = np.asarray(run.straightness_t_ns, dtype=np.int64)
    held = np.searchsorted(run.temperature_t_ns, st, side="right") - 1
    temp = np.asarray(run.temperature_c)[np.clip(held, 0, None)]
    t_ref = float(temp[0] + d_k)
    gauge = wear + c_m_per_k * (temp - t_ref)
    run.straightness_m = gauge + np.random.default_rng(6000 + seed).normal(0.0, noise_m, gauge.size)
    return params, run, wear, t_ref, held


def test_thermal_drift_corrects_each_measurement_with_the_temperature_at_its_stamp():
    params, run, wear, t_ref, held = thermal_case(3, 3.0, 5.0, 0.0, 1.2e-6, 3.0)
    assert np.ptp(np.asarray(run.temperature_c)) > 1.0
    assert held[0] < 0 and np.all(held[1:] >= 0)      # the first measurement precedes the first reading
    live = {"effects": "thermal_drift", "thermal_drift_m_per_k": 1.2e-6, "thermal_reference_c": t_ref}
    validate_wear_params({**params, **live})
    monitor = PrecisionMonitor(wear_axis_params({**params, **live}))
    monitor.process_run(run)
    est = monitor.estimator
    # the first measurement (t = 0, before any temperature reading) is a counted rejection, not a guess
    assert monitor.rejected.total == 1 and est.count == wear.size - 1
    assert np.max(np.abs(np.asarray(est.measurement_m) - wear[1:])) < 1e-12     # the gauge term taken off
    assert monitor.report()["wear_coefficient"] == pytest.approx(params["wear_coefficient"], rel=1e-6)
    assert "straightness_thermal_correction_um" in monitor.report()
    plain = PrecisionMonitor(wear_axis_params(params))
    plain.process_run(run)
    assert abs(plain.report()["wear_coefficient"] / params["wear_coefficient"] - 1.0) > 0.01
    # per message: a measurement before any temperature reading is a counted rejection, nothing changes
    fresh = PrecisionMonitor(wear_axis_params({**params, **live}))
    fresh.on_joint(int(run.joint_t_ns[0]), float(run.joint_position_m[0]))
    before = json_state(fresh)
    reason = fresh.on_straightness(int(run.joint_t_ns[0]) + 1, 20e-6)
    assert reason == "straightness before any guide/temperature (thermal_drift correction)"
    assert fresh.rejected.total == 1 and json_state(fresh) == before
    # a reading stamped before the measurement but arriving after the one stamped after it still applies
    fresh.on_temperature(int(run.joint_t_ns[0]) + 10, t_ref + 5.0)
    fresh.on_temperature(int(run.joint_t_ns[0]) - 10, t_ref + 1.0)
    fresh.on_straightness(int(run.joint_t_ns[0]) + 2, 20e-6)
    assert fresh.estimator.measurement_m[-1] == pytest.approx(20e-6 - 1.2e-6 * 1.0, abs=1e-15)
    again = PrecisionMonitor(wear_axis_params({**params, **live}))
    again.restore(json.loads(json.dumps(fresh.state())))
    assert again.thermal_offset_at_k(int(run.joint_t_ns[0]) + 20) == pytest.approx(5.0, rel=1e-12)


def test_the_life_interval_carries_the_gauge_terms_as_a_rerun_moves_the_life():
    """thermal_drift's c_T and the gauge offset e at T_ref enter the interval through the K update (each reading
    is corrected by (c_T + dc) (T_j - T_ref) + de). The interval's share of each (its variance alone in the
    covariance, less the interval with none) equals the life's change when the monitor is rerun with c_T or
    T_ref moved by that sd (finite difference of the whole monitor, not of the delta method's terms): 5 %.
    Measured on seeds 0-9 of the hidden thermal case (20 h, noise 0.3 um): without these terms the 90 %
    interval held the oracle's life 8/10 (z sd 1.4), with them 9/10 (z sd 0.85)."""
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    params, run, wear, t_ref, _ = thermal_case(2, 6.0, 5.0, 0.3e-6, 1.2e-6, -4.0)
    c, n = 1.2e-6, len(COVARIANCE_NAMES)
    live = {**params, "effects": "thermal_drift", "thermal_drift_m_per_k": c, "thermal_reference_c": t_ref}

    def report(extra: dict, variances: dict) -> dict:
        cov = np.zeros((n, n))
        for name, v in variances.items():
            cov[COVARIANCE_NAMES.index(name), COVARIANCE_NAMES.index(name)] = v
        return life_of({**live, **extra, "effect_covariance": cov.ravel().tolist()}, run)

    def half_width(r: dict) -> float:
        """ln(high / life) = t sd of ln(life)."""
        return math.log(r["remaining_life_h_high"] / r["remaining_life_h"])

    none = report({}, {})
    t = _t90(none)
    for name, sd, moved in (("thermal_drift_m_per_k", 0.03e-6, lambda s: {"thermal_drift_m_per_k": c + s}),
                            ("thermal_gauge_offset_m", 0.1e-6, lambda s: {"thermal_reference_c": t_ref - s / c})):
        one = report({}, {name: sd ** 2})
        assert one["remaining_life_h"] == pytest.approx(none["remaining_life_h"], rel=1e-12)
        predicted = math.sqrt(half_width(one) ** 2 - half_width(none) ** 2) / t     # this term's sd of ln(life)
        up, down = (report(moved(s), {})["remaining_life_h"] for s in (sd, -sd))
        rerun = abs(math.log(up / down)) / 2.0
        print(f"{name}: delta method {predicted:.5f}, rerun {rerun:.5f}")
        assert predicted == pytest.approx(rerun, rel=0.05), name
        assert predicted > 0.2 * half_width(none) / t        # not negligible against K's own spread


def _t90(report: dict) -> float:
    """The interval's quantile (t with n - 1 degrees of freedom, PrecisionMonitor.effect_life_interval_s)."""
    from scipy.special import stdtrit

    return float(stdtrit(report["measurements"] - 1, 0.95))


def test_the_model_file_carries_the_gauge_offset_at_t_ref_by_its_jacobian():
    """The fit's thermal parameters are c_T and b, the gauge offset at T_0; the file's are c_T and T_ref, and its
    covariance rows c_T and e, the offset at T_ref: e = dc_T (T_ref - T_0) + db (closed form, 1e-12), which is
    also -c_T dT_ref to first order; the other rows are the fit's own."""
    from types import SimpleNamespace

    from guide_health.analysis.discrepancy.model_file import live_parameter_text, model_parameters
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    c, b, t0 = 1.2e-6, 4.8e-6, 21.5                  # T_ref = T_0 - b / c = 17.5 degC
    names = ["wear_coefficient", "thermal_drift_m_per_k", "thermal_offset_m"]
    sd = np.array([0.02 * 4.4e-6, 0.03e-6, 0.2e-6])
    corr = np.array([[1.0, 0.3, -0.2], [0.3, 1.0, -0.6], [-0.2, -0.6, 1.0]])
    sigma = corr * np.outer(sd, sd)
    final = SimpleNamespace(values={"wear_coefficient": 4.4e-6, "thermal_drift_m_per_k": c, "thermal_offset_m": b},
                            extra={"covariance": {"names": names, "matrix": sigma}})
    problem = SimpleNamespace(a0_free=False, a0_m=15e-6, fit_references={"load_reference_n": 5000.0}, retract_sign=-1,
                              cells=SimpleNamespace(t0_ns=1_700_000_000 * 10 ** 9), temperature_first_c=t0)
    model = model_parameters(problem, final, ["thermal_drift"])
    assert model["thermal_reference_c"] == pytest.approx(t0 - b / c, rel=1e-12)
    n = len(COVARIANCE_NAMES)
    cov = np.asarray(model["effect_covariance"]).reshape(n, n)
    k, ct, e = (COVARIANCE_NAMES.index(x) for x in ("wear_coefficient", "thermal_drift_m_per_k",
                                                    "thermal_gauge_offset_m"))
    d = model["thermal_reference_c"] - t0
    assert cov[k, k] == pytest.approx(sigma[0, 0], rel=1e-12) and cov[ct, ct] == pytest.approx(sigma[1, 1], rel=1e-12)
    assert cov[e, e] == pytest.approx(d ** 2 * sigma[1, 1] + 2 * d * sigma[1, 2] + sigma[2, 2], rel=1e-12)
    assert cov[ct, e] == pytest.approx(d * sigma[1, 1] + sigma[1, 2], rel=1e-12)
    assert cov[k, e] == pytest.approx(d * sigma[0, 1] + sigma[0, 2], rel=1e-12)
    # -c_T dT_ref: dT_ref = (b / c^2) dc - db / c
    grad = -c * np.array([0.0, b / c ** 2, -1.0 / c])
    assert cov[e, e] == pytest.approx(float(grad @ sigma @ grad), rel=1e-9)
    assert np.count_nonzero(cov) == 9
    # diagnose's text and report.md show them (model_file.live_parameter_text)
    text = live_parameter_text(model)
    assert f"thermal_drift_m_per_k = {c:.4g} ± {0.03e-6:.2g}" in text
    assert f"thermal_reference_c = {t0 - b / c:.4g}, thermal_gauge_offset_m = 0 ± {math.sqrt(cov[e, e]):.2g}" in text


@pytest.mark.slow
def test_thermal_drift_life_interval_10_seeds():
    """Seeds 0-9 of the hidden thermal case (20 h, 10 Hz, noise 0.3 um, c_T 1.2 um/K, T_ref 4 K below T_0; ~60 s):
    diagnose names thermal_drift, and the model file's 90 % interval holds the oracle's life (the same monitor
    with the true c_T and T_ref on the noise-free readings). Measured 2026-11-24: 10/10 (z sd 0.78); 9/10 (z sd
    0.85) while diagnose interpolated the temperature (this case's gauge holds the reading, as the live monitor
    does); before c_T and the gauge offset were in the interval, 8/10 (z sd 1.4)."""
    covered, z = 0, []
    for seed in range(10):
        params, run, wear, t_ref, held = thermal_case(seed, 20.0, 10.0, 0.3e-6, 1.2e-6, -4.0)
        result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
        assert "thermal_drift" in result["named_effects"], (seed, result["named_effects"])
        w = life_of({**params, **result["model_file"]}, run)
        temp = np.asarray(run.temperature_c)[np.clip(held, 0, None)]
        truth_run = type(run)(**{**vars(run), "straightness_m": wear + 1.2e-6 * (temp - t_ref)})
        oracle = life_of({**params, "effects": "thermal_drift", "thermal_drift_m_per_k": 1.2e-6,
                          "thermal_reference_c": t_ref}, truth_run)["remaining_life_h"]
        covered += w["remaining_life_h_low"] <= oracle <= w["remaining_life_h_high"]
        z.append(math.log(w["remaining_life_h"] / oracle) * _t90(w) / math.log(w["remaining_life_h_high"]
                                                                               / w["remaining_life_h"]))
    print(f"thermal_drift: covered {covered}/10, z sd {np.std(z):.2f}")
    assert covered >= 8 and max(abs(v) for v in z) < 3.0


def test_an_unbounded_linearisation_gives_an_unbounded_interval():
    """When a hundredth of a parameter's sd already takes the life to the limit or to no wear, the delta
    method has no answer: the interval is [0, inf), never NaN (found with an absurd 1 cm gauge-offset sd)."""
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    params, run, wear, t_ref, _ = thermal_case(2, 3.0, 5.0, 0.3e-6, 1.2e-6, -4.0)
    n = len(COVARIANCE_NAMES)
    cov = np.zeros((n, n))
    e = COVARIANCE_NAMES.index("thermal_gauge_offset_m")
    cov[e, e] = 0.01 ** 2
    r = life_of({**params, "effects": "thermal_drift", "thermal_drift_m_per_k": 1.2e-6, "thermal_reference_c": t_ref,
                 "effect_covariance": cov.ravel().tolist()}, run)
    assert math.isfinite(r["remaining_life_h"]) and r["remaining_life_h"] > 0
    assert r["remaining_life_h_low"] == 0.0 and r["remaining_life_h_high"] == math.inf


def json_state(monitor) -> str:
    import json

    return json.dumps(monitor.state(), sort_keys=True, default=str)


def test_model_file_with_thermal_drift_carries_the_reference_temperature(tmp_path):
    """Hidden thermal drift (20 h, 10 Hz, noise 0.3 um, d = T_ref - T_0 = -4 K): diagnose names it, the file's
    thermal_reference_c is T_0 + d within 0.5 K, and the monitor with the file recovers K within 2 % (the
    plain model's K is biased by the gauge term)."""
    from guide_health.analysis.discrepancy.model_file import write_model_file

    params, run, wear, t_ref, _ = thermal_case(2, 20.0, 10.0, 0.3e-6, 1.2e-6, -4.0)
    result = diagnose_cells(duty_cells_from_runs(run, params["slider_length_m"]), params)
    assert "thermal_drift" in result["named_effects"], result["named_effects"]
    model = result["model_file"]
    assert "thermal_drift" in model["effects"].split(",")
    assert model["thermal_reference_c"] == pytest.approx(t_ref, abs=0.5)
    path = tmp_path / "model.yaml"
    write_model_file(path, params, model, result["named_effects"])
    with_file = life_of(wear_monitor_params([JOBS, path]), run)
    plain = life_of(params, run)
    k = params["wear_coefficient"]
    print(f"K with the file {with_file['wear_coefficient'] / k:.4f} x true, plain {plain['wear_coefficient'] / k:.4f}")
    assert with_file["wear_coefficient"] == pytest.approx(k, rel=0.02)


@pytest.mark.ros
def test_live_node_with_the_duty_and_thermal_effects_matches_replay(tmp_path, ros_test_env):
    """wear_monitor --params-file BASE --params-file model.yaml against replay of the same bag (bench, 1.5 h,
    guide temperature at 0.2 Hz, two relubricate events on maintenance/events) with load_along_rail,
    wear_rate_change, lubrication_interval (recorded), thermal_drift and stroke_distribution (the node's
    passes, one joint message at a time): same samples and measurements,
    straightness, K and remaining life with its interval to 0.5 %."""
    pytest.importorskip("rclpy")
    from guide_health.analysis.replay import analyse_bag
    from guide_health.cli.simulate import event_series
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.nodes.session import bag_counts, settled_status_after_bag

    bench = ROOT / "config" / "bench_000.yaml"
    env = ros_test_env()
    base = wear_monitor_params(bench)
    sim = dict(simulation_params(bench), duration_h=1.5, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.1, temperature_rate_hz=0.2)
    run = simulate_machine(base, sim, seed=8)
    t0 = int(run.joint_t_ns[0])
    events = [MaintenanceEvent(t0 + int(h * H * 1e9), "relubricate", base["joint"], source="test")
              for h in (0.4, 1.1)]
    bag = tmp_path / "bench"
    write_machine_bag(run, bag, extra=event_series(events, base["machine_id"]))
    model = tmp_path / "model.yaml"
    cov = np.diag([(0.02 * 4.4e-6) ** 2, 0, 0, 0, 0, 0, 0.5 ** 2, 0.1 ** 2, (0.1 / H) ** 2, 0.05 ** 2, (0.03e-6) ** 2,
                   (0.1e-6) ** 2, 0.0]).ravel().tolist()
    model.write_text(yaml.safe_dump({"wear_monitor": {"ros__parameters": {
        "wear_coefficient": 4.4e-6,
        "effects": "load_along_rail,wear_rate_change,lubrication_interval,thermal_drift,stroke_distribution",
        "stroke_distribution_weight": 0.6, "load_gradient_per_m": 2.0, "load_reference_position_m": 0.15,
        "wear_rate_change_factor": 1.8,
        "wear_rate_change_stamp_s": (t0 + 0.7 * H * 1e9) * 1e-9, "lubrication_wear_growth": 0.6 / H,
        "lubrication_interval_s": 0.0, "lubrication_reference_stamp_s": (t0 + 1.1 * H * 1e9) * 1e-9,
        "thermal_drift_m_per_k": 0.8e-6, "thermal_reference_c": float(np.mean(run.temperature_c)),
        "effect_covariance": cov}}}))
    merged = wear_monitor_params([bench, model])
    offline = analyse_bag(bag, merged)[1]
    live = settled_status_after_bag("guide_health.nodes.wear_monitor", [bench, model],
                                    {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25}, env,
                                    bag, "bench_000/wear_monitor: x precision", tmp_path / "node.log",
                                    collector_name="test_collector_duty", counts=bag_counts(offline))
    keys = ("samples", "measurements", "straightness_um", "remaining_life_h", "remaining_life_h_low",
            "remaining_life_h_high", "wear_coefficient", "straightness_thermal_correction_um")
    values = {k: float(live["values"][k]) for k in keys}
    assert values["samples"] == offline["samples"]
    assert values["measurements"] == offline["measurements"] == run.straightness_t_ns.size - 1   # t = 0: no T yet
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
                "wear_coefficient", "straightness_thermal_correction_um"):
        assert values[key] == pytest.approx(offline[key], rel=0.005), key
    plain = analyse_bag(bag, base)[1]
    assert abs(plain["remaining_life_h"] / offline["remaining_life_h"] - 1.0) > 0.05     # the file matters


def test_a_monitor_with_effects_reports_before_its_first_measurement():
    """Strokes known, no measurement accepted yet (the first one came before any temperature): the report
    has a life from the configured K, no error (a node crashed here before stop 11)."""
    params, run, _, t_ref, _ = thermal_case(1, 0.5, 5.0, 0.0, 1.0e-6, 0.0)
    live = {"effects": "thermal_drift,load_along_rail", "thermal_drift_m_per_k": 1.0e-6, "thermal_reference_c": t_ref,
            "load_gradient_per_m": 1.0, "load_reference_position_m": 0.1}
    monitor = PrecisionMonitor(wear_axis_params({**params, **live}))
    monitor.on_straightness(int(run.joint_t_ns[0]), 20e-6)          # no time base yet: rejected
    for t, x in zip(run.joint_t_ns[:3000].tolist(), run.joint_position_m[:3000].tolist()):
        monitor.on_joint(t, x)
        if monitor.load_t_ns is None:
            monitor.on_load(t, 6000.0)
    assert monitor.estimator.count == 0
    r = monitor.report()
    assert r["measurements"] == 0
    assert 0 < r["remaining_life_h_low"] <= r["remaining_life_h"] <= r["remaining_life_h_high"]


def test_a_state_with_the_duty_and_thermal_effects_passes_the_state_schema_and_restores():
    """A monitor with all four new live effects, after 2 h (temperatures, a relubrication, measurements): its
    state passes check_precision_state against a fresh monitor of the same parameters and restores to the same
    report; a corrupted reading (a string stamp, a NaN temperature, unequal lists, stamps out of order) is a
    one-line refusal."""
    import copy

    from guide_health.models.wear.state_schema import check_precision_state

    params, run, _, t_ref, _ = thermal_case(5, 2.0, 5.0, 0.2e-6, 1.0e-6, 1.0)
    t0 = int(run.joint_t_ns[0])
    p = {**params, "effects": "load_along_rail,wear_rate_change,lubrication_interval,thermal_drift",
         "load_gradient_per_m": 1.5, "load_reference_position_m": 0.1, "wear_rate_change_factor": 1.5,
         "wear_rate_change_stamp_s": (t0 + 0.9 * H * 1e9) * 1e-9, "lubrication_wear_growth": 0.3 / H,
         "thermal_drift_m_per_k": 1.0e-6, "thermal_reference_c": t_ref}
    axis = AxisMonitor(wear_axis_params(p))
    axis.schedule(MaintenanceEvent(t0 + int(0.6 * H * 1e9), "relubricate", params["joint"], source="test"))
    axis.process_run(run)
    monitor = axis.primary
    state = json.loads(json.dumps(monitor.state()))
    fresh = PrecisionMonitor(wear_axis_params(p))
    check_precision_state(state, fresh.state())
    assert len(state["temperatures"]["reading_t_ns"]) == run.temperature_t_ns.size
    assert state["effects"]["last_relubrication_t_ns"] == t0 + int(0.6 * H * 1e9)
    fresh.restore(state)
    a, b = monitor.report(), fresh.report()
    for key in ("straightness_um", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
                "wear_coefficient"):
        assert b[key] == pytest.approx(a[key], rel=1e-12), key
    for path, value, message in ((("temperatures", "reading_t_ns", 0), "x", "reading_t_ns"),
                                 (("temperatures", "reading_c", 1), float("nan"), "reading_c"),
                                 (("temperatures", "reading_c"), [20.0], "length differs"),
                                 (("temperatures", "reading_t_ns"),
                                  state["temperatures"]["reading_t_ns"][::-1], "not in stamp order")):
        bad = copy.deepcopy(state)
        node = bad
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
        with pytest.raises(InputError, match=message):
            check_precision_state(bad, PrecisionMonitor(wear_axis_params(p)).state())


def test_a_thermal_state_saved_before_the_offsets_were_kept_rebuilds_them_from_the_readings():
    """A state saved before stop 12 has no T - T_ref per measurement (NaN on restore), which left c_T and the
    gauge offset out of the interval. They are rebuilt from the kept readings: the same offsets (1e-12) and the
    same interval as the monitor that kept them. Where the kept readings do not reach back to a measurement
    (trimmed), it stays NaN and the interval leaves the gauge terms out, as before."""
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    params, run, _, t_ref, _ = thermal_case(2, 3.0, 5.0, 0.3e-6, 1.2e-6, -4.0)
    n = len(COVARIANCE_NAMES)
    cov = np.zeros((n, n))
    for name, sd in (("thermal_drift_m_per_k", 0.03e-6), ("thermal_gauge_offset_m", 0.1e-6)):
        cov[COVARIANCE_NAMES.index(name), COVARIANCE_NAMES.index(name)] = sd ** 2
    p = {**params, "effects": "thermal_drift", "thermal_drift_m_per_k": 1.2e-6, "thermal_reference_c": t_ref,
         "effect_covariance": cov.ravel().tolist()}
    monitor = PrecisionMonitor(wear_axis_params(p))
    monitor.process_run(run)
    kept = list(monitor.effect_wear.measurement_temperature_offset_k)
    assert len(kept) > 10 and np.all(np.isfinite(kept)) and np.ptp(kept) > 1.0
    state = json.loads(json.dumps(monitor.state()))
    del state["effects"]["measurement_temperature_offset_k"]       # as saved before stop 12
    old = PrecisionMonitor(wear_axis_params(p))
    old.restore(state)
    assert old.effect_wear.measurement_temperature_offset_k == pytest.approx(kept, rel=1e-12, abs=1e-12)
    a, b = monitor.report(), old.report()
    for key in ("remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"):
        assert b[key] == pytest.approx(a[key], rel=1e-12), key
    # readings trimmed to those after the 5th measurement: the first five stay unknown
    t5 = monitor.estimator.measurement_t_ns[5]
    temps = state["temperatures"]
    keep = [i for i, t in enumerate(temps["reading_t_ns"]) if t > t5]
    temps["reading_t_ns"] = [temps["reading_t_ns"][i] for i in keep]
    temps["reading_c"] = [temps["reading_c"][i] for i in keep]
    trimmed = PrecisionMonitor(wear_axis_params(p))
    trimmed.restore(state)
    offsets = np.asarray(trimmed.effect_wear.measurement_temperature_offset_k)
    assert np.all(np.isnan(offsets[:6])) and offsets[7:] == pytest.approx(kept[7:], rel=1e-12, abs=1e-12)
    narrow = PrecisionMonitor(wear_axis_params({**p, "effect_covariance": [0.0] * n * n}))
    narrow.process_run(run)
    c = trimmed.report()
    assert c["remaining_life_h_high"] == pytest.approx(narrow.report()["remaining_life_h_high"], rel=1e-9)
    assert a["remaining_life_h_high"] > 1.05 * c["remaining_life_h_high"]


# --- the remaining life follows the relubrication schedule ------------------------------------------------

@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.floats(-2e-4, 2e-4), st.floats(0.0, 30.0), st.sampled_from([0.0, 3.0, 5.0, 8.0]), st.floats(0.0, 40.0))
def test_the_lubrication_multiplier_integral_is_the_schedule_summed(b_s, tau_h, interval_h, horizon_h):
    """effect_life.lubrication_multiplier_integral_s against the schedule stepped through here every
    5 s (midpoint sum; tau grows from tau_now, the next relubrication due at interval - tau_now or now when
    overdue, then every interval; 0: none; the multiplier clipped at 0): to 1e-3 of the horizon."""
    from guide_health.models.wear.effect_life import lubrication_multiplier_integral_s

    dt = 5.0
    u = (np.arange(int(horizon_h * H / dt)) + 0.5) * dt
    due = max(interval_h * H - tau_h * H, 0.0) if interval_h else math.inf
    tau = np.where(u < due, tau_h * H + u, np.mod(u - due, interval_h * H) if interval_h else 0.0)
    summed = float(np.sum(np.maximum(1.0 + b_s * tau, 0.0)) * dt)
    exact = float(lubrication_multiplier_integral_s(u.size * dt, b_s, tau_h * H, interval_h * H))
    assert exact == pytest.approx(summed, rel=1e-3, abs=1e-3 * horizon_h * H + 1e-6)


def lubricated_bench(seed: int, b_per_s: float = 5.6e-5, interval_h: float = 5.0):
    """bench 000 (constant duty), relubricated every interval_h, the lubrication_interval effect hidden by the
    simulator (30 h, 5 Hz, a measurement every 15 min, noise 0.05 um); the truth's time to the limit [h]."""
    bench = ROOT / "config" / "bench_000.yaml"
    params = wear_monitor_params(bench)
    sim = dict(simulation_params(bench), duration_h=30.0, joint_state_rate_hz=5.0, relubrication_interval_h=interval_h,
               straightness_noise_m=0.05e-6, measurement_interval_h=0.25)
    run = simulate_machine(params, sim, seed=seed, effects={"lubrication_interval": b_per_s})
    truth = run.metadata["truth"]
    t, y = np.asarray(truth["straightness_t_s"]), np.asarray(truth["straightness_m"])
    k = int(np.argmax(y >= params["straightness_limit_m"]))
    end_h = float(np.interp(params["straightness_limit_m"], y[k - 1:k + 1], t[k - 1:k + 1])) / H
    return params, sim, run, end_h


def test_the_remaining_life_follows_the_relubrication_schedule():
    """Constant duty, relubricated every 5 h, the true lubrication_interval parameters live: the predicted time
    at the limit (now + remaining life) is the truth's at every half hour of a cycle, in the recorded form (the
    relubricate events, lubrication_forecast_interval_s 5 h) and the interval form (T = 5 h), to 1 %. Measured
    before the schedule (the duty window's mean multiplier for all the future): 18.25..21.12 h against 19.1 h.
    Without an expected relubrication (interval 0) the time since the last keeps growing: earlier (17.55 h at
    the start of a cycle), never later."""
    from guide_health.models.wear.axis import split_run

    params, sim, run, end_h = lubricated_bench(3)
    t0 = int(run.joint_t_ns[0])
    k = params["wear_coefficient"] * sim["wear_coefficient_factor"]
    recorded = {"lubrication_interval_s": 0.0, "lubrication_reference_stamp_s": t0 * 1e-9,
                "lubrication_wear_growth": 5.6e-5}
    forms = {"recorded": {**recorded, "lubrication_forecast_interval_s": 5 * H},
             "interval": {"lubrication_interval_s": 5 * H, "lubrication_reference_stamp_s": t0 * 1e-9,
                          "lubrication_wear_growth": 5.6e-5 * 5 * H},
             "none expected": recorded}
    ends = {}
    for name, extra in forms.items():
        axis = AxisMonitor(wear_axis_params({**params, "effects": "lubrication_interval", "wear_coefficient": k,
                                             **extra}))
        if name != "interval":
            for j in range(1, 6):
                axis.schedule(MaintenanceEvent(t0 + int(j * 5 * H * 1e9), "relubricate", params["joint"]))
        rest, ends[name] = run, []
        for hours in np.arange(10.5, 18.6, 0.5):
            head, rest = split_run(rest, t0 + int(hours * H * 1e9))
            axis.process_run(head)
            ends[name].append(hours + axis.primary.report()["remaining_life_h"])
    print({n: f"{min(e):.2f}..{max(e):.2f}" for n, e in ends.items()}, f"truth {end_h:.2f}")
    for name in ("recorded", "interval"):
        assert np.asarray(ends[name]) == pytest.approx(end_h, rel=0.01), name
    assert max(ends["none expected"]) < 1.001 * end_h and min(ends["none expected"]) < 0.95 * end_h


def test_the_interval_carries_the_lubrication_growth_as_a_rerun_moves_the_life():
    """b's share of the interval (its variance alone) equals the life's change when the whole monitor is rerun
    with b moved by that sd (5 %): b moves the past effective work (K refitted), the duty window's rate and the
    schedule's future multiplier."""
    from guide_health.models.wear.axis import split_run
    from guide_health.models.wear.effects.registry import COVARIANCE_NAMES

    params, sim, run, _ = lubricated_bench(4)
    t0 = int(run.joint_t_ns[0])
    head = split_run(run, t0 + int(12.2 * H * 1e9))[0]
    n, i = len(COVARIANCE_NAMES), COVARIANCE_NAMES.index("lubrication_wear_growth")
    b, sd = 5.6e-5, 0.5e-5

    def life(growth: float, variance: float) -> dict:
        cov = np.zeros((n, n))
        cov[i, i] = variance
        axis = AxisMonitor(wear_axis_params({**params, "effects": "lubrication_interval", "lubrication_interval_s": 0.0,
                            "lubrication_reference_stamp_s": t0 * 1e-9, "lubrication_wear_growth": growth,
                            "lubrication_forecast_interval_s": 5 * H, "effect_covariance": cov.ravel().tolist()}))
        for j in (1, 2):
            axis.schedule(MaintenanceEvent(t0 + int(j * 5 * H * 1e9), "relubricate", params["joint"]))
        axis.process_run(head)
        return axis.primary.report()

    none, one = life(b, 0.0), life(b, sd ** 2)
    t = _t90(none)
    half = [math.log(r["remaining_life_h_high"] / r["remaining_life_h"]) for r in (none, one)]
    predicted = math.sqrt(half[1] ** 2 - half[0] ** 2) / t
    up, down = life(b + sd, 0.0)["remaining_life_h"], life(b - sd, 0.0)["remaining_life_h"]
    rerun = abs(math.log(up / down)) / 2.0
    print(f"b: delta method {predicted:.5f}, rerun {rerun:.5f}")
    assert predicted == pytest.approx(rerun, rel=0.05)
    assert predicted > 0.2 * half[0] / t


def test_the_model_file_carries_the_recorded_relubrication_interval():
    """Recorded form: lubrication_forecast_interval_s is the record's mean gap between relubrications
    (3, 8, 12 h: 4.5 h); one recorded: 0 (none expected)."""
    from types import SimpleNamespace

    from guide_health.analysis.discrepancy.model_file import duty_effect_parameters

    for relube_h, expected_h in (([3.0, 8.0, 12.0], 4.5), ([3.0], 0.0)):
        problem = SimpleNamespace(cells=SimpleNamespace(t0_ns=10 ** 18), relubrication_t_s=np.array(relube_h) * H)
        out = duty_effect_parameters(problem, {"lubrication_wear_growth_per_s": 5e-5}, ["lubrication_interval"])
        assert out["lubrication_forecast_interval_s"] == pytest.approx(expected_h * H, rel=1e-12)
        assert out["lubrication_reference_stamp_s"] == pytest.approx(1e9 + relube_h[-1] * H, rel=1e-12)


# --- the simulator hides the duty effects (simulate --effect) ----------------------------------------------

@pytest.mark.parametrize("effect, value, sim_extra", [
    ("wear_rate_change", 2.0, {"wear_rate_change_h": 1.3}),
    ("lubrication_interval", 1.0e-4, {"relubrication_interval_h": 1.1}),
    # over whole jobs the rail's factor averages to 1 about x_ref: 20 h of jobs at their own positions
    ("load_along_rail", 2.5, {"duration_h": 20.0}),
])
def test_the_simulator_hides_the_duty_effects_as_this_file_integrates_them(effect, value, sim_extra):
    """The simulator's noise-free truth (exact knots, the package's effect terms) against this file's own
    sample integration of the same motion: the effect's part (truth minus the same run without it) equal to
    2 % of its largest value (measured 0.07, 0.1, 1.0 %), the whole wear to 0.3 % (the sampling of the
    reversals); the automatic relubrications are in the run's metadata; x_ref is the work-weighted mean
    position."""
    params = wear_monitor_params(JOBS)
    sim = {**simulation_params(JOBS), "duration_h": 4.0, "joint_state_rate_hz": 20.0, "load_rate_hz": 20.0,
           "straightness_noise_m": 0.0, **sim_extra}
    run = simulate_machine(params, sim, seed=4, effects={effect: value})
    truth = run.metadata["truth"]
    t0_s = int(run.joint_t_ns[0]) * 1e-9
    relube_s = [t0_s + t for t in run.metadata["relubrication_t_s"]]
    if effect == "wear_rate_change":
        case = {"f": value, "t_c": t0_s + 1.3 * H}
    elif effect == "lubrication_interval":
        assert run.metadata["relubrication_t_s"] == pytest.approx([1.1 * H, 2.2 * H, 3.3 * H])
        case = {"b": value, "t_first": t0_s}
    else:
        x_ref = run.metadata["effect_parameters"]["load_reference_position_m"]
        x = np.asarray(run.joint_position_m)
        w = np.abs(np.diff(x)) * np.asarray(run.load_n)[np.clip(np.searchsorted(run.load_t_ns, run.joint_t_ns[1:],
                                                                                 side="right") - 1, 0, None)]
        assert x_ref == pytest.approx(np.sum(w * 0.5 * (x[1:] + x[:-1])) / w.sum(), abs=1e-3)
        case = {"g": value, "x_ref": x_ref}
    mine = own_straightness_m(run, params, truth["wear_coefficient"], truth["stroke_min_m"] + truth["stroke_max_m"],
                              case, relube_s)
    simulated = np.asarray(truth["straightness_m"])
    a0 = params["straightness_initial_m"]
    # the same motion without the effect (effects draw no random numbers): the effect's part of each side,
    # free of the sampling difference both share (0.2 % of the wear at 20 Hz, at the reversals)
    twin = np.asarray(simulate_machine(params, sim, seed=4).metadata["truth"]["straightness_m"])
    plain = own_straightness_m(run, params, truth["wear_coefficient"], truth["stroke_min_m"] + truth["stroke_max_m"],
                               {}, [])
    effect_sim, effect_mine = simulated - twin, mine - plain
    match = np.max(np.abs(effect_sim - effect_mine)) / np.max(np.abs(effect_mine))
    print(f"{effect}: simulator vs this file {match:.2g} of the effect (max {np.max(np.abs(effect_mine)) * 1e6:.2f} um)"
          f", whole wear {np.max(np.abs(simulated - mine)[1:] / (mine - a0)[1:]):.2g}")
    assert match < 0.02 and np.max(np.abs(simulated - mine)[1:] / (mine - a0)[1:]) < 3e-3


def test_simulate_diagnose_replay_with_an_automatic_lubricator(tmp_path):
    """The CLI loop on a hidden lubrication_interval (machine_jobs, 20 h, 5 Hz, relubricated every 5 h by the
    simulator, recorded as relubricate events, b = 0.2 per hour): diagnose names it on the recorded time base
    with b within 25 %, writes it to the model file, and replay --params BASE --params model.yaml loads it."""
    import subprocess
    import sys

    base = yaml.safe_load(JOBS.read_text())
    base["guide_health_simulation"]["ros__parameters"].update(duration_h=20.0, joint_state_rate_hz=5.0,
                                                              load_rate_hz=5.0, relubrication_interval_h=5.0)
    params_file = tmp_path / "jobs.yaml"
    params_file.write_text(yaml.safe_dump(base))
    b = 0.2 / H

    def cli(*args):
        proc = subprocess.run([sys.executable, "-m", "guide_health.cli", *args], capture_output=True, text=True,
                              cwd=ROOT, timeout=600)
        assert proc.returncode == 0, proc.stderr
        return proc

    bag = tmp_path / "bag"
    cli("simulate", "--params", str(params_file), "--out", str(bag), "--seed", "3",
        "--effect", f"lubrication_interval={b}")
    cli("diagnose", str(bag), "--params", str(params_file), "--out", str(tmp_path / "diag"), "--no-plot")
    report = json.loads((tmp_path / "diag" / "report.json").read_text())
    assert report["data"]["relubrications_recorded"] == 3
    assert "lubrication_interval" in report["named_effects"], report["named_effects"]
    fitted = report["effects"]["lubrication_interval"]["parameters"]["lubrication_wear_growth_per_s"]["value"]
    print(f"lubrication_interval named {report['named_effects']}, b fitted {fitted / b:.3f} x the hidden one")
    assert fitted == pytest.approx(b, rel=0.25)
    model = yaml.safe_load((tmp_path / "diag" / "model.yaml").read_text())["/**/wear_monitor"]["ros__parameters"]
    assert "lubrication_interval" in model["effects"] and model["lubrication_interval_s"] == 0.0
    out = json.loads(cli("replay", str(bag), "--params", str(params_file), "--params", str(tmp_path / "diag" /
                                                                                           "model.yaml"),
                         "--out", str(tmp_path / "replay"), "--no-plot", "--json").stdout)
    assert out["effects"] == model["effects"] and out["remaining_life_h"] > 0


@pytest.mark.parametrize("config, extra", [
    ("nsk_lh45.yaml", {}),                                    # a rolling guide: Walther oil viscosity
    ("machine_jobs.yaml", {"effects": "thermal_drift", "thermal_drift_m_per_k": 1e-6, "thermal_reference_c": 20.0}),
])
def test_implausible_temperatures_are_counted_rejections_live_and_offline(config, extra):
    """NaN, -274 degC, 1e300 degC and 600 degC readings: each a counted rejection with one reason, the same per
    message and per run, no exception (a 1e300 reading overflowed the rolling guide's Walther viscosity, a
    -274 one raised, before stop 11); the plausible reading applies."""
    from guide_health.models.wear.input_rules import TEMPERATURE_IMPLAUSIBLE, rejected_key
    from guide_health.runs import MachineRun

    params = {**wear_monitor_params(ROOT / "config" / config), **extra}
    t0 = 1_700_000_000_000_000_000
    temps = [(t0 + 1, math.nan), (t0 + 2, -274.0), (t0 + 3, 1e300), (t0 + 4, 600.0), (t0 + 5, 25.0)]
    joints = [(t0 + 10 * i * 10**6, 0.1 + 0.001 * i) for i in range(200)]
    live = PrecisionMonitor(wear_axis_params(params))
    reasons = [live.on_temperature(t, c) for t, c in temps]
    assert reasons == [TEMPERATURE_IMPLAUSIBLE] * 4 + [None]
    live.on_load(t0, 1000.0)
    for t, x in joints:
        live.on_joint(t, x)
    live.on_straightness(joints[-1][0], 20e-6)
    run = MachineRun("x", np.array([t for t, _ in joints], dtype=np.int64), np.array([x for _, x in joints]),
                     np.zeros(0), np.array([t0], dtype=np.int64), np.array([1000.0]),
                     np.array([joints[-1][0]], dtype=np.int64), np.array([20e-6]),
                     temperature_t_ns=np.array([t for t, _ in temps], dtype=np.int64),
                     temperature_c=np.array([c for _, c in temps]))
    offline = PrecisionMonitor(wear_axis_params(params))
    offline.process_run(run)
    a, b = live.report(), offline.report()
    assert a[rejected_key(TEMPERATURE_IMPLAUSIBLE)] == b[rejected_key(TEMPERATURE_IMPLAUSIBLE)] == 4
    assert a["measurements"] == b["measurements"] == 1
    assert a["straightness_measured_um"] == pytest.approx(b["straightness_measured_um"], rel=1e-12)
