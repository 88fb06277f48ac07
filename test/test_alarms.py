"""Issue 16, alarms: hysteresis (a value hovering at a threshold keeps its level), ERROR latched until
acknowledged with a count of events (a one-period slewing overstress stays visible), every level change in
the fleet history whatever the history period. Rules: guide_health/models/levels.py."""
import sqlite3

import pytest

from guide_health.models.levels import ERROR, OK, STALE, WARN, Alarm, falls_below, hysteresis_level

LIFE_WARN_H = 500.0
HOVERING_LIFE_H = [510.0, 499.0, 501.0, 499.5, 520.0, 524.0, 526.0, 499.0]


def life_level(life_h, margin):
    return WARN if falls_below(life_h, LIFE_WARN_H, margin) else OK


def levels_of(lives, margin):
    current, out = None, []
    for life in lives:
        current = hysteresis_level(current, life_level(life, 0.0), life_level(life, margin))
        out.append(current)
    return out


def test_a_value_hovering_at_a_threshold_does_not_toggle():
    # margin 5 %: WARN at < 500 h holds until the life is back above 525 h
    assert levels_of(HOVERING_LIFE_H, 0.05) == [OK, WARN, WARN, WARN, WARN, WARN, OK, WARN]
    # without a margin the same values toggle every period
    assert levels_of(HOVERING_LIFE_H, 0.0) == [OK, WARN, OK, WARN, OK, OK, OK, WARN]


def test_levels_rise_at_once_and_fall_only_as_far_as_the_margin_allows():
    assert hysteresis_level(OK, ERROR, ERROR) == ERROR
    assert hysteresis_level(ERROR, OK, WARN) == WARN          # within the margin of WARN only
    assert hysteresis_level(ERROR, WARN, ERROR) == ERROR
    assert hysteresis_level(WARN, OK, OK) == OK


def test_error_latched_until_acknowledged_with_a_count_of_events():
    alarm = Alarm()
    assert alarm.update(OK, OK, "fine") == (OK, "fine")
    assert alarm.update(ERROR, ERROR, "overstress 4100 MPa") == (ERROR, "overstress 4100 MPa")
    level, message = alarm.update(OK, OK, "fine")               # one period later: still visible
    assert level == ERROR and message == ("ERROR latched until acknowledged (1 events; first: overstress 4100 MPa); "
                                          "now OK: fine")
    assert alarm.update(STALE, STALE, "no data") == (STALE, "no data")   # STALE passes, the latch stays
    alarm.update(ERROR, ERROR, "again")
    alarm.update(OK, OK, "fine")
    assert alarm.values() == {"alarm_events": 2, "alarm_latched": 1}
    assert alarm.acknowledge() == 2
    assert alarm.update(OK, OK, "fine") == (OK, "fine")
    assert alarm.values() == {"alarm_events": 2, "alarm_latched": 0}
    assert alarm.acknowledge() == 0


rclpy = pytest.importorskip("rclpy")
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue  # noqa: E402
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402


def wrench(axial_n):
    msg = WrenchStamped()
    msg.wrench.force.z = float(axial_n)
    return msg


def test_a_one_period_slewing_overstress_stays_visible_until_acknowledged(ros_context):
    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    node = SlewingMonitorNode(context=ros_context, parameter_overrides=[Parameter("input_timeout_s", value=60.0)])
    published = []
    node.diag_pub.publish = published.append
    try:
        def period(axial_n):
            node._on_load(wrench(axial_n))
            node.publish_diagnostics()
            status = published[-1].status[0]
            return status.level[0], status.message, {kv.key: kv.value for kv in status.values}

        assert period(1.0e6)[0] == OK                       # 1 MN on 170 rollers: far below 4000 MPa
        level, message, values = period(2.0e8)              # one period of overstress
        assert level == ERROR and values["alarm_events"] == "1" and values["alarm_latched"] == "1"
        level, message, values = period(1.0e6)              # back to normal: the ERROR stays visible
        assert level == ERROR and message.startswith("ERROR latched until acknowledged (1 events; first: contact "
                                                     "pressure above the allowable")
        response = node.updater._acknowledge(Trigger.Request(), Trigger.Response())
        assert response.success and response.message == "acknowledged 131.32.2000.00Z roller contact (1 ERROR events)"
        level, message, values = period(1.0e6)
        assert level == OK and values["alarm_events"] == "1" and values["alarm_latched"] == "0"
    finally:
        node.destroy_node()


def test_fleet_history_records_every_level_change_whatever_the_period(ros_context, tmp_path):
    from rclpy.serialization import serialize_message

    from guide_health.nodes.fleet_monitor import FleetMonitorNode

    db = tmp_path / "fleet.db"
    fleet = FleetMonitorNode(context=ros_context, parameter_overrides=[
        Parameter("history_file", value=str(db)), Parameter("history_period_s", value=3600.0)])
    try:
        for level in (OK, OK, ERROR, OK, OK, WARN, WARN):    # within a second: one period of 3600 s
            array = DiagnosticArray(status=[DiagnosticStatus(
                level=bytes([level]), name="m1/wear_monitor: x precision", hardware_id="m1", message="m",
                values=[KeyValue(key="remaining_life_h", value="1.0")])])
            fleet._on_diagnostics_raw(serialize_message(array))     # as the raw subscription hands it
        fleet.publish_diagnostics()                           # commits
        rows = sqlite3.connect(db).execute("SELECT level FROM fleet_history ORDER BY rowid").fetchall()
        # the first, and each change: OK, ERROR, OK, WARN (the repeats inside the period are not)
        assert [r[0] for r in rows] == [OK, ERROR, OK, WARN]
    finally:
        fleet.close()
        fleet.destroy_node()
