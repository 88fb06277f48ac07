"""Maintenance from the package's own CLI and what a call answers (issues 26, 27): `guide-health maintenance`
on a live 3-axis node under a namespace (real DDS), the entered straightness as the measured one, the reply
with the entered and the model's values, repeats refused within maintenance_repeat_window_s, events
rejected on the topic counted under their input_rules reason; WARN/ERROR messages naming the rule and its
threshold; keys a guide type does not have are absent."""
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import pytest

from guide_health.errors import InputError
from guide_health.models.levels import Level
from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.input_rules import (
    MAINTENANCE_REASONS,
    MAINTENANCE_REPEATED,
    MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE,
    MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER,
    MAINTENANCE_UNKNOWN_GUIDE,
    MAINTENANCE_UNKNOWN_KIND,
    rejected_key,
)
from guide_health.models.wear.life import PrecisionNow, RecentInputs, Thresholds, judge, judge_precision
from guide_health.models.wear.maintenance import MaintenanceEvent, straightness_from_text
from guide_health.params import wear_monitor_params
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
XYZ = ROOT / "config" / "machine_xyz.yaml"
S = 1_000_000_000


# --- the value parser (one for the CLI and simulate --maintenance) -------------------------------------------
@pytest.mark.parametrize("text", ["4um", "4 um", "4e-6m", "0.004mm", " 4.0 um ", "4\u00b5m"])
def test_every_spelling_of_4_um_is_4e_6_m(text):
    assert straightness_from_text(text) == pytest.approx(4e-6, rel=1e-12)


@pytest.mark.parametrize("text,needle", [("4", "unit"), ("4xx", "unit"), ("abcum", "unit"), ("4 km", "unit"),
                                         ("nanum", "finite"), ("-1um", ">= 0"), ("infm", "finite"), ("", "unit")])
def test_a_bad_value_is_one_line(text, needle):
    with pytest.raises(InputError, match=needle) as err:
        straightness_from_text(text)
    assert "\n" not in str(err.value)


# --- the model: the entered value, repeats, counted rejections ------------------------------------------------
def worn_axis():
    from guide_health.params import simulation_params
    from guide_health.sim.machine import simulate_machine

    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=1.0, joint_state_rate_hz=10.0, load_rate_hz=1.0)
    model = AxisMonitor(wear_axis_params(params))
    model.process_run(simulate_machine(params, sim, seed=5))
    return params, model


def test_a_regrind_at_4_um_is_the_measured_straightness_and_keeps_k():
    import json as _json

    params, model = worn_axis()
    before = model.report()
    assert before["straightness_um"] > 12.0 and before["measurements"] > 0
    assert model.schedule(MaintenanceEvent(model.last_t_ns, "regrind", "x", "", 4e-6, "test")) is None
    after = model.report()
    assert after["straightness_measured_um"] == pytest.approx(4.0, rel=1e-12)     # was nan
    assert after["straightness_um"] == pytest.approx(4.0, rel=1e-12)
    assert after["wear_coefficient"] == pytest.approx(before["wear_coefficient"], rel=1e-12)
    # kept over a restart (the axis's maintenance state), and a regrind without a value measures nothing
    again = AxisMonitor(wear_axis_params(params))
    again.primary.restore(model.primary.state())
    again.restore_maintenance(_json.loads(_json.dumps(model.maintenance_state())))
    assert again.report()["straightness_measured_um"] == pytest.approx(4.0, rel=1e-12)
    model.schedule(MaintenanceEvent(model.last_t_ns + 120 * S, "regrind", "x", "", math.nan, "test"))
    model.apply_due()
    assert math.isnan(model.report()["straightness_measured_um"])


def test_the_same_maintenance_within_the_window_is_refused_and_counted():
    params, model = worn_axis()
    t = model.last_t_ns
    window_s = params["maintenance_repeat_window_s"]
    assert window_s == 60.0
    assert model.schedule(MaintenanceEvent(t, "regrind", "x", "", 4e-6, "service")) is None
    assert model.schedule(MaintenanceEvent(t, "regrind", "x", "", 4e-6, "topic")) is None   # itself: echo
    # same action, stamped 60 s later (the edge of the window): a repeat, nothing applied
    reason = model.schedule(MaintenanceEvent(t + 60 * S, "regrind", "x", "", 4e-6, "topic"))
    assert reason.startswith(MAINTENANCE_REPEATED) and "already applied at" in reason
    assert len(model.events) == 1 and model.pending == []
    assert model.report()[rejected_key(MAINTENANCE_REPEATED)] == 1
    # another value, another kind, or beyond the window: a new event
    assert model.schedule(MaintenanceEvent(t + 60 * S, "regrind", "x", "", 5e-6, "topic")) is None
    assert model.schedule(MaintenanceEvent(t + 60 * S, "relubricate", "x", "", math.nan, "topic")) is None
    assert model.schedule(MaintenanceEvent(t + 121 * S, "regrind", "x", "", 5e-6, "topic")) is None
    assert len(model.events) + len(model.pending) == 4


@pytest.mark.parametrize("event,reason", [
    (MaintenanceEvent(0, "polish", "x"), MAINTENANCE_UNKNOWN_KIND),
    (MaintenanceEvent(0, "regrind", "x", "left", 1e-6), MAINTENANCE_UNKNOWN_GUIDE),
    (MaintenanceEvent(0, "measure", "x", "", 1e308), MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE),
])
def test_a_rejected_event_counts_under_one_fixed_reason(event, reason):
    model = AxisMonitor(wear_axis_params(wear_monitor_params(BENCH)))
    assert model.schedule(event).startswith(reason + ": ")
    report = model.report()
    assert report[rejected_key(reason)] == 1 and report["rejected_samples"] == 1
    assert model.events == [] and model.pending == []


# --- the node in-process: topic rejections in the status, the service's reply and repeats -----------------------
def event_array(t_s: float, **values):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    msg = DiagnosticArray()
    msg.header.stamp.sec = int(t_s)
    msg.status = [DiagnosticStatus(name="maintenance: x", message=values.get("kind", ""),
                                   values=[KeyValue(key=k, value=v) for k, v in values.items()])]
    return msg


def status_values(node) -> dict:
    node.publish_diagnostics()
    (status,) = [s for s in node.published[-1].status if s.name.endswith("x precision")]
    return {kv.key: kv.value for kv in status.values}


def test_topic_events_rejected_count_in_the_status(ros_context, tmp_path):
    from test_wear_monitor_node import T0, feed_cycle, make_node

    node = make_node(ros_context, tmp_path)
    try:
        t = feed_cycle(node, T0 + 1.0)
        bad = [dict(kind="polish", axis="x"), dict(kind="measure", axis="x", straightness_m="abc"),
               dict(kind="measure", axis="x", straightness_m="1e308"), dict(kind="regrind", axis="x", guide="left"),
               dict(kind="regrind", axis="y")]                  # another node's axis: not ours, not counted
        for values in bad:
            node._on_events(event_array(t, **values))
        values = status_values(node)
        for reason in (MAINTENANCE_UNKNOWN_KIND, MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER,
                       MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE, MAINTENANCE_UNKNOWN_GUIDE):
            assert values[rejected_key(reason)] == "1", reason
        assert sum(int(values.get(rejected_key(r), 0)) for r in MAINTENANCE_REASONS) == 4
        assert values["maintenance_event_count"] == "0"
        # a sliding guide has no lubrication regime: absent, not nan
        assert "lubrication_regime" not in values
    finally:
        node.close()
        node.destroy_node()


def test_the_reply_states_the_entered_and_model_values_and_a_repeat_is_refused(ros_context, tmp_path):
    from rclpy.parameter import Parameter
    from std_srvs.srv import Trigger
    from test_wear_monitor_node import T0, feed_cycle, make_node

    node = make_node(ros_context, tmp_path)
    node.event_pub.publish = lambda msg: None
    channel = node.channels[0]
    try:
        feed_cycle(node, T0 + 1.0, strokes=(0.1, 0.25, 0.18, 0.3))
        k_before = node.monitor.report()["wear_coefficient"]

        def call(kind, value_m=0.0, note=""):
            node.set_parameters([Parameter("maintenance_straightness_m", value=value_m),
                                 Parameter("maintenance_note", value=note)])
            return channel.on_maintenance_call(kind, Trigger.Response())

        first = call("regrind", 4e-6, note="ground by J. Doe")
        assert first.success, first.message
        assert "straightness entered 4.00 um, model 4.00 um, measured 4.00 um" in first.message
        assert f"K {k_before:.4g}" in first.message
        values = status_values(node)
        assert float(values["straightness_measured_um"]) == pytest.approx(4.0, rel=1e-12)
        assert channel.model.events[0].note == "ground by J. Doe"
        second = call("regrind", 4e-6)                         # the axis stood still: the same stamp
        assert not second.success and second.message.startswith("already applied at ")
        assert "regrind of x, straightness entered 4.00 um; nothing applied (maintenance_repeat_window_s 60 s)" \
            in second.message
        assert len(channel.model.events) == 1
        other = call("regrind", 5e-6)                           # another value: applied
        assert other.success and "straightness entered 5.00 um" in other.message
    finally:
        node.close()
        node.destroy_node()


# --- levels that say why ------------------------------------------------------------------------------------
TH = Thresholds(straightness_warn_fraction=0.8, life_warn_h=500.0, life_error_h=50.0, rejected_share_warn=0.5)


@pytest.mark.parametrize("straightness_um,life_h,level,needles", [
    (40.0, 23.0, Level.ERROR, ["remaining precision life 23 h < life_error_h 50 h"]),
    (40.0, 300.0, Level.WARN, ["remaining precision life 300 h < life_warn_h 500 h"]),
    (130.0, 900.0, Level.WARN, ["straightness 130.0 um > straightness_warn_fraction 0.8 x limit 150 um = 120.0 um",
                                "remaining precision life 900 h"]),
    (130.0, 30.0, Level.ERROR, ["< life_error_h 50 h", "> straightness_warn_fraction 0.8"]),
    (151.0, 30.0, Level.ERROR, ["exceeds the limit (>= straightness_limit_m 150.0 um)"]),
    (40.0, 900.0, Level.OK, ["remaining precision life 900 h at current duty"]),
])
def test_every_warn_and_error_names_its_rule_and_threshold(straightness_um, life_h, level, needles):
    got, text = judge_precision(PrecisionNow(straightness_um, 150.0, life_h, 100, "x"), TH)
    assert got == level
    for needle in needles:
        assert needle in text, text
    if level == Level.OK:
        assert "<" not in text and ">" not in text


def test_a_rejected_share_warning_names_rejected_share_warn():
    level, text, _ = judge(PrecisionNow(40.0, 150.0, 900.0, 100, "x"),
                           RecentInputs(0.75, "joint_states", "non-finite joint position/velocity", 200), TH)
    assert level == Level.WARN and "75% of the last 200 joint_states samples rejected" in text
    assert "> rejected_share_warn 50%" in text


def test_rolling_and_slewing_levels_name_their_thresholds():
    from guide_health.models.levels import ERROR, WARN
    from guide_health.models.slewing.monitor import _level_message

    assert "> warn_fraction 0.8 x allowable_contact_stress_pa = 3200 MPa" in _level_message(
        WARN, 3500.0, 0.0, 4000.0, 0.8)
    assert "> allowable_contact_stress_pa 4000 MPa" in _level_message(ERROR, 4100.0, 0.0, 4000.0, 0.8)


def test_rolling_guide_levels_name_their_thresholds():
    from test_rolling_guide import duty_run, params

    from guide_health.models.wear.precision import PrecisionMonitor

    slow = PrecisionMonitor(wear_axis_params(params(boundary_share_warn=0.5)))
    slow.process_run(duty_run([(600.0, 0.0003, 3000.0)], rate_hz=10.0))
    assert "100% of the recent travel in boundary lubrication > boundary_share_warn 50%" in slow.report()["message"]
    heavy = PrecisionMonitor(wear_axis_params(params(dynamic_load_rating_n=1500.0, life_used_warn=0.8,
                                                     life_used_error=1.0, load_max_rating_multiple=0.0)))
    heavy.process_run(duty_run([(600.0, 0.3, 12000.0)]))
    assert heavy.fatigue_report()["message"].endswith(">= life_used_error 100%")
    mid = PrecisionMonitor(wear_axis_params(params(life_used_warn=1e-9)))
    mid.process_run(duty_run([(60.0, 0.3, 6000.0)]))
    assert mid.fatigue_report()["message"].endswith("of the rating life used >= life_used_warn 0%")


def test_vibration_levels_name_their_rules():
    from guide_health.models.rolling.life_signs import LifeTestSigns
    from guide_health.models.rolling.vibration import GuideKinematics

    signs = LifeTestSigns(20000.0, GuideKinematics(6.35e-3, 6.6e-3, 0.25), 1.0)
    assert signs.level() == (Level.OK, "no failure sign")
    signs.noise.rise_travel_m = 300e3
    assert signs.level()[0] == Level.WARN and "> rise_cusum_db 8 dB" in signs.level()[1]
    signs.failure_travel_m = 400e3
    text = f"band z > z_threshold {signs.bands.threshold:.2f} in 3 of 5 blocks from 400.0 km"
    assert signs.level() == (Level.WARN, f"sustained abnormal vibration band: {text}")
    signs.failure_lower_m = 395e3
    signs.noise.shift.sd_db = 0.3
    signs.noise.shift.drops.append((380e3, 5.0))            # before the spall signature: no loosening
    assert signs.level()[0] == Level.WARN
    signs.noise.shift.drops.append((450e3, 5.0))
    level, message = signs.level()
    assert level == Level.ERROR and text in message
    assert "noise drop of 5.0 dB at 450.0 km >= noise_drop_db 3 dB (two-sided CUSUM > 10 noise sd 0.3 dB)" in message


def test_machine_replay_json_has_no_lubrication_regime_for_sliding_guides(tmp_path):
    from test_machine import make_machine_bag

    from guide_health.analysis.machine_replay import analyse_machine_bag

    bag = tmp_path / "xyz"
    axes, _ = make_machine_bag(bag, hours=0.05)
    report = analyse_machine_bag(bag, axes)[1]["axes"]
    assert set(report) == {"x", "y", "z"}
    for axis, values in report.items():
        assert "lubrication_regime" not in values, axis
        assert math.isfinite(values["straightness_um"])


# --- the command on a live node (real DDS, the test's own domain) --------------------------------------------
@pytest.fixture
def ros_env(ros_test_env):
    from guide_health.nodes.session import clean_fastdds_shm

    env = ros_test_env()
    yield env
    clean_fastdds_shm()


def maintenance_cli(env, *args, timeout=120):
    return subprocess.run([sys.executable, "-m", "guide_health.cli", "maintenance", *map(str, args)], env=env,
                          capture_output=True, text=True, timeout=timeout)


def received_events(topic: str, timeout_s: float = 30.0) -> list:
    """The events a late subscriber gets from the node's transient-local maintenance/events publisher."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor

    from guide_health.nodes.wear_monitor import EVENT_QOS

    context = rclpy.context.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("maintenance_events_probe", context=context)
    got = []
    node.create_subscription(DiagnosticArray, topic, got.append, EVENT_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    end = time.monotonic() + timeout_s
    try:
        while not got and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
    return got


@pytest.mark.ros
def test_maintenance_command_regrinds_an_axis_of_a_live_three_axis_node(tmp_path, ros_env):
    from test_machine import make_machine_bag

    from guide_health.analysis.machine_replay import analyse_machine_bag
    from guide_health.nodes.session import DiagnosticsCollector, bag_counts, play_bag, stop_node

    bag = tmp_path / "xyz"
    axes, _ = make_machine_bag(bag, hours=0.1)
    offline = analyse_machine_bag(bag, axes)[1]["axes"]
    log = tmp_path / "node.log"
    node = subprocess.Popen([sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "-r",
                             "__ns:=/m1", "--params-file", str(XYZ), "-p", f"state_file:={tmp_path / 'state.db'}",
                             "-p", "diagnostics_period_s:=0.25"], env=ros_env, stdout=open(log, "w"),
                            stderr=subprocess.STDOUT)
    collector = DiagnosticsCollector("maintenance_cli_collector")
    status = "vmc_xyz_01/wear_monitor: y precision"
    try:
        assert collector.wait_for(status, timeout=120.0) is not None, log.read_text()
        played = play_bag(bag, ros_env, ["--remap-ns", "/m1", "--wait-subscribers", "1"])
        assert played.returncode == 0, played.stderr
        before = collector.wait_counts(status, bag_counts(offline["y"]))
        assert int(before["values"]["samples"]) == offline["y"]["samples"]
        assert float(before["values"]["straightness_um"]) > 4.5
        first = maintenance_cli(ros_env, "/m1", "y", "regrind", "--value", "4um", "--json")
        assert first.returncode == 0, first.stdout + first.stderr
        reply = json.loads(first.stdout)
        assert reply["success"] and reply["straightness_entered_um"] == pytest.approx(4.0)
        assert "regrind of y" in reply["message"] and "straightness entered 4.00 um, model 4.00 um" in reply["message"]
        after = collector.wait_for(status, lambda s: s["values"]["maintenance_event_count"] == "1", timeout=60.0)
        assert after is not None, collector.get(status)
        assert float(after["values"]["straightness_um"]) == pytest.approx(4.0, abs=1e-9)
        assert float(after["values"]["straightness_measured_um"]) == pytest.approx(4.0, abs=1e-9)
        assert after["values"]["wear_coefficient"] == before["values"]["wear_coefficient"]     # K kept
        x_after = collector.get("vmc_xyz_01/wear_monitor: x precision")
        assert x_after["values"]["maintenance_event_count"] == "0"
        # the event reached maintenance/events in the namespace
        (event,) = received_events("/m1/maintenance/events")
        values = {kv.key: kv.value for kv in event.status[0].values}
        assert (values["kind"], values["axis"], float(values["straightness_m"])) == ("regrind", "y", 4e-6)
        # the same call again: refused, exit 1, nothing applied
        second = maintenance_cli(ros_env, "/m1", "y", "regrind", "--value", "4 um")
        refused_at = time.monotonic()
        assert second.returncode == 1, second.stdout + second.stderr
        assert second.stdout.startswith("refused: already applied at ")
        # no such node: exit 2, one line
        missing = maintenance_cli(ros_env, "/m2", "y", "regrind", "--timeout", "1")
        assert missing.returncode == 2 and missing.stdout == ""
        assert missing.stderr.count("\n") == 1 and "no node /m2/wear_monitor found" in missing.stderr
        # a status published after the refused call (not a quiet time): still one event
        later = collector.wait_for(status, lambda s: s["received"] > refused_at + 0.5, timeout=60.0)
        assert later is not None and later["values"]["maintenance_event_count"] == "1"
    finally:
        stop_node(node)
        collector.close()
