"""slewing_monitor: the ROS-free core (bad loads, lift-off, worst per period, levels), the node in-process
(STALE, keys), the numerical table, and a slewing bag replayed through bag_player -> slewing_monitor
against the offline analysis of the same bag."""
import math
import time
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.slewing_replay import analyse_slewing_run
from guide_health.models.slewing.monitor import SlewingContactModel, SlewingMonitor, slewing_contact_report
from guide_health.models.slewing.row_loads import axial_row_roller_loads
from guide_health.nodes.slewing_monitor import ROLLER_CONTACT_KEYS
from guide_health.params import SLEWING_MONITOR_DEFAULTS
from guide_health.params.typed import slewing_monitor_params
from guide_health.sim.slewing import simulate_slewing

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "slewing_131.32.2000.00Z.yaml"
PARAMS = dict(SLEWING_MONITOR_DEFAULTS)


def test_bad_loads_get_a_status_and_never_crash():
    core = SlewingMonitor(slewing_monitor_params(dict(PARAMS)))
    for bad in ((math.nan, 0.0, 1e6), (1e5, math.inf, 0.0), (1e5, 0.0, -math.inf)):
        assert core.on_loads(*bad) == "non-finite load (NaN/inf) ignored"
    level, message, values = core.period_report()
    assert level == 1 and "no valid load" in message and values["rejected_loads"] == 3
    # no load at all: both axial rows unloaded -> WARN with the reason, not an exception
    assert core.on_loads(0.0, 0.0, 0.0) is None
    level, message, _ = core.period_report()
    assert level == 1 and "no axial roller is loaded" in message
    # a moment that lifts the main row's far-side rollers (4 M / D0 > F_a): normal for a three-row
    # bearing (the retaining row takes it), said in the message, level from the stress (OK here)
    assert core.on_loads(1e5, 0.0, 2e6) is None
    level, message, values = core.period_report()
    rows = axial_row_roller_loads(1e5, 2e6, PARAMS["roller_count"], PARAMS["raceway_diameter_m"])
    assert level == 0 and "lifts" in message
    assert values["roller_load_max_n"] == pytest.approx(max(rows.main_row_max_n, rows.opposite_row_max_n))


def test_worst_case_per_period_and_levels_from_the_allowable():
    core = SlewingMonitor(slewing_monitor_params(dict(PARAMS)))
    for moment in (2e6, 9e6, 4e6):                          # the 9e6 N m sample is the worst
        core.on_loads(6e5, 2e4, moment)
    level, _, values = core.period_report()
    direct = slewing_contact_report(slewing_monitor_params(PARAMS), values["roller_load_max_n"])
    q = axial_row_roller_loads(6e5, 9e6, PARAMS["roller_count"], PARAMS["raceway_diameter_m"]).main_row_max_n
    assert values["roller_load_max_n"] == pytest.approx(q)
    assert values["loads_in_period"] == 3
    for key in ("p0_hertz_MPa", "p0_center_MPa", "p0_end_MPa", "von_mises_max_MPa", "shear_max_MPa"):
        assert values[key] == pytest.approx(direct[key], rel=1e-9), key
    p_end = values["p0_end_MPa"] * 1e6
    # thresholds relative to this load's end pressure: below warn -> OK, between -> WARN, above -> ERROR
    for allowable, want in ((p_end / 0.7, 0), (p_end / 0.9, 1), (p_end * 0.95, 2)):
        c = SlewingMonitor(slewing_monitor_params(dict(PARAMS, allowable_contact_stress_pa=allowable,
                                                       warn_fraction=0.8)))
        c.on_loads(6e5, 2e4, 9e6)
        assert c.period_report()[0] == want, allowable
    # the next period starts afresh but keeps the last report when no load came
    core.on_loads(6e5, 0.0, 1e6)
    assert core.period_report()[2]["roller_load_max_n"] < q


def test_numerical_model_is_tabulated_once_and_matches_a_direct_solve():
    from guide_health.models.slewing.monitor import _numerical_report

    p = slewing_monitor_params(dict(PARAMS, stress_model="numerical", roller_end_radius_m=2e-3,
                                    numerical_table_loads=8, numerical_table_min_load_n=2e4,
                                    numerical_table_max_load_n=2e5))
    model = SlewingContactModel(p)
    assert model.table.loads_n.size == 8
    got = model.report_for_roller_load(103_400.0)
    want = _numerical_report(p, 103_400.0)
    for key in ("p_max_MPa", "p0_end_MPa", "end_stress_ratio", "von_mises_max_MPa", "von_mises_depth_mm"):
        assert got[key] == pytest.approx(want[key], rel=0.02), key
    assert got["table_in_range"] and got["end_stress_ratio"] > 1.5     # a real end radius: end peak
    t0 = time.perf_counter()
    for _ in range(200):
        model.report_for_loads(6e5, 2e4, 9e6)
    per_call = (time.perf_counter() - t0) / 200
    assert per_call < 0.05 * model.table.solve_time_per_load_s   # a lookup, not a solve


def test_offline_analysis_finds_the_worst_roller_of_a_crane_duty():
    run = simulate_slewing({"duration_h": 0.02, "load_rate_hz": 50.0}, seed=4)
    _, report = analyse_slewing_run(run, dict(PARAMS))
    model = SlewingContactModel(slewing_monitor_params(PARAMS))
    p = np.array([model.report_for_loads(a, r, m)["p_max_MPa"]
                  for a, r, m in zip(run.axial_n, run.radial_n, run.moment_nm)])
    assert report["p_max_MPa"] == pytest.approx(p.max(), rel=1e-12)
    assert report["worst_t_s"] == pytest.approx((run.t_ns[p.argmax()] - run.t_ns[0]) * 1e-9)
    assert report["samples_ok"] + report["samples_warn"] + report["samples_error"] == run.t_ns.size
    assert p.max() > 1.3 * p.min()                                  # the duty varies


rclpy = pytest.importorskip("rclpy")


def test_node_keys_stale_and_bad_messages(ros_context, monkeypatch):
    """Keys, a counted bad message, and STALE once the loads stop for input_timeout_s. The status clock
    (nodes/status.py's time.monotonic) is the test's: a loaded machine that pauses this process between two
    calls cannot make the loads stale early, and no sleep is needed."""
    import types

    from geometry_msgs.msg import WrenchStamped
    from rclpy.parameter import Parameter

    from guide_health.nodes import status as status_module
    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    clock = [1000.0]
    monkeypatch.setattr(status_module, "time", types.SimpleNamespace(monotonic=lambda: clock[0]))
    node = SlewingMonitorNode(context=ros_context, parameter_overrides=[Parameter("input_timeout_s", value=0.3)])
    published = []
    node.diag_pub.publish = published.append
    try:
        node.publish_diagnostics()
        status = published[-1].status[0]
        assert status.name == "machine/slewing_monitor: 131.32.2000.00Z roller contact" and status.level == b"\x03"
        msg = WrenchStamped()
        msg.wrench.force.z, msg.wrench.force.x, msg.wrench.torque.x = 6e5, 2e4, 5e6
        node._on_load(msg)
        bad = WrenchStamped()
        bad.wrench.torque.y = math.nan
        node._on_load(bad)
        node.publish_diagnostics()
        status = published[-1].status[0]
        values = {kv.key: kv.value for kv in status.values}
        assert set(ROLLER_CONTACT_KEYS) <= set(values)
        assert status.level == b"\x00" and float(values["rejected_loads"]) == 1
        assert float(values["roller_load_max_n"]) == pytest.approx(
            axial_row_roller_loads(6e5, 5e6, 170, 2.0).main_row_max_n)
        clock[0] += 0.29                     # within input_timeout_s: not stale (WARN: this period's only load was bad)
        node.publish_diagnostics()
        assert published[-1].status[0].level == b"\x01"
        clock[0] += 0.02                                     # loads silent for 0.31 s: STALE
        node.publish_diagnostics()
        assert published[-1].status[0].level == b"\x03"
    finally:
        node.destroy_node()


@pytest.mark.parametrize(("overrides", "events"), [
    ({}, True), ({"executor": "single_threaded"}, False), ({"sensor_qos": "best_effort"}, False),
    ({"use_sim_time": True}, False), ({"executor": "events", "sensor_qos": "best_effort"}, True)])
def test_node_spins_the_events_executor_unless_the_loss_count_or_sim_time_needs_the_other(ros_context, overrides,
                                                                                         events):
    """executor auto: events (arrival order across topics: a tilting clearance follows the axis samples received
    before it) unless sensor_qos is best_effort (the exact loss count needs message info) or the node runs on
    /clock; under events no subscription asks for message info (rclpy 7.1.6's EventsExecutor raises SystemError)."""
    from rclpy.parameter import Parameter

    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    node = SlewingMonitorNode(context=ros_context, parameter_overrides=[
        Parameter(name, value=value) for name, value in {"state_file": "none", **overrides}.items()])
    try:
        assert node.events is events
        assert node.sensors.with_info is not events
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_slewing_bag_through_bag_player_and_node_matches_offline(tmp_path, ros_test_env):
    from guide_health.io.bag.reader import read_slewing_bag
    from guide_health.io.bag.writer import write_slewing_bag
    from guide_health.nodes.session import (
        DiagnosticsCollector,
        clean_fastdds_shm,
        play_bag,
        start_node,
        stop_node,
    )
    from guide_health.params import load_node_params

    env = ros_test_env()
    bag = tmp_path / "slewing"
    # 10.8 s of loads at 200 Hz: every message counted and the worst period's contact equal to offline's need no
    # longer stream (the node handles each load message on its own, a few hundred a second)
    write_slewing_bag(simulate_slewing({"duration_h": 0.003, "load_rate_hz": 200.0}, seed=2), bag)
    params = load_node_params(CONFIG, "slewing_monitor", SLEWING_MONITOR_DEFAULTS)
    _, offline = analyse_slewing_run(read_slewing_bag(bag), params)
    name = "slewing_131/slewing_monitor: 131.32.2000.00Z roller contact"
    collector = DiagnosticsCollector("slewing_collector")
    node = start_node("guide_health.nodes.slewing_monitor", CONFIG,
                      {"diagnostics_period_s": 0.2, "input_timeout_s": 2.0}, env, tmp_path / "node.log")
    try:
        assert collector.wait_for(name, timeout=120.0) is not None, (tmp_path / "node.log").read_text()
        played = play_bag(bag, env, ["--wait-subscribers", "1", "--max-rate", "0"])
        assert played.returncode == 0, played.stderr

        def loads_received() -> int:
            return sum(int(float(s["values"]["loads_in_period"])) for s in list(collector.history.get(name, [])))
        # every load counted (a CPU-starved node may pause for longer than input_timeout_s mid-bag and say
        # STALE), then the STALE of the silence after the bag
        end = time.monotonic() + 300.0
        while loads_received() < offline["messages"] and time.monotonic() < end:
            time.sleep(0.1)
        stale = collector.wait_for(name, lambda s: s["level"] == 3 and s["received"] > time.monotonic() - 0.5,
                                   timeout=120.0)
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
    assert stale is not None, "no STALE status after the loads stopped"
    history = collector.history[name]
    received = sum(int(float(s["values"]["loads_in_period"])) for s in history)
    assert received == offline["messages"] == 2160                       # nothing lost
    assert float(history[-1]["values"]["samples_missing_estimate"]) == offline["samples_missing_estimate"] == 0
    periods = [s for s in history if int(float(s["values"]["loads_in_period"])) > 0]
    live_max = max(float(s["values"]["p_max_MPa"]) for s in periods)
    assert live_max == pytest.approx(offline["p_max_MPa"], rel=1e-9)
    worst = max(periods, key=lambda s: float(s["values"]["p_max_MPa"]))
    for key in ("roller_load_max_n", "p0_end_MPa", "von_mises_max_MPa", "von_mises_depth_mm"):
        assert float(worst["values"][key]) == pytest.approx(offline[key], rel=1e-9), key


def test_load_samples_lost_by_stamp_gaps_are_estimated_live_and_offline():
    """A 200 Hz slewing load stream with 37 samples taken out in three gaps (10, 1 and 26 samples) and one
    non-finite sample: the core counts 37 missing (models/wear/stream_gaps.py, as wear_monitor does) whether
    fed per message with stamps (the node) or by the offline analysis; the period is 5000 us; the message
    says it; a complete stream counts 0."""
    import dataclasses

    run = simulate_slewing({"duration_h": 0.02, "load_rate_hz": 200.0}, seed=3)
    keep = np.ones(run.t_ns.size, dtype=bool)
    for lo, n in ((1000, 10), (5000, 1), (9000, 26)):
        keep[lo:lo + n] = False
    gappy = dataclasses.replace(run, t_ns=run.t_ns[keep], axial_n=run.axial_n[keep].copy(),
                                radial_n=run.radial_n[keep], moment_nm=run.moment_nm[keep])
    gappy.axial_n[7000] = math.nan                   # a rejected sample was received: no gap
    params = dict(PARAMS)
    _, offline = analyse_slewing_run(gappy, params)
    live = SlewingMonitor(slewing_monitor_params(params))
    for t, fa, fr, mt in zip(gappy.t_ns.tolist(), gappy.axial_n.tolist(), gappy.radial_n.tolist(),
                             gappy.moment_nm.tolist()):
        live.on_loads(fa, fr, mt, t_ns=t)
    level, message, values = live.period_report()
    assert values["samples_missing_estimate"] == offline["samples_missing_estimate"] == 37
    assert values["load_period_estimate_us"] == pytest.approx(5000.0) and values["load_stamp_pauses"] == 0
    assert "37 load samples missing (stamp gaps)" in message
    assert analyse_slewing_run(run, params)[1]["samples_missing_estimate"] == 0
