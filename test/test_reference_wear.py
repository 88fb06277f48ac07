"""The independent reference of the discrepancy acceptance (test/reference_wear.py) against closed forms,
and the package's simulator truth and candidate model against the reference.

The reference shares no function with guide_health.analysis.discrepancy or guide_health.models.wear:
a wrong effect term in the package (exponent, factor, sign, direction) shows up here as a difference
between the package and this truth, instead of being in both.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.analysis.discrepancy.model import WearProblem
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.runs import MachineRun
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_wear as ref  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"
K, H, B, LS = 4.42e-6, 199e6, 0.040, 0.100       # seed 000 / config/machine_jobs.yaml
A0 = 15e-6

ALL_EFFECTS = {"running_in": 2.0, "retract_asymmetry": 0.3, "speed_dependent_wear": 0.05, "load_exponent": 1.5,
               "stroke_distribution": 0.7, "thermal_drift": 1e-6, "initial_offset": 3e-6}


def constant_duty_run(stroke_m, cycles, v_feed, v_back, w_feed, w_back, rate_hz=100.0):
    """Feed 0 -> L at v_feed under w_feed, retract at v_back under w_back, no dwell; samples at every
    reversal (stroke and speeds chosen so), straightness measured after every cycle."""
    t_feed, t_back = stroke_m / v_feed, stroke_m / v_back
    n_f, n_b = round(t_feed * rate_hz), round(t_back * rate_hz)
    assert abs(n_f - t_feed * rate_hz) < 1e-9 and abs(n_b - t_back * rate_hz) < 1e-9
    x_cycle = np.concatenate((np.linspace(0, stroke_m, n_f + 1)[:-1], np.linspace(stroke_m, 0, n_b + 1)[:-1]))
    x = np.concatenate((np.tile(x_cycle, cycles), [0.0]))
    t_ns = np.round(np.arange(x.size) * 1e9 / rate_hz).astype(np.int64)
    per = n_f + n_b
    # load sample stamped half a period into each interval: the feed load while moving +x
    load_t = t_ns[:-1] + int(0.5e9 / rate_hz)
    load = np.where(np.diff(x) > 0, w_feed, w_back)
    meas = t_ns[::per]
    return MachineRun(joint_t_ns=t_ns, joint_position_m=x, load_t_ns=load_t, load_n=load,
                      straightness_t_ns=meas, straightness_m=np.zeros(meas.size))


@pytest.mark.parametrize("hidden", [
    ref.Hidden(),
    ref.Hidden(running_in_ratio=2.0, running_in_distance_m=3.0),
    ref.Hidden(retract_wear_factor=0.2),
    ref.Hidden(lift_speed_m_s=0.05),
    ref.Hidden(load_exponent=1.7, load_reference_n=5000.0),
    ref.Hidden(stroke_distribution_weight=0.8),
    ref.Hidden(running_in_ratio=1.5, running_in_distance_m=2.0, retract_wear_factor=0.5, lift_speed_m_s=0.03,
               load_exponent=1.4, stroke_distribution_weight=0.6, initial_offset_m=2e-6),
], ids=["none", "running_in", "retract", "speed", "load_exponent", "stroke", "all"])
@pytest.mark.parametrize("stroke_m", [0.06, 0.2])
def test_reference_integration_is_the_closed_form_at_constant_duty(hidden, stroke_m):
    """Sample by sample == the constant-duty closed form (pass length = L; L < L_s covers the slider's L only)."""
    cycles = 20
    run = constant_duty_run(stroke_m, cycles, 0.02, 0.2, 8000.0, 2000.0)
    got = ref.reference_straightness_m(run, hidden, wear_coefficient=K, hardness_pa=H, contact_width_m=B,
                                       slider_length_m=LS, straightness_initial_m=A0, stroke_sum_m=2 * stroke_m)
    closed = A0 + hidden.initial_offset_m + ref.constant_duty_wear_m(
        hidden, K, H, B, stroke_m, np.arange(cycles + 1), 8000.0, 2000.0, 0.02, 0.2, LS)
    assert got == pytest.approx(closed, rel=1e-9, abs=1e-15)
    if hidden == ref.Hidden():          # Eq. 7/10 by hand: A = A0 + 2 K W s / (H b (l_min + l_max))
        s_cycle_work = stroke_m * (8000.0 + 2000.0)
        assert got[-1] - A0 == pytest.approx(K * cycles * s_cycle_work / (H * B * stroke_m), rel=1e-12)


def test_running_in_closed_form_limits():
    """S(s) = s + r s0 (1 - e^(-s/s0)): (1 + r) s at the start, s + r s0 long after."""
    assert ref.effective_distance_running_in(1e-6, 2.0, 100.0) == pytest.approx(3e-6, rel=1e-6)
    assert ref.effective_distance_running_in(1e5, 2.0, 100.0) == pytest.approx(1e5 + 200.0, rel=1e-12)


def sim_case(effects, seed=3, s0=400.0):
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(joint_state_rate_hz=20.0, load_rate_hz=20.0, straightness_noise_m=0.0, running_in_distance_m=s0)
    run = simulate_machine(params, sim, seed=seed, effects=effects)
    truth = run.metadata["truth"]
    hidden = ref.hidden_from_effects(effects, s0, sim["load_reference_n"])
    y = ref.reference_straightness_m(
        run, hidden, wear_coefficient=params["wear_coefficient"], hardness_pa=params["hardness_pa"],
        contact_width_m=params["contact_width_m"], slider_length_m=params["slider_length_m"],
        straightness_initial_m=params["straightness_initial_m"],
        stroke_sum_m=truth["stroke_min_m"] + truth["stroke_max_m"])
    return params, sim, run, np.asarray(truth["straightness_m"]), y


@pytest.mark.parametrize("effect", [None, *ALL_EFFECTS, "all"])
def test_simulator_truth_is_the_independent_reference(effect):
    """sim/machine.py's truth (exact knots, shared effect functions) == the reference over the 20 Hz
    samples, to the sampling error (0.13..0.25 um of a 20..60 um loss, 2026-11-23)."""
    effects = {} if effect is None else dict(ALL_EFFECTS) if effect == "all" else {effect: ALL_EFFECTS[effect]}
    _, _, _, truth, y = sim_case(effects)
    loss = truth[-1] - truth[0]
    assert np.abs(truth - y).max() < min(0.01 * loss, 0.35e-6), effect


@pytest.mark.parametrize("effect", [None, *ALL_EFFECTS, "all"])
def test_candidate_model_with_the_true_parameters_is_the_reference(effect):
    """The workflow's model (duty cells) with the hidden values reproduces the reference truth; the
    model keeps its own W_ref (work-weighted geometric mean load), so K is rescaled by
    (W_ref,model / W_ref,hidden)^(n - 1): nothing hidden is handed to it."""
    effects = {} if effect is None else dict(ALL_EFFECTS) if effect == "all" else {effect: ALL_EFFECTS[effect]}
    params, sim, run, _, y = sim_case(effects)
    problem = WearProblem(duty_cells_from_runs(run, params["slider_length_m"]), params)
    n = effects.get("load_exponent", 1.0)
    values = {"wear_coefficient": params["wear_coefficient"]
              * (problem.fit_references["load_reference_n"] / sim["load_reference_n"]) ** (n - 1.0)}
    names = {"running_in": "running_in_ratio", "retract_asymmetry": "retract_wear_factor",
             "speed_dependent_wear": "lift_speed_m_s", "load_exponent": "load_exponent",
             "stroke_distribution": "stroke_distribution_weight", "thermal_drift": "thermal_drift_m_per_k",
             "initial_offset": "initial_offset_m"}
    values.update({names[k]: v for k, v in effects.items()})
    if "running_in" in effects:
        values["running_in_distance_m"] = sim["running_in_distance_m"]
    pred = problem.predict_m(values)
    loss = y[-1] - y[0]
    assert np.abs(pred - y).max() < min(0.01 * loss, 0.4e-6), effect
    assert math.isfinite(loss) and loss > 15e-6
