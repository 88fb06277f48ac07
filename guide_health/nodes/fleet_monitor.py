"""`fleet_monitor`: one status for a fleet of machines, and a SQLite history of every machine's health.

Subscribes `/diagnostics` (every machine's wear_monitor / slewing_monitor statuses, told apart by
`hardware_id` = machine_id) and publishes, at `diagnostics_period_s`, a status `fleet_monitor: fleet`
(keys: guide_health.models.fleet.SUMMARY_KEYS): counts per level, the worst machine, the least remaining
precision life, the highest fatigue life used and end-stress ratio. Statuses silent for `stale_after_s`
count as STALE. With `history_file`, each status is recorded at most every `history_period_s` into the
table `fleet_history(t_unix_s, hardware_id, name, level, message, values_json)` for trend reports.
"""
from __future__ import annotations

import json
import sqlite3
import sys
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node

from guide_health.models.fleet import SUMMARY_KEYS, FleetBoard
from guide_health.nodes.common import run_node
from guide_health.nodes.status import StatusTask, StatusUpdater
from guide_health.params import FLEET_MONITOR_SCHEMA, declare_parameters

HISTORY_SCHEMA = """
CREATE TABLE IF NOT EXISTS fleet_history (
    t_unix_s REAL NOT NULL,
    hardware_id TEXT NOT NULL,
    name TEXT NOT NULL,
    level INTEGER NOT NULL,
    message TEXT NOT NULL,
    values_json TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS fleet_history_machine ON fleet_history (hardware_id, name, t_unix_s);
"""


class FleetHistory:
    """Append-only SQLite record of statuses, at most one row per status every `period_s`."""

    def __init__(self, path: str, period_s: float):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(path, isolation_level=None, timeout=10.0)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.executescript(HISTORY_SCHEMA)
        self.period_s = float(period_s)
        self._last: dict[tuple[str, str], float] = {}
        self._pending: list[tuple] = []

    def record(self, t_unix_s: float, hardware_id: str, name: str, level: int, message: str, values: dict):
        key = (hardware_id, name)
        last = self._last.get(key)
        if last is not None and t_unix_s - last < self.period_s:
            return
        self._last[key] = t_unix_s
        self._pending.append((t_unix_s, hardware_id, name, level, message, json.dumps(values)))

    def commit(self) -> None:
        if self._pending:
            with self.db:
                self.db.executemany("INSERT INTO fleet_history VALUES (?, ?, ?, ?, ?, ?)", self._pending)
            self._pending.clear()

    def close(self) -> None:
        self.commit()
        self.db.close()


class FleetMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("fleet_monitor", **kwargs)
        self.params = declare_parameters(self, FLEET_MONITOR_SCHEMA)   # validated: periods > 0
        self.board = FleetBoard(self.params["stale_after_s"], ignore_prefix=f"{self.get_name()}: ")
        self.history = (FleetHistory(self.params["history_file"], self.params["history_period_s"])
                        if self.params["history_file"] else None)
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 100)
        # the board ages silent machines to STALE itself: the task has no stale inputs
        self.updater = StatusUpdater(self, self.params["machine_id"])
        self.updater.add(StatusTask("fleet", self._fleet_report, SUMMARY_KEYS))
        self.create_timer(self.params["diagnostics_period_s"], self.publish_diagnostics)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        wall = time.time()
        for status in msg.status:
            level = status.level[0] if isinstance(status.level, (bytes, bytearray)) else int(status.level)
            values = {kv.key: kv.value for kv in status.values}
            if self.board.update(status.name, status.hardware_id, level, status.message, values, now) \
                    and self.history is not None:
                self.history.record(wall, status.hardware_id, status.name, level, status.message, values)

    def _fleet_report(self) -> tuple[int, str, dict]:
        summary = self.board.summary(time.monotonic())
        return summary["level"], summary["message"], summary

    def publish_diagnostics(self) -> None:
        self.updater.update()
        if self.history is not None:
            self.history.commit()

    def close(self) -> None:
        if self.history is not None:
            self.history.close()
            self.history = None


def main(argv: list[str] | None = None) -> int:
    return run_node("fleet_monitor", FleetMonitorNode, argv)


if __name__ == "__main__":
    sys.exit(main())
