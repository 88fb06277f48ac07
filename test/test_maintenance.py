"""Maintenance events (issue 16): what each does to the model, simulate --maintenance + replay, a regrind
mid-bag live (real DDS) == offline, the services in-process (event published, logged, applied the same by a
second node from the topic)."""
import json
import math
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from guide_health.errors import InputError
from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.maintenance import MaintenanceEvent
from guide_health.params import machine_axes_params, simulation_params, wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.sim.machine import START_TIME_NS, apply_maintenance_truth, parse_maintenance, simulate_machine

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
NSK = ROOT / "config" / "nsk_lh45.yaml"
H = 3_600_000_000_000


def bench_run(hours=2.0, seed=5, events=()):
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=hours, joint_state_rate_hz=10.0, load_rate_hz=1.0)
    run = simulate_machine(params, sim, seed=seed)
    apply_maintenance_truth(run, list(events), params)
    return params, run


def regrind(at_h: float, after_um: float | None = 10.0, guide: str = "") -> MaintenanceEvent:
    return MaintenanceEvent(START_TIME_NS + int(at_h * H), "regrind", "x", guide,
                            math.nan if after_um is None else after_um * 1e-6, "test")


# --- the model -----------------------------------------------------------------------------------------
def test_regrind_restarts_straightness_from_the_measured_value_and_keeps_k():
    params, run = bench_run()
    event = regrind(1.0)
    model = AxisMonitor(wear_axis_params(params))
    model.schedule(event)
    head_end = int(np.searchsorted(run.joint_t_ns, event.t_ns, side="right"))
    model.process_run(run)
    assert [e.key for e in model.events] == [event.key] and not model.pending
    # independent: a monitor whose guide is new at the event (A0 = 10 um, prior K = the posterior at the
    # event) fed the samples after it gives the same straightness
    before = AxisMonitor(wear_axis_params(params))
    from guide_health.models.wear.axis import split_run

    head, tail = split_run(run, event.t_ns)
    assert head.joint_t_ns.size == head_end
    before.process_run(head)
    k_before, k_sd, _ = before.primary.estimator.posterior(before.primary.measurement_losses_per_k_m())
    slid_before = before.primary.integrator.sliding_distance_m
    worn_um = before.report()["straightness_um"]
    assert worn_um > 14.0                                                # worn before the regrind
    fresh = AxisMonitor(wear_axis_params(dict(params, straightness_initial_m=10e-6, wear_coefficient=k_before,
                             wear_coefficient_prior_rel_sd=k_sd / k_before)))
    fresh.primary.integrator = before.primary.integrator                 # same motion state, wear reset below
    fresh.primary.integrator.archard_work_nm = 0.0
    fresh.primary.integrator.profile_work_n[:] = 0.0
    fresh.primary.load_n, fresh.primary.load_t_ns = before.primary.load_n, before.primary.load_t_ns
    fresh.primary.joint_base, fresh.primary.load_base = before.primary.joint_base, before.primary.load_base
    fresh.process_run(tail)
    r, f = model.report(), fresh.report()
    assert r["straightness_um"] == pytest.approx(f["straightness_um"], rel=1e-9)
    assert r["wear_coefficient"] == pytest.approx(f["wear_coefficient"], rel=1e-9)
    # the sliding distance is kept (the machine's use), the straightness restarted from 10 um
    assert r["sliding_distance_m"] > slid_before
    assert 10.0 < r["straightness_um"] < worn_um
    assert model.primary.estimator.prior_wear_coefficient == pytest.approx(k_before, rel=1e-12)


def test_straightness_right_after_a_regrind_is_the_post_regrind_value():
    params, run = bench_run(hours=1.0)
    model = AxisMonitor(wear_axis_params(params))
    model.process_run(run)
    assert model.report()["straightness_um"] > 12.0
    t_now = model.last_t_ns
    model.schedule(MaintenanceEvent(t_now, "regrind", "x", "", 9.5e-6, "test"))    # at the present: at once
    assert model.report()["straightness_um"] == pytest.approx(9.5, abs=1e-9)
    model.schedule(MaintenanceEvent(t_now, "regrind", "x", "", 9.5e-6, "topic"))   # same event again: once
    assert len(model.events) == 1
    model.schedule(MaintenanceEvent(t_now + 1, "regrind", "x", "", math.nan, "test"))   # no value: A0
    model.apply_due()
    assert model.report()["straightness_um"] == pytest.approx(15.0, abs=1e-9)


@pytest.mark.parametrize("event,reason", [
    (MaintenanceEvent(0, "regrind", "x", "left", 1e-6), "no guide 'left'"),
    (MaintenanceEvent(0, "regrind", "x", "", 150e-6), "not below the limit"),
    (MaintenanceEvent(0, "measure", "x", "", math.nan), "needs its value"),
    (MaintenanceEvent(0, "polish", "x", "", math.nan), "unknown maintenance kind"),
])
def test_bad_events_are_rejected_and_change_nothing(event, reason):
    model = AxisMonitor(wear_axis_params(wear_monitor_params(BENCH)))
    assert reason in model.schedule(event)
    assert model.events == [] and model.pending == []


def test_carriage_replacement_resets_fatigue_and_keeps_the_rail_wear():
    params = dict(wear_monitor_params(NSK), guides=["left", "right"], guide_load_shares=[0.5, 0.5])
    sim = dict(simulation_params(BENCH), duration_h=0.5, joint_state_rate_hz=10.0, load_rate_hz=1.0)
    run = simulate_machine(params, sim, seed=2)
    model = AxisMonitor(wear_axis_params(params))
    model.process_run(run)
    used = {n: g.fatigue_report()["life_used_fraction"] for n, g in model.guides.items()}
    straight = {n: model.guide(n).report()["straightness_um"] for n in model.guides}
    assert all(u > 0 for u in used.values())
    model.schedule(MaintenanceEvent(model.last_t_ns, "replace_carriage", "x", "left"))
    assert model.guides["left"].fatigue_report()["life_used_fraction"] == 0.0
    assert model.guides["right"].fatigue_report()["life_used_fraction"] == used["right"]
    assert {n: model.guide(n).report()["straightness_um"] for n in model.guides} == straight
    # relubrication: the recent boundary share restarts, the whole-history share stays
    total = model.guide("left").report()["boundary_share_total"]
    model.schedule(MaintenanceEvent(model.last_t_ns, "relubricate", "x"))
    assert model.guide("left").report()["boundary_share_total"] == total


def test_maintenance_state_survives_a_restart():
    params, run = bench_run(hours=1.0)
    model = AxisMonitor(wear_axis_params(params))
    model.process_run(run)
    model.schedule(MaintenanceEvent(model.last_t_ns, "regrind", "x", "", 9.0e-6))
    again = AxisMonitor(wear_axis_params(params))
    again.primary.restore(model.primary.state())
    again.restore_maintenance(json.loads(json.dumps(model.maintenance_state())))
    assert again.report()["straightness_um"] == pytest.approx(9.0, abs=1e-9)
    assert again.report()["wear_coefficient"] == model.report()["wear_coefficient"]
    assert [e.key for e in again.events] == [e.key for e in model.events]


def test_parse_maintenance_options():
    axes = machine_axes_params(ROOT / "config" / "machine_xyz.yaml")
    events = parse_maintenance(["regrind:x@10h=8um", "replace_carriage:y.front@90min", "measure:z@600s=7e-6m",
                                "relubricate:x@0.5"], axes)
    assert [(e.kind, e.axis, e.guide, (e.t_ns - START_TIME_NS) / 1e9) for e in events] == [
        ("measure", "z", "", 600.0), ("relubricate", "x", "", 1800.0), ("replace_carriage", "y", "front", 5400.0),
        ("regrind", "x", "", 36000.0)]
    assert events[-1].straightness_m == pytest.approx(8e-6) and events[0].straightness_m == pytest.approx(7e-6)
    for bad, needle in [("regrind:q@1h", "no axis 'q'"), ("grind:x@1h", "KIND:AXIS"), ("regrind:x@soon", "time"),
                        ("regrind:x@1h=8", "unit"), ("regrind:x.middle@1h", "no guide 'middle'")]:
        with pytest.raises(InputError, match=needle):
            parse_maintenance([bad], axes)


# --- simulate + replay -----------------------------------------------------------------------------------
def cli(*args):
    return subprocess.run([sys.executable, "-m", "guide_health.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=600)


def test_simulated_regrind_is_replayed_and_listed(tmp_path):
    with_event, without = tmp_path / "with", tmp_path / "without"
    for bag, extra in ((with_event, ["--maintenance", "regrind:x@1h=10um"]), (without, [])):
        proc = cli("simulate", "--params", BENCH, "--hours", 2, "--rate", 10, "--seed", 4, "--out", bag, *extra)
        assert proc.returncode == 0, proc.stderr
    rep = {b.name: json.loads(cli("replay", b, "--params", BENCH, "--json", "--no-plot").stdout)
           for b in (with_event, without)}
    events = rep["with"]["maintenance_events"]
    assert events == [{"t_ns": START_TIME_NS + H, "kind": "regrind", "axis": "x", "guide": "", "source": "simulate",
                       "straightness_um": 10.0, "applied": True}]
    assert "maintenance_events" not in rep["without"]
    # the truth after the regrind grew from 10 um: without it the guide is ~5 um more worn
    from guide_health.io.bag.metadata import read_run_metadata

    truth = read_run_metadata(with_event)["truth"]["straightness_m"][-1] * 1e6
    assert rep["with"]["straightness_um"] == pytest.approx(truth, abs=0.5)
    assert rep["without"]["straightness_um"] - rep["with"]["straightness_um"] > 3.0
    # K is kept: the same motion and measurements up to 1 h, the same true K after it (measured: 3 % apart)
    assert rep["with"]["wear_coefficient"] == pytest.approx(rep["without"]["wear_coefficient"], rel=0.05)


# --- live ----------------------------------------------------------------------------------------------------
@pytest.mark.ros
def test_regrind_mid_bag_live_equals_offline(tmp_path, live_wear_node):
    from guide_health.analysis.replay import analyse_bag
    from guide_health.cli.simulate import event_series
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.nodes.session import bag_counts

    event = regrind(0.25)               # 0.5 h: the regrind between samples, live == offline on each of them
    params, run = bench_run(hours=0.5, events=[event])
    bag = tmp_path / "bag"
    write_machine_bag(run, bag, extra=event_series([event], params["machine_id"]))
    offline = analyse_bag(bag, params)[1]
    assert offline["maintenance_events"][0]["applied"] is True
    status = "bench_000/wear_monitor: x precision"
    live_wear_node.start(BENCH, {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25}, status)
    live_wear_node.play(bag)            # uncapped: reliable KEEP_ALL, the event ordered by the player's barrier
    live = live_wear_node.wait_counts(status, bag_counts(offline))     # every message taken
    live_wear_node.close()              # clean shutdown: the state database read below is complete
    values = live["values"]
    assert int(values["samples"]) == offline["samples"] and int(values["maintenance_event_count"]) == 1
    assert int(values["measurements"]) == offline["measurements"]
    for key in ("straightness_um", "remaining_life_h", "wear_coefficient", "wear_volume_mm3", "sliding_distance_m"):
        assert float(values[key]) == pytest.approx(offline[key], rel=1e-3), key
    # the regrind is in the state database with its time and value
    row = sqlite3.connect(tmp_path / "state.db").execute(
        "SELECT state_json FROM monitor_state WHERE key = 'bench_000/x/maintenance'").fetchone()
    logged = json.loads(row[0])["events"]
    assert [(e["kind"], e["t_ns"], e["straightness_um"]) for e in logged] == [("regrind", event.t_ns, 10.0)]


def test_services_apply_publish_and_log_the_event(ros_context, tmp_path):
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger
    from test_wear_monitor_node import T0, feed_cycle, make_node, snapshot

    node = make_node(ros_context, tmp_path / "a")
    other = make_node(ros_context, tmp_path / "b")
    published = []
    node.event_pub.publish = published.append
    try:
        for n in (node, other):
            feed_cycle(n, T0 + 1.0, strokes=(0.1, 0.25, 0.18, 0.3))
        worn = node.monitor.report()["straightness_um"]
        assert worn > 15.0
        node.set_parameters([Parameter("maintenance_straightness_m", value=12.0e-6)])
        response = node.channels[0].on_maintenance_call("regrind", Trigger.Response())
        assert response.success, response.message
        assert node.monitor.report()["straightness_um"] == pytest.approx(12.0, abs=1e-9)
        assert node.get_parameter("maintenance_straightness_m").value == 0.0     # cleared after the call
        # the event on the topic: DiagnosticArray stamped with the axis's latest joint stamp
        (msg,) = published
        values = {kv.key: kv.value for kv in msg.status[0].values}
        assert (msg.status[0].message, values["axis"], float(values["straightness_m"])) == ("regrind", "x", 12e-6)
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == node.monitor.integrator.last_t_ns
        # logged in the state database at once
        row = sqlite3.connect(tmp_path / "a" / "state.db").execute(
            "SELECT state_json FROM monitor_state WHERE key = 'm1/x/maintenance'").fetchone()
        assert json.loads(row[0])["events"][0]["kind"] == "regrind"
        # another node given the event from the topic ends in the same state; its own event back: once
        other._on_events(msg)
        node._on_events(msg)
        assert snapshot(other) == snapshot(node) and len(node.channels[0].model.events) == 1
        # no value: a measure call is refused with the reason, nothing changes
        response = node.channels[0].on_maintenance_call("measure", Trigger.Response())
        assert not response.success and "needs its value" in response.message
    finally:
        for n in (node, other):
            n.close()
            n.destroy_node()


def test_regrind_service_called_through_ros(ros_context, tmp_path):
    """The Trigger service over DDS (an rclpy client in another node of the same domain), with the value set
    through the parameter service as `ros2 param set` does."""
    import threading
    import time

    import rclpy
    from rcl_interfaces.srv import SetParameters
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger
    from test_wear_monitor_node import T0, feed_cycle, make_node

    node = make_node(ros_context, tmp_path)
    client_node = rclpy.create_node("maintenance_client", context=ros_context)
    executor = MultiThreadedExecutor(context=ros_context)
    executor.add_node(node)
    executor.add_node(client_node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    try:
        feed_cycle(node, T0 + 1.0, strokes=(0.1, 0.25, 0.18, 0.3))     # before spinning: no concurrent timer
        assert node.monitor.report()["straightness_um"] > 15.0
        thread.start()

        def call(srv_type, name, request):
            client = client_node.create_client(srv_type, name)
            assert client.wait_for_service(timeout_sec=10.0), name
            future = client.call_async(request)
            end = time.monotonic() + 10.0
            while not future.done() and time.monotonic() < end:
                time.sleep(0.01)
            return future.result()

        result = call(SetParameters, "/wear_monitor/set_parameters", SetParameters.Request(
            parameters=[Parameter("maintenance_straightness_m", value=11.0e-6).to_parameter_msg()]))
        assert result.results[0].successful, result.results[0].reason
        response = call(Trigger, "/maintenance/x/regrind", Trigger.Request())
        assert response.success, response.message
        assert "straightness entered 11.00 um, model 11.00 um" in response.message
        assert node.monitor.report()["straightness_um"] == pytest.approx(11.0, abs=1e-9)
    finally:
        executor.shutdown()
        if thread.is_alive():
            thread.join(timeout=5)
        node.close()
        node.destroy_node()
        client_node.destroy_node()
