"""The fleet history: an append-only SQLite record of every machine status `fleet_monitor` receives, for
trend reports (table ``fleet_history``; WAL journal)."""
from __future__ import annotations

import json
import sqlite3
from pathlib import Path

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
    """Append-only SQLite record of statuses: at most one row per status every `period_s`, and every level
    change whenever it comes (a short ERROR between two OKs is two rows, however short)."""

    def __init__(self, path: str, period_s: float):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(path, isolation_level=None, timeout=10.0)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.executescript(HISTORY_SCHEMA)
        self.period_s = float(period_s)
        self._last: dict[tuple[str, str], float] = {}
        self._last_level: dict[tuple[str, str], int] = {}
        self._pending: list[tuple] = []

    def record(self, t_unix_s: float, hardware_id: str, name: str, level: int, message: str, values: dict):
        key = (hardware_id, name)
        last = self._last.get(key)
        changed = self._last_level.get(key) != level
        if last is not None and t_unix_s - last < self.period_s and not changed:
            return
        self._last[key] = t_unix_s
        self._last_level[key] = level
        self._pending.append((t_unix_s, hardware_id, name, level, message, json.dumps(values)))

    def commit(self) -> None:
        if self._pending:
            with self.db:
                self.db.executemany("INSERT INTO fleet_history VALUES (?, ?, ?, ?, ?, ?)", self._pending)
            self._pending.clear()

    def close(self) -> None:
        self.commit()
        self.db.close()
