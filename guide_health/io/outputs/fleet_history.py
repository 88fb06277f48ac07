"""The fleet history: an append-only SQLite record of every machine status `fleet_monitor` receives, for
trend reports and the fleet plan (table ``fleet_history``; WAL journal). Rows older than ``retention_days``
are deleted (at most once an hour); the file is created 0600, never through a symbolic link; an unusable
file is one InputError line naming it.

Layout 2 (``PRAGMA user_version = 2``): one column per value a reader uses, the trend values as REAL
(models/fleet.FLEET_VALUES; a value that is no number is NULL, as the trend reads it: NaN) and the limit
dates as their text (FLEET_DATE_KEYS, for `fleet plan`); a status's other keys are not kept (no reader
used them, and their JSON was ~90 % of a row's bytes). A history of layout 1 (the status's values as one
``values_json`` text) is migrated when `fleet_monitor` opens it: one transaction in SQLite (json_extract
of the same keys, so the readers' numbers are unchanged), the old table dropped.
"""
from __future__ import annotations

import math
import os
import sqlite3
from pathlib import Path

from guide_health.errors import InputError
from guide_health.models.fleet import FLEET_DATE_KEYS, FLEET_VALUE_KEYS

PRUNE_PERIOD_S = 3600.0         # how often old rows are deleted
LAYOUT = 2                      # PRAGMA user_version of the layout below
VALUE_COLUMNS = FLEET_VALUE_KEYS + FLEET_DATE_KEYS

HISTORY_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS fleet_history (
    t_unix_s REAL NOT NULL,
    hardware_id TEXT NOT NULL,
    name TEXT NOT NULL,
    level INTEGER NOT NULL,
    message TEXT NOT NULL,
    {", ".join(f"{k} REAL" for k in FLEET_VALUE_KEYS)},
    {", ".join(f"{k} TEXT" for k in FLEET_DATE_KEYS)}
);
CREATE INDEX IF NOT EXISTS fleet_history_machine ON fleet_history (hardware_id, name, t_unix_s);
PRAGMA user_version = {LAYOUT};
"""
INSERT_ROW = f"INSERT INTO fleet_history VALUES ({', '.join('?' * (5 + len(VALUE_COLUMNS)))})"
#: layout 1 -> 2, in SQLite: the same keys out of values_json as the layout-1 trend reader took them
_EXTRACTS = ", ".join(f"CASE WHEN json_valid(values_json) THEN json_extract(values_json, '$.\"{k}\"') END"
                      for k in VALUE_COLUMNS)
_MIGRATION = f"""
BEGIN;
DROP INDEX IF EXISTS fleet_history_machine;
ALTER TABLE fleet_history RENAME TO fleet_history_layout1;
{HISTORY_SCHEMA}
INSERT INTO fleet_history SELECT t_unix_s, hardware_id, name, level, message, {_EXTRACTS}
    FROM fleet_history_layout1 ORDER BY rowid;
DROP TABLE fleet_history_layout1;
COMMIT;
"""


def history_layout(db: sqlite3.Connection) -> int:
    """0: no fleet_history table yet; 1: the values_json layout; else the file's user_version."""
    columns = [row[1] for row in db.execute("PRAGMA table_info(fleet_history)")]
    if not columns:
        return 0
    return 1 if "values_json" in columns else int(db.execute("PRAGMA user_version").fetchone()[0])


def _number(text) -> float | None:
    """A status value text as the REAL column stores it (None = NULL for no number: NaN in the readers)."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(value) else value


def history_row(t_unix_s: float, hardware_id: str, name: str, level: int, message: str, values: dict) -> tuple:
    """One status as the row INSERT_ROW takes: its trend values as numbers, its limit dates as texts."""
    return (t_unix_s, hardware_id, name, level, message, *(_number(values.get(k)) for k in FLEET_VALUE_KEYS),
            *(values.get(k) for k in FLEET_DATE_KEYS))


def _open(path: Path) -> sqlite3.Connection:
    """The history's connection in layout 2 (a layout-1 file migrated); InputError for a newer layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    os.close(os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600))
    db = sqlite3.connect(str(path), isolation_level=None, timeout=10.0)
    db.execute("PRAGMA journal_mode=WAL")
    layout = history_layout(db)
    if layout == 1:
        db.executescript(_MIGRATION)
    elif layout > LAYOUT:
        db.close()
        raise InputError(f"history file {path}: layout {layout} of a newer guide_health (this one writes "
                         f"{LAYOUT}); give another history_file")
    db.executescript(HISTORY_SCHEMA)
    return db


class FleetHistory:
    """Append-only SQLite record of statuses: at most one row per status every `period_s`, and every level
    change whenever it comes (a short ERROR between two OKs is two rows, however short)."""

    def __init__(self, path: str, period_s: float, retention_days: float = 0.0):
        self.path = Path(path)
        try:
            self.db = _open(self.path)
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
        self._pending.append(history_row(t_unix_s, hardware_id, name, level, message, values))

    def commit(self, now_unix_s: float | None = None) -> None:
        """Write the pending rows; with `now_unix_s`, prune at most every PRUNE_PERIOD_S."""
        if self._pending:
            with self.db:
                self.db.executemany(INSERT_ROW, self._pending)
            self._pending.clear()
        if now_unix_s is not None and now_unix_s - self._pruned_at >= PRUNE_PERIOD_S:
            self.prune(now_unix_s)

    def close(self) -> None:
        self.commit()
        self.db.close()
