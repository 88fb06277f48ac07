"""Raceway wear of a slewing bearing -> tilting clearance -> remaining life to the replacement clearance
(models/slewing/raceway_wear.py, docs/slewing.md "Raceway wear and tilting clearance").

Truths: the closed form d c / (k d phi) = sum_j Q_j chi(Q_j) / (4 pi D_pw) with chi integrated here from the
seed-003 line load (trapezoid written in the test), the conjugate-normal posterior of k written out, Eq. 12's
life by hand, and the simulator's true remaining life (the same random duty continued to the limit).
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from guide_health.models.slewing.finite_roller import finite_roller_contact
from guide_health.params import SLEWING_MONITOR_DEFAULTS
from guide_health.params.typed import slewing_monitor_params

D_PW, Z, L_E, D_WE = 2.0, 170, 0.0313, 0.032


def _monitor(**changes):
    from guide_health.models.slewing.monitor import SlewingMonitor

    return SlewingMonitor(slewing_monitor_params({**SLEWING_MONITOR_DEFAULTS, **changes}))


def _chi(load_n):
    """integral w |y| dy / (Q l_e / 4) of the seed-003 line load, normalised to carry Q (written here)."""
    c = finite_roller_contact(load_n, L_E, D_WE, 210e9, 0.3, points=4001)
    w, y = c.line_load_n_m, c.y_m
    area = np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(y))
    moment = np.sum(0.5 * (w[1:] * abs(y[1:]) + w[:-1] * abs(y[:-1])) * np.diff(y))
    return moment / (area * L_E / 4.0)


def _turn(monitor, revolutions, steps=360, t0=0):
    for k in range(steps * revolutions + 1):
        monitor.on_axis_angle(2 * math.pi * k / steps, t0 + k * 10**9)


def test_axial_load_over_n_revolutions_gives_the_closed_form_clearance():
    """F_a = 600 kN, 3 revolutions: g = 3 F_a chi(F_a / Z) / (2 D_pw) (both raceways of the upper row; the
    lower row unloaded). chi of the end-loaded roller is 1.02-1.04, not 1 (uniform) and not 2 (a factor lost);
    a load reversal wears the other row by the same amount (the tilting clearance sums both)."""
    q = 600e3 / Z
    chi = _chi(q)
    assert 1.02 < chi < 1.04
    m = _monitor()
    m.on_loads(600e3, 0.0, 0.0, t_ns=0)
    _turn(m, 3)
    expected = 3 * 600e3 * chi / (2 * D_PW)
    assert m.wear.clearance_per_k == pytest.approx(expected, rel=2e-3)
    reversed_ = _monitor()
    reversed_.on_loads(-600e3, 0.0, 0.0, t_ns=0)
    _turn(reversed_, 3)
    assert reversed_.wear.clearance_per_k == pytest.approx(expected, rel=2e-3)
    assert reversed_.fatigue.row_damage()["upper_axial"] == 0.0


def test_encoder_noise_at_standstill_wears_nothing():
    m = _monitor()
    m.on_loads(600e3, 0.0, 1.0e6, t_ns=0)
    for k in range(200):
        m.on_axis_angle(1.0 + 2e-4 * (-1) ** k, k * 10**8)      # inside the 1e-3 rad deadband
    assert m.wear.clearance_per_k < 600e3 * 2e-4 / (2 * D_PW) * 1.1 * 3   # at most the first half-step


def test_measured_clearances_update_k_with_the_guides_estimator_and_the_life_follows_eq12():
    """Three clearances on c_0 + k_true g (exact): the posterior written out (prior k0, sd r k0, sigma the
    noise parameter while n < 3, then the residual scatter floor) gives k_true within 1 % (the prior's
    weight); the life equals (c_lim - c_0 - k g) / (k g / T) by hand and its 90 % ends use the interval's
    k ends (higher k, lower life)."""
    k_true, c0, c_lim = 4e-13, 0.3e-3, 1.0e-3
    m = _monitor(raceway_wear_coefficient_m2_n=1e-13)
    m.on_loads(600e3, 0.0, 1.0e6, t_ns=0)
    for j in range(3):
        _turn(m, 500, steps=36, t0=j * 10**12)
        m.on_tilting_clearance(c0 + k_true * m.wear.clearance_per_k)
    g = np.asarray(m.wear.estimator.measurement_loss_per_k_m)
    y = g * k_true
    prior_var = (2.0 * 1e-13) ** 2
    sigma = 20e-6
    k = (1e-13 / prior_var + g @ y / sigma**2) / (1 / prior_var + g @ g / sigma**2)
    values = m.period_report()[2]
    assert values["raceway_wear_coefficient_m2_n"] == pytest.approx(k, rel=1e-9, abs=0.0)
    assert k == pytest.approx(k_true, rel=1e-2, abs=0.0)
    g_now, elapsed = m.wear.clearance_per_k, m.elapsed_s()
    life = (c_lim - c0 - k * g_now) / (k * g_now / elapsed)
    assert values["raceway_wear_remaining_life_h"] == pytest.approx(life / 3600, rel=1e-9)
    k_high = values["raceway_wear_coefficient_high_m2_n"]
    assert values["raceway_wear_remaining_life_low_h"] == pytest.approx(
        (c_lim - c0 - k_high * g_now) / (k_high * g_now / elapsed) / 3600, rel=1e-9)
    assert values["tilting_clearance_predicted_mm"] == pytest.approx((c0 + k * g_now) * 1e3, rel=1e-9)


@pytest.mark.parametrize("value", [math.nan, -1e-4, 0.0, math.inf])
def test_a_bad_clearance_is_refused_in_one_line_and_counted(value):
    m = _monitor()
    reason = m.on_tilting_clearance(value)
    assert reason and "\n" not in reason and m.rejected_clearances == 1 and m.wear.estimator.count == 0


def test_the_clearance_limit_must_exceed_the_initial_clearance():
    from guide_health.errors import InputError

    with pytest.raises(InputError, match="tilting_clearance_limit_m .* must exceed"):
        slewing_monitor_params({**SLEWING_MONITOR_DEFAULTS, "tilting_clearance_limit_m": 0.2e-3})


def test_wear_state_round_trip_and_refusal():
    from guide_health.models.slewing.raceway_wear import check_wear_state

    m = _monitor()
    m.on_loads(600e3, 0.0, 1.0e6, t_ns=0)
    _turn(m, 2)
    m.on_tilting_clearance(0.35e-3)
    state = m.wear.state()
    other = _monitor()
    other.wear.restore(state)
    assert other.wear.report(100.0) == m.wear.report(100.0)
    bad = {**state, "clearance_per_k": -1.0}
    with pytest.raises(ValueError, match="clearance_per_k must be finite and >= 0"):
        check_wear_state(bad)
    bad = {**state, "measurements": {**state["measurements"], "measurement_m": []}}
    with pytest.raises(ValueError, match="unequal length"):
        other.wear.restore(bad)
    assert other.wear.estimator.count == 1


# ---- the acceptance: a simulated 2-year yaw duty with 6 tilting-clearance measurements -----------------

YAW = {"duty": "yaw", "duration_h": 2 * 8760.0, "yaw_dwell_mean_s": 4 * 3600.0, "axis_sample_step_rad": 1.0,
       "clearance_measurements": 6, "true_raceway_wear_coefficient_m2_n": 8e-13}
#: the monitor's prior k is 4x below the simulated bearing's: the measurements must carry the estimate
MONITOR = {**SLEWING_MONITOR_DEFAULTS, "machine_id": "yaw1", "raceway_wear_coefficient_m2_n": 2e-13}


@pytest.fixture(scope="module")
def yaw_run():
    from guide_health.sim.slewing import simulate_slewing

    return simulate_slewing(YAW, seed=11)


def test_two_year_yaw_duty_life_interval_covers_the_simulated_truth(yaw_run):
    """The remaining life to the replacement clearance: its 90 % interval covers the true life (the same
    random duty continued to the limit); the point within 15 % of it; k within 10 % of the true 8e-13 (from a
    prior 4x off). The run stays small: ~4400 motions, one load each."""
    from guide_health.analysis.slewing_replay import analyse_slewing_run

    assert yaw_run.clearance_m.size == 6 and yaw_run.t_ns.size < 6000
    truth_h = yaw_run.metadata["truth_remaining_life_h"]
    assert math.isfinite(truth_h) and truth_h > 1000
    _, report = analyse_slewing_run(yaw_run, MONITOR)
    assert report["tilting_clearance_measurements"] == 6
    assert report["raceway_wear_coefficient_m2_n"] == pytest.approx(8e-13, rel=0.10, abs=0.0)
    low, life, high = (report[f"raceway_wear_remaining_life{s}_h"] for s in ("_low", "", "_high"))
    assert low <= truth_h <= high, (low, truth_h, high)
    assert life == pytest.approx(truth_h, rel=0.15)
    assert high / low < 2.0


def test_simulate_cli_yaw_and_pitch_bags_carry_axis_and_clearances(tmp_path):
    """`guide-health simulate --kind slewing --duty yaw|pitch`: the bag holds loads, the axis and the
    clearances; a pitch duty's strokes are small (below theta_crit = 2.12 deg for most)."""
    from guide_health.cli.app import main
    from guide_health.io.bag.reader import read_slewing_bag

    params = tmp_path / "p.yaml"
    params.write_text("guide_health_slewing_simulation:\n  ros__parameters:\n    duration_h: 0.5\n"
                      "    yaw_dwell_mean_s: 300.0\n")
    for duty in ("yaw", "pitch"):
        out = tmp_path / duty
        assert main(["simulate", "--kind", "slewing", "--duty", duty, "--params", str(params),
                     "--out", str(out)]) == 0
        run = read_slewing_bag(out)
        assert run.clearance_m.size == 6 and run.axis_t_ns.size > run.t_ns.size > 0
        swing = np.abs(np.diff(run.axis_angle_rad))
        if duty == "pitch":
            assert np.max(np.abs(run.axis_angle_rad)) <= 0.05 + 1e-12
        else:
            assert swing.max() <= 1.0 + 1e-12


def test_replay_text_of_a_yaw_bag_shows_fatigue_static_safety_and_wear(tmp_path, capsys):
    """`replay` of a slewing bag with the axis and clearance readings: the text shows each row's damage and
    remaining life, the governing row, S0 and the raceway wear's clearance, k and life, as report.json has
    them (formatted from the same numbers)."""
    import json

    from guide_health.cli.app import main

    params = tmp_path / "p.yaml"
    params.write_text("guide_health_slewing_simulation:\n  ros__parameters:\n    duration_h: 0.5\n"
                      "    yaw_dwell_mean_s: 300.0\n")
    bag = tmp_path / "yaw"
    assert main(["simulate", "--kind", "slewing", "--duty", "yaw", "--params", str(params), "--out", str(bag)]) == 0
    capsys.readouterr()
    node = tmp_path / "slewing.yaml"
    node.write_text("slewing_monitor:\n  ros__parameters:\n    machine_id: yaw1\n")
    assert main(["replay", str(bag), "--params", str(node), "--out", str(tmp_path / "rep"), "--no-plot"]) == 0
    text = capsys.readouterr().out
    report = json.loads((tmp_path / "rep" / "report.json").read_text())
    for row in ("upper_axial", "lower_axial", "radial"):
        assert (f"fatigue {row}:" in text and f"damage {report[f'fatigue_damage_{row}']:.3g}," in text), row
    assert f"governing row:     {report['fatigue_governing_row']} (" in text
    assert f"static safety S0:  {report['static_safety_factor']:.3g} ({report['static_safety_row']} row)" in text
    assert report["tilting_clearance_measurements"] == 6 and "(6 readings)" in text
    assert f"raceway wear k:    {report['raceway_wear_coefficient_m2_n']:.4g} m^2/N" in text
    assert f"to the limit:      {report['raceway_wear_remaining_life_h']:.4g} h" in text


def test_fleet_replay_of_slewing_bearings_only(tmp_path, capsys):
    """`fleet replay` of two slewing bags with a params file of a slewing_monitor section only: each row holds
    its bag's governing row, that row's damage and remaining life, S0 and the life to the clearance limit as
    the single `replay` has them; the ranking is by the governing row's remaining fatigue life; the text
    has a line per bearing."""
    import csv
    import json
    from pathlib import Path

    from guide_health.analysis.fleet_report import ranking
    from guide_health.cli.app import main

    sim = tmp_path / "p.yaml"
    sim.write_text("guide_health_slewing_simulation:\n  ros__parameters:\n    duration_h: 0.5\n"
                   "    yaw_dwell_mean_s: 300.0\n")
    for duty in ("yaw", "pitch"):
        assert main(["simulate", "--kind", "slewing", "--duty", duty, "--params", str(sim),
                     "--out", str(tmp_path / "fleet" / duty)]) == 0
    node = tmp_path / "slewing.yaml"
    node.write_text("slewing_monitor:\n  ros__parameters:\n    machine_id: b1\n")
    singles = {}
    for duty in ("yaw", "pitch"):
        assert main(["replay", str(tmp_path / "fleet" / duty), "--params", str(node), "--out",
                     str(tmp_path / f"one_{duty}"), "--no-plot"]) == 0
        singles[duty] = json.loads((tmp_path / f"one_{duty}" / "report.json").read_text())
    capsys.readouterr()
    assert main(["fleet", "replay", str(tmp_path / "fleet"), "--params", str(node), "--workers", "0",
                 "--out", str(tmp_path / "out")]) == 0
    text = capsys.readouterr().out
    with open(tmp_path / "out" / "fleet.csv") as handle:
        rows = {Path(r["bag"]).name: r for r in csv.DictReader(handle)}
    for duty, one in singles.items():
        row, governing = rows[duty], one["fatigue_governing_row"]
        assert row["fatigue_governing_row"] == governing and row["kind"] == "slewing"
        assert float(row["fatigue_damage"]) == pytest.approx(one[f"fatigue_damage_{governing}"], rel=1e-5)
        assert float(row["fatigue_remaining_life_h"]) == pytest.approx(
            one[f"fatigue_remaining_life_{governing}_h"], rel=1e-5)
        assert float(row["static_safety_factor"]) == pytest.approx(one["static_safety_factor"], rel=1e-5)
        assert float(row["raceway_wear_remaining_life_h"]) == pytest.approx(one["raceway_wear_remaining_life_h"],
                                                                            rel=1e-5)
        assert f"fatigue {governing} row damage {one[f'fatigue_damage_{governing}']:.3g}," in text
    result = json.loads((tmp_path / "out" / "fleet.json").read_text())
    key, ranked = ranking([{**r, **{k: float(r[k]) for k in ("fatigue_remaining_life_h",) if r[k]}}
                           for r in rows.values()])
    assert key == "fatigue_remaining_life_h" and len(ranked) == 2
    assert ranked[0]["fatigue_remaining_life_h"] <= ranked[1]["fatigue_remaining_life_h"]
    assert result["summary"]["ok"] == 2 and (tmp_path / "out" / "fleet_ranking.png").stat().st_size > 1000


@pytest.mark.ros
def test_live_yaw_bag_equals_replay_for_every_wear_key(tmp_path, ros_test_env):
    """bag_player -> slewing_monitor (its tilting_clearance topic) == `replay` of the same bag: every reading
    dated at the axis stamp replay gives it (the latest axis sample stamped at or before its log time, computed
    here from the bag), every raceway wear key and the fatigue damage to 1e-9 (the same samples in
    the same order). A Float64 reading has no stamp: the node's events executor (the default) handles messages
    in arrival order across topics, and the player sends a reading only once the data before it is in the
    node's reader queues, so the reading follows exactly the axis samples before it however far the node lags.
    No settle time: the bag is played at the default rate, so a loaded node works through a backlog after the
    player ends, and its status reaches replay's numbers once it has (waited for, up to 180 s). (The
    single-threaded executor, which takes one message per subscription per wait, dated the readings here 2 300
    to 13 800 h of travel early on a loaded machine: predicted clearance 0.330 mm against replay's 0.365 mm.)"""
    import yaml

    from guide_health.analysis.replay import analyse_slewing_bag
    from guide_health.io.bag.reader import read_slewing_bag
    from guide_health.io.bag.writer import write_slewing_bag
    from guide_health.models.slewing.raceway_wear import RACEWAY_WEAR_KEYS
    from guide_health.nodes.session import DiagnosticsCollector, clean_fastdds_shm, play_bag, start_node, stop_node
    from guide_health.sim.slewing import simulate_slewing

    env = ros_test_env()
    # the same 2-year yaw duty, coarser (a motion a day, one axis sample per motion): ~2 200 messages
    run = simulate_slewing({**YAW, "yaw_dwell_mean_s": 86400.0, "axis_sample_step_rad": 3.2}, seed=11)
    bag = write_slewing_bag(run, tmp_path / "yaw")
    config = tmp_path / "params.yaml"
    config.write_text(yaml.safe_dump({"slewing_monitor": {"ros__parameters": {
        "machine_id": "yaw1", "raceway_wear_coefficient_m2_n": 2e-13}}}))
    _, offline, _, _ = analyse_slewing_bag(bag, MONITOR)
    name = "yaw1/slewing_monitor: 131.32.2000.00Z roller contact"
    overrides = {"diagnostics_period_s": 0.2, "input_timeout_s": 30.0, "state_file": "none"}
    collector = DiagnosticsCollector("slewing_wear_collector")
    node = start_node("guide_health.nodes.slewing_monitor", config, overrides, env, tmp_path / "node.log")
    try:
        assert collector.wait_for(name, timeout=120.0) is not None, (tmp_path / "node.log").read_text()
        played = play_bag(bag, env, ["--wait-subscribers", "1"])
        assert played.returncode == 0, played.stderr
        keys = (*RACEWAY_WEAR_KEYS, "fatigue_damage_upper_axial")

        def replay_numbers(status) -> bool:
            return all(float(status["values"].get(key, "nan")) == pytest.approx(offline[key], rel=1e-9, abs=0.0)
                       for key in keys)
        # the player ends once the node's reader queues hold everything; a loaded node is still working through
        # them: its numbers reach replay's once it has (a misdated or lost reading never does)
        done = collector.wait_for(name, replay_numbers, timeout=180.0)
        last = collector.get(name)
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
    assert done is not None, {key: ((last or {"values": {}})["values"].get(key), offline[key]) for key in keys}
    recorded = read_slewing_bag(bag)           # the stamps as the bag holds them (replay's input)
    axis_t = np.asarray(recorded.axis_t_ns, dtype=np.int64)
    replay_dates = np.array([axis_t[axis_t <= t].max() for t in np.asarray(recorded.clearance_t_ns, np.int64)])
    live_dates = np.array([int(t) for t in re.findall(r"tilting clearance .* at axis stamp (\d+) ns",
                                                      (tmp_path / "node.log").read_text())], dtype=np.int64)
    # the estimator's times pass through float64 (256 ns steps here); the axis samples are hours apart
    assert live_dates.size == 6 and np.all(np.abs(live_dates - replay_dates) < 1000), (live_dates.tolist(),
                                                                                      replay_dates.tolist())


def test_the_bag_size_guard_expects_the_duty_s_message_count(yaw_run):
    """`simulate`'s size guard estimates the expected messages of an oscillating duty from its mean cycle: the
    2-year yaw run above (loads + axis samples + readings: ~18 000) within 20 % of it, where the shortest dwell
    would estimate ~5 M and refuse a long duty's bag by its size; a pitch hour likewise."""
    from guide_health.cli.simulate import _slewing_messages_per_s
    from guide_health.params.simulation import slewing_simulation_params
    from guide_health.sim.slewing import simulate_slewing

    for sim, run in ((YAW, yaw_run), ({"duty": "pitch", "duration_h": 1.0}, None)):
        values = slewing_simulation_params(sim)
        run = run if run is not None else simulate_slewing(sim, seed=3)
        written = run.t_ns.size + run.axis_t_ns.size + run.clearance_m.size
        expected = _slewing_messages_per_s(values) * values["duration_h"] * 3600.0
        assert written == pytest.approx(expected, rel=0.20), (sim["duty"], written, expected)
