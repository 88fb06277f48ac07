"""Fleet board (pure) and the fleet_monitor node: per-machine statuses in, one fleet status out, history
in SQLite."""
import math
import sqlite3
import time

import pytest

from guide_health.models.fleet import FleetBoard
from guide_health.models.levels import ERROR, OK, STALE, WARN


def test_board_counts_levels_and_finds_the_weakest_machine():
    board = FleetBoard(stale_after_s=10.0, ignore_prefix="fleet/fleet_monitor: ")
    board.update("m1/wear_monitor: x precision", "m1", OK, "fine", {"remaining_life_h": "412.5"}, 100.0)
    board.update("m2/wear_monitor: x precision", "m2", WARN, "low life", {"remaining_life_h": "12.0"}, 100.0)
    board.update("m2/wear_monitor: x fatigue", "m2", OK, "", {"life_used_fraction": "0.31"}, 100.0)
    board.update("c1/slewing_monitor: b1 roller contact", "c1", OK, "", {"end_stress_ratio": "1.21"}, 100.0)
    board.update("m3/wear_monitor: x precision", "m3", OK, "", {"remaining_life_h": "nan"}, 100.0)
    assert not board.update("fleet/fleet_monitor: fleet", "fleet", OK, "", {}, 100.0)   # own status ignored
    s = board.summary(now_s=105.0)
    assert (s["machines"], s["statuses"]) == (4, 5)
    assert (s["ok"], s["warn"], s["error"], s["stale"]) == (4, 1, 0, 0)
    assert s["level"] == WARN and s["worst_machine"] == "m2"
    assert s["min_remaining_life_h"] == 12.0 and s["min_remaining_life_machine"] == "m2"
    assert s["max_life_used_fraction"] == 0.31 and s["max_end_stress_machine"] == "c1"
    # an ERROR anywhere makes the fleet ERROR
    board.update("m1/wear_monitor: x precision", "m1", ERROR, "limit", {"remaining_life_h": "0"}, 106.0)
    s = board.summary(now_s=107.0)
    assert s["level"] == ERROR and s["worst_machine"] == "m1" and s["min_remaining_life_h"] == 0.0


def test_silent_machines_turn_stale_and_the_fleet_warns():
    board = FleetBoard(stale_after_s=5.0)
    board.update("a: t", "m1", OK, "", {}, 0.0)
    board.update("a: t", "m2", OK, "", {}, 4.0)
    s = board.summary(now_s=6.0)                       # m1 silent 6 s > 5 s
    assert (s["ok"], s["stale"]) == (1, 1) and s["level"] == WARN and s["worst_machine"] == "m1"
    empty = FleetBoard().summary(0.0)
    assert empty["level"] == STALE and empty["machines"] == 0 and math.isnan(empty["min_remaining_life_h"])


def test_silent_statuses_are_forgotten_and_the_board_stays_bounded():
    """Issue 10 item 7: 50,000 ids used to stay on the board forever (fleet WARN forever)."""
    board = FleetBoard(stale_after_s=5.0, forget_after_s=60.0, max_statuses=1000)
    for i in range(1000):
        assert board.update("a: t", f"old{i}", OK, "", {}, 0.0)
    assert not board.update("a: t", "new", OK, "", {}, 1.0)          # full: ignored, counted
    assert board.ignored == {"board full": 1} and "board full" in board.last_problem
    board.update("a: t", "live", OK, "", {}, 59.0) or None           # still full at 59 s
    s = board.summary(now_s=60.5)                                     # 60.5 s > 60 s: the 1000 are gone
    assert (s["machines"], s["statuses"], s["forgotten_statuses"]) == (0, 0, 1000)
    assert s["level"] == STALE and s["ignored_statuses"] == 2
    assert board.update("a: t", "live", OK, "", {}, 61.0)
    s = board.summary(now_s=62.0)
    assert (s["machines"], s["ok"], s["level"]) == (1, 1, OK)          # no WARN left from the retired ones
    with pytest.raises(ValueError):
        FleetBoard(stale_after_s=10.0, forget_after_s=5.0)


def test_invalid_values_and_unknown_levels_are_ignored_and_counted():
    board = FleetBoard()
    board.update("w: x precision", "m1", OK, "", {"remaining_life_h": "40.0"}, 0.0)
    assert board.update("w: x precision", "m2", OK, "", {"remaining_life_h": "-5"}, 0.0)   # main: fleet min
    assert "remaining_life_h = '-5' (invalid)" in board.last_problem
    board.update("w: x precision", "m3", OK, "", {"remaining_life_h": "banana", "life_used_fraction": "-0.1"}, 0.0)
    board.update("w: x precision", "m4", OK, "", {"remaining_life_h": "nan"}, 0.0)          # not known yet: fine
    board.update("w: x precision", "m5", OK, "", {"remaining_life_h": "inf"}, 0.0)          # no wear: fine
    assert not board.update("w: x precision", "m6", 7, "", {}, 0.0)                        # main: dropped silently
    assert "unknown level (7)" in board.last_problem
    s = board.summary(1.0)
    assert s["min_remaining_life_h"] == 40.0 and s["min_remaining_life_machine"] == "m1"
    assert math.isnan(s["max_life_used_fraction"])
    assert (s["invalid_values"], s["ignored_statuses"], s["statuses"]) == (3, 1, 5)


def test_history_retention_deletes_old_rows_and_forgets_old_periods(tmp_path):
    from guide_health.io.outputs.fleet_history import FleetHistory

    history = FleetHistory(str(tmp_path / "h.db"), period_s=60.0, retention_days=1.0)
    day = 86400.0
    for k in range(5):                                  # one row a day for 5 days
        history.record(k * day, "m1", "w: t", OK, "", {})
    history.commit()
    assert history.prune(4 * day - 1.0) == 3             # rows of day 0, 1, 2 are older than one day
    rows = [r[0] for r in history.db.execute("SELECT t_unix_s FROM fleet_history ORDER BY t_unix_s")]
    assert rows == [3 * day, 4 * day] and list(history._last) == [("m1", "w: t")]
    assert history.prune(4 * day + 60.0) == 1 and history._last == {}     # day 3 goes; the last period is over
    assert history._last_level == {}                    # memory bounded by the statuses of one period
    history.close()
    assert (tmp_path / "h.db").stat().st_mode & 0o777 == 0o600
    (tmp_path / "link.db").symlink_to(tmp_path / "h.db")
    from guide_health.errors import InputError
    with pytest.raises(InputError, match="history file .*link.db: cannot be used"):
        FleetHistory(str(tmp_path / "link.db"), period_s=1.0)


rclpy = pytest.importorskip("rclpy")


def test_fleet_node_aggregates_statuses_from_the_topic_and_records_history(ros_context, tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from guide_health.nodes.fleet_monitor import FleetMonitorNode

    db = tmp_path / "fleet.db"
    fleet = FleetMonitorNode(context=ros_context, parameter_overrides=[
        Parameter("history_file", value=str(db)), Parameter("history_period_s", value=0.2),
        Parameter("diagnostics_period_s", value=0.1)])
    source = rclpy.create_node("machines", context=ros_context)
    pub = source.create_publisher(DiagnosticArray, "/diagnostics", 10)
    seen = []
    source.create_subscription(DiagnosticArray, "/diagnostics",
                               lambda m: seen.extend(s for s in m.status if s.name == "fleet/fleet_monitor: fleet"), 10)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(fleet)
    ex.add_node(source)

    def machine_status(hw, level, life_h):
        return DiagnosticStatus(level=bytes([level]), name=f"{hw}/wear_monitor: x precision", hardware_id=hw,
                                message="m", values=[KeyValue(key="remaining_life_h", value=repr(life_h))])
    def spin(seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.01)
    try:
        end = time.monotonic() + 10.0
        while time.monotonic() < end:
            pub.publish(DiagnosticArray(status=[machine_status("m1", 0, 300.0), machine_status("m2", 1, 15.5)]))
            spin(0.1)
            if seen and dict((kv.key, kv.value) for kv in seen[-1].values).get("machines") == "2":
                break
        assert seen, fleet.board.statuses
        last = {kv.key: kv.value for kv in seen[-1].values}
        assert last["machines"] == "2" and last["min_remaining_life_machine"] == "m2"
        assert float(last["min_remaining_life_h"]) == 15.5
        assert seen[-1].level == DiagnosticStatus.WARN and seen[-1].hardware_id == "fleet"
        for _ in range(10):                         # a second history row per status after 0.2 s
            pub.publish(DiagnosticArray(status=[machine_status("m1", 0, 299.0), machine_status("m2", 1, 15.0)]))
            spin(0.05)
    finally:
        fleet.close()
        ex.shutdown()
        fleet.destroy_node()
        source.destroy_node()
    with sqlite3.connect(db) as con:
        rows = con.execute("SELECT hardware_id, level, remaining_life_h FROM fleet_history "
                           "ORDER BY t_unix_s").fetchall()
    machines = {r[0] for r in rows}
    assert machines == {"m1", "m2"}                  # the fleet's own status is not recorded
    per_machine = [r for r in rows if r[0] == "m2"]
    assert 2 <= len(per_machine) <= 5                # throttled: not one row per message (~20 sent)
    assert per_machine[0][2] == 15.5
