"""The fleet history: an append-only SQLite record of every machine status `fleet_monitor` receives, for
trend reports (table ``fleet_history``; WAL journal). Rows older than ``retention_days`` are deleted (at
most once an hour); the file is created 0600, never through a symbolic link; an unusable file is one
InputError line naming it."""
from __future__ import annotations

import os
import sqlite3
from pathlib import Path

from guide_health.errors import InputError
from guide_health.io.outputs.json_text import json_text

PRUNE_PERIOD_S = 3600.0         # how often old rows are deleted

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

    def __init__(self, path: str, period_s: float, retention_days: float = 0.0):
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            os.close(os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600))
            self.db = sqlite3.connect(str(self.path), isolation_level=None, timeout=10.0)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.executescript(HISTORY_SCHEMA)
        except (OSError, sqlite3.Error) as exc:
            reason = getattr(exc, "strerror", None) or " ".join(str(exc).split())
            raise InputError(f"history file {self.path}: cannot be used ({reason}); set history_file to a "
                             "writable SQLite file that is no symbolic link, or '' for none") from None
        self.period_s = float(period_s)
        self.retention_s = float(retention_days) * 86400.0      # 0: keep every row
        self._last: dict[tuple[str, str], float] = {}
        self._last_level: dict[tuple[str, str], int] = {}
        self._pending: list[tuple] = []
        self._pruned_at = -float("inf")
        self.deleted_rows = 0

    def prune(self, now_unix_s: float) -> int:
        """Delete the rows older than the retention (if any); forget the per-status periods that are over
        (the history's memory stays bounded by the statuses of one period). Returns the rows deleted."""
        self._last = {k: t for k, t in self._last.items() if now_unix_s - t < self.period_s}
        # a status without a running period is recorded at its next message anyway: its last level can go
        self._last_level = {k: level for k, level in self._last_level.items() if k in self._last}
        self._pruned_at = now_unix_s
        if not self.retention_s > 0:
            return 0
        with self.db:
            deleted = self.db.execute("DELETE FROM fleet_history WHERE t_unix_s < ?",
                                      (now_unix_s - self.retention_s,)).rowcount
        self.deleted_rows += deleted
        return deleted

    def record(self, t_unix_s: float, hardware_id: str, name: str, level: int, message: str, values: dict):
        key = (hardware_id, name)
        last = self._last.get(key)
        changed = self._last_level.get(key) != level
        if last is not None and t_unix_s - last < self.period_s and not changed:
            return
        self._last[key] = t_unix_s
        self._last_level[key] = level
        self._pending.append((t_unix_s, hardware_id, name, level, message, json_text(values)))

    def commit(self, now_unix_s: float | None = None) -> None:
        """Write the pending rows; with `now_unix_s`, prune at most every PRUNE_PERIOD_S."""
        if self._pending:
            with self.db:
                self.db.executemany("INSERT INTO fleet_history VALUES (?, ?, ?, ?, ?, ?)", self._pending)
            self._pending.clear()
        if now_unix_s is not None and now_unix_s - self._pruned_at >= PRUNE_PERIOD_S:
            self.prune(now_unix_s)

    def close(self) -> None:
        self.commit()
        self.db.close()
