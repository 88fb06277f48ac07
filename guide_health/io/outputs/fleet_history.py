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

Layout 3 adds ``fleet_history_hourly``: per status and hour of UTC (hour = floor(t / 3600)) the number of
rows, the first and last time, the level's first, last, least and worst value, the last message, and per
trend value its minimum, maximum and last reported value with its time (NULL: none in that hour), and the
time of the hour's last row with limit dates (`fleet plan` finds each status's newest dates through it).
A trend page of a month of hundreds of machines at history_period_s 60 (26 M rows) reads these 432 000 rows
instead: SQLite needs a sort to aggregate the rows themselves (~90 s on 26 M rows), while the hourly rows are
kept up to date at each commit by one upsert of the rows added since the last one (ROLL_UP, the same
statement that builds them for a layout-2 file when fleet_monitor opens it). Retention deletes whole hours.
"""
from __future__ import annotations

import contextlib
import math
import os
import sqlite3
from pathlib import Path

from guide_health.errors import InputError
from guide_health.models.fleet import FLEET_DATE_KEYS, FLEET_VALUE_KEYS

PRUNE_PERIOD_S = 3600.0         # how often old rows are deleted
LAYOUT = 3                      # PRAGMA user_version of the layout below
SECONDS_PER_BUCKET = 3600.0     # the rollup's buckets: hours of UTC
VALUE_COLUMNS = FLEET_VALUE_KEYS + FLEET_DATE_KEYS

_TABLES = f"""
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
CREATE TABLE IF NOT EXISTS fleet_history_hourly (
    hardware_id TEXT NOT NULL,
    name TEXT NOT NULL,
    hour INTEGER NOT NULL,
    rows INTEGER NOT NULL,
    t_first REAL NOT NULL,
    t_last REAL NOT NULL,
    level_first INTEGER NOT NULL,
    level_last INTEGER NOT NULL,
    level_min INTEGER NOT NULL,
    level_max INTEGER NOT NULL,
    message_last TEXT NOT NULL,
    {", ".join(f"{k}_min REAL, {k}_max REAL, {k}_last REAL, {k}_t_last REAL" for k in FLEET_VALUE_KEYS)},
    dates_t_last REAL,
    PRIMARY KEY (hardware_id, name, hour)
) WITHOUT ROWID;
"""
HISTORY_SCHEMA = f"{_TABLES}PRAGMA user_version = {LAYOUT};\n"
#: floor(t_unix_s / 3600) in SQL (CAST truncates toward 0; SQLite's floor() is not built into every library)
HOUR_OF_T = (f"(CAST(t_unix_s / {SECONDS_PER_BUCKET} AS INTEGER) - "
             f"(t_unix_s < 0 AND t_unix_s / {SECONDS_PER_BUCKET} != CAST(t_unix_s / {SECONDS_PER_BUCKET} AS INTEGER)))")
#: a row that reports value k (not NULL) at or after the hour's last report of it
_NEWER = "excluded.{k}_last IS NOT NULL AND ({k}_t_last IS NULL OR excluded.{k}_t_last >= {k}_t_last)"
#: the hourly rows of every fleet_history row with rowid > ?, in rowid order (the order they were recorded):
#: counts add up, minima and maxima widen (SQLite's two-argument min/max are NULL if either is; coalesce keeps
#: the other), the first and last level and message go by time, a value's last is its last reported (non-NULL)
#: one, with its time ({k}_t_last: the trend's latest value of a machine is the newest of its statuses')
ROLL_UP = f"""
INSERT INTO fleet_history_hourly
SELECT hardware_id, name, {HOUR_OF_T}, 1, t_unix_s, t_unix_s, level,
       level, level, level, message,
       {", ".join(f"{k}, {k}, {k}, CASE WHEN {k} IS NULL THEN NULL ELSE t_unix_s END" for k in FLEET_VALUE_KEYS)},
       CASE WHEN {FLEET_DATE_KEYS[1]} IS NULL THEN NULL ELSE t_unix_s END
FROM fleet_history WHERE rowid > ? ORDER BY rowid
ON CONFLICT (hardware_id, name, hour) DO UPDATE SET
    rows = rows + 1,
    t_first = min(t_first, excluded.t_first),
    level_first = CASE WHEN excluded.t_first < t_first THEN excluded.level_first ELSE level_first END,
    t_last = max(t_last, excluded.t_last),
    level_last = CASE WHEN excluded.t_last >= t_last THEN excluded.level_last ELSE level_last END,
    message_last = CASE WHEN excluded.t_last >= t_last THEN excluded.message_last ELSE message_last END,
    level_min = min(level_min, excluded.level_min),
    level_max = max(level_max, excluded.level_max),
    {(","+chr(10)+"    ").join(
        f"{k}_min = coalesce(min({k}_min, excluded.{k}_min), {k}_min, excluded.{k}_min), "
        f"{k}_max = coalesce(max({k}_max, excluded.{k}_max), {k}_max, excluded.{k}_max), "
        f"{k}_last = CASE WHEN {_NEWER.format(k=k)} THEN excluded.{k}_last ELSE {k}_last END, "
        f"{k}_t_last = CASE WHEN {_NEWER.format(k=k)} THEN excluded.{k}_t_last ELSE {k}_t_last END"
        for k in FLEET_VALUE_KEYS)},
    dates_t_last = coalesce(max(dates_t_last, excluded.dates_t_last), dates_t_last, excluded.dates_t_last)
"""
INSERT_ROW = f"INSERT INTO fleet_history VALUES ({', '.join('?' * (5 + len(VALUE_COLUMNS)))})"
#: layout 1 -> 2, in SQLite: the same keys out of values_json as the layout-1 trend reader took them
_EXTRACTS = ", ".join(f"CASE WHEN json_valid(values_json) THEN json_extract(values_json, '$.\"{k}\"') END"
                      for k in VALUE_COLUMNS)
_MIGRATION = f"""
BEGIN;
DROP INDEX IF EXISTS fleet_history_machine;
ALTER TABLE fleet_history RENAME TO fleet_history_layout1;
{_TABLES}
PRAGMA user_version = 2;
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


@contextlib.contextmanager
def transaction(db: sqlite3.Connection):
    """One transaction on a connection that autocommits each statement: the rows and their hourly rows are
    written, deleted or migrated together or not at all."""
    db.execute("BEGIN IMMEDIATE")
    try:
        yield
    except BaseException:
        db.execute("ROLLBACK")
        raise
    db.execute("COMMIT")


def _open(path: Path) -> sqlite3.Connection:
    """The history's connection in layout 3 (a layout-1 or -2 file migrated); InputError for a newer layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    os.close(os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600))
    db = sqlite3.connect(str(path), isolation_level=None, timeout=10.0)
    db.execute("PRAGMA journal_mode=WAL")
    layout = history_layout(db)
    if layout == 1:
        db.executescript(_MIGRATION)
    if layout in (1, 2):            # layout 2 -> 3: the hourly rows of every row so far, in one transaction
        db.executescript(_TABLES)   # (executescript commits first: outside the transaction)
        with transaction(db):
            db.execute("DELETE FROM fleet_history_hourly")
            db.execute(ROLL_UP, (0,))
            db.execute(f"PRAGMA user_version = {LAYOUT}")
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
        # the newest row already in the hourly rows (the migration, or an earlier run, rolled up the rest)
        self._rolled_rowid = self._newest_rowid()
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
        cutoff = now_unix_s - self.retention_s
        with transaction(self.db):
            deleted = self.db.execute("DELETE FROM fleet_history WHERE t_unix_s < ?", (cutoff,)).rowcount
            # whole hours only: an hour the cutoff falls in stays (its counts include the rows just deleted)
            self.db.execute("DELETE FROM fleet_history_hourly WHERE hour < ?",
                            (math.floor(cutoff / SECONDS_PER_BUCKET),))
            # every row left is rolled up; with none left SQLite numbers the next rows from 1 again
            newest = self._newest_rowid()
        self._rolled_rowid = newest
        self.deleted_rows += deleted
        return deleted

    def _newest_rowid(self) -> int:
        return self.db.execute("SELECT coalesce(MAX(rowid), 0) FROM fleet_history").fetchone()[0]


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
            with transaction(self.db):
                self.db.executemany(INSERT_ROW, self._pending)
                self.db.execute(ROLL_UP, (self._rolled_rowid,))
                newest = self._newest_rowid()
            self._rolled_rowid = newest
            self._pending.clear()
        if now_unix_s is not None and now_unix_s - self._pruned_at >= PRUNE_PERIOD_S:
            self.prune(now_unix_s)

    def close(self) -> None:
        self.commit()
        self.db.close()
