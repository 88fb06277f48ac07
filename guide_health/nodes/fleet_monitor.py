"""`fleet_monitor`: one status for a fleet of machines, and a SQLite history of every machine's health.

Subscribes `/diagnostics` (every machine's wear_monitor / slewing_monitor statuses, told apart by
`hardware_id` = machine_id) and publishes, at `diagnostics_period_s`, a status
`<machine_id>/fleet_monitor: fleet` (`fleet/fleet_monitor: fleet`)
(keys: guide_health.models.fleet.SUMMARY_KEYS): counts per level, the worst machine, the least remaining
precision life, the highest fatigue life used and end-stress ratio. Statuses silent for `stale_after_s`
count as STALE; silent for `forget_after_s` they leave the board (at most `max_statuses`). Statuses of an
unknown level, messages that are no DiagnosticArray in CDR (the statuses are read from the raw bytes,
io/diagnostics_cdr.py; such a message counts as one ignored status) and invalid values (a negative
remaining life, 'banana') are ignored, counted in the fleet
status (`ignored_statuses`, `invalid_values`, `forgotten_statuses`) and logged (throttled). With
`history_file`, each status is recorded at most every `history_period_s`, and at every level change
whenever it comes, into the table
`fleet_history(t_unix_s, hardware_id, name, level, message, values_json)` for trend reports; rows older
than `history_retention_days` are deleted hourly.
"""
from __future__ import annotations

import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node

from guide_health.io.diagnostics_cdr import MalformedMessage, decode_diagnostic_array
from guide_health.io.outputs.fleet_history import FleetHistory
from guide_health.models.fleet import FLEET_DATE_KEYS, FLEET_VALUE_KEYS, SUMMARY_KEYS, FleetBoard
from guide_health.nodes.common import run_node
from guide_health.nodes.live_params import PeriodicTimers, apply_fleet_changes
from guide_health.nodes.status import StatusTask, StatusUpdater, status_name
from guide_health.params import FLEET_MONITOR_SCHEMA, declare_parameters
from guide_health.params.typed import fleet_monitor_params

#: the only status values the board and the history read; the others are skipped without being decoded
_KEPT_KEYS = frozenset(FLEET_VALUE_KEYS + FLEET_DATE_KEYS)


class FleetMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("fleet_monitor", **kwargs)
        self.params = declare_parameters(self, FLEET_MONITOR_SCHEMA,   # validated: periods > 0
                                         on_applied=self._apply_params)
        p = fleet_monitor_params(self.params)
        self.periodic = PeriodicTimers(self)
        own = status_name(p.machine_id, self.get_name(), "")     # its own statuses
        self.board = FleetBoard(p.stale_after_s, ignore_prefix=own, forget_after_s=p.forget_after_s,
                                max_statuses=p.max_statuses)
        self.history = (FleetHistory(p.history_file, p.history_period_s, p.history_retention_days)
                        if p.history_file else None)
        # raw CDR: the statuses are read from the bytes (io/diagnostics_cdr.py); building rclpy message
        # objects for every KeyValue was most of the node's CPU at hundreds of machines
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics_raw, 100, raw=True)
        # the board ages silent machines to STALE itself: the task has no stale inputs
        self.updater = StatusUpdater(self, p.machine_id)
        self.updater.add(StatusTask("fleet", self._fleet_report, SUMMARY_KEYS))
        self.periodic.create("diagnostics_period_s", p.diagnostics_period_s, self.publish_diagnostics)

    def _apply_params(self, changed: dict) -> None:
        """An accepted ``ros2 param set`` (guide_health.nodes.live_params)."""
        apply_fleet_changes(changed, self.board, self.history, self.periodic)

    def _on_diagnostics_raw(self, raw: bytes) -> None:
        try:
            statuses = decode_diagnostic_array(raw, _KEPT_KEYS)
        except MalformedMessage as exc:      # counted among the ignored statuses, logged (throttled)
            self.board.reject_message(str(exc))
            self._log_problem()
            return
        now = time.monotonic()
        wall = time.time()
        for status in statuses:
            kept = self.board.update(status.name, status.hardware_id, status.level, status.message,
                                     status.values, now)
            self._log_problem()
            if kept and self.history is not None:
                self.history.record(wall, status.hardware_id, status.name, status.level, status.message,
                                    status.values)

    def _log_problem(self) -> None:
        if self.board.last_problem:     # unknown level, full board, invalid value: counted in the status
            self.get_logger().warning(f"{self.board.last_problem} (counted in the fleet status)",
                                      throttle_duration_sec=10.0)

    def _fleet_report(self) -> tuple[int, str, dict]:
        summary = self.board.summary(time.monotonic())
        return summary["level"], summary["message"], summary

    def publish_diagnostics(self) -> None:
        self.updater.update()
        if self.history is not None:
            self.history.commit(time.time())

    def close(self) -> None:
        if self.history is not None:
            self.history.close()
            self.history = None


def main(argv: list[str] | None = None) -> int:
    # the events executor: rclpy's SingleThreadedExecutor rebuilds its wait set for every message, which
    # at hundreds of machines cost more than reading the statuses; on /clock it stays single-threaded
    # (rclpy 7.1.6's EventsExecutor stopped taking messages there, nodes/qos.resolve_executor)
    return run_node("fleet_monitor", FleetMonitorNode, argv,
                    events_executor=lambda node: not node.get_parameter("use_sim_time").value)


if __name__ == "__main__":
    sys.exit(main())
