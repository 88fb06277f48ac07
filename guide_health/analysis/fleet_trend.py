"""The fleet_monitor history (io/outputs/fleet_history.py) as per-machine trends: the data (`read_trends`,
`MachineTrend`), the ranking by latest remaining life and the per-machine CSV. The plots are
fleet_trend_plots.py, the whole report (`guide-health fleet trend`) fleet_trend_report.py.

Two resolutions: every row, or (a history of layout 3 holding more than RAW_ROWS_MAX rows in the window, or
asked for) the history's hourly rows: per status and hour the last values and the level as the trend's
points, each value's minimum and maximum drawn as the figures' envelope, and the level changes still exact
(the rows of only those hours whose level is not constant, or differs from the hour before, are read).
"""
from __future__ import annotations

import csv
import math
import re
import sqlite3
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from guide_health.errors import InputError
from guide_health.io.outputs.files import open_output
from guide_health.io.outputs.fleet_history import LAYOUT, SECONDS_PER_BUCKET, history_layout
from guide_health.models.fleet import FLEET_VALUES
from guide_health.models.levels import LEVEL_NAMES

#: the trend quantities: status key, label with unit (the history's value columns)
TREND_KEYS = FLEET_VALUES
#: rows in the window above which a layout-3 history is read by the hour (resolution "auto"): a page of every
#: row grows with the rows (432 000 rows: 17.8 s and 52 MB on the 2-core host, docs/performance.md)
RAW_ROWS_MAX = 500_000
RESOLUTIONS = ("auto", "rows", "hourly")
#: the hourly rows' per-bucket columns beyond the trend's points (fleet_history_hourly)
HOURLY_COLUMNS = ("rows", "t_first", "level_first", "level_min", "level_max",
                  *(f"{k}_{edge}" for k, _ in TREND_KEYS for edge in ("min", "max", "t_last")))


@dataclass
class MachineTrend:
    """The history rows of one machine (every status of its monitors), oldest first: times [unix s], levels
    and each trend key's values (NaN: not reported) as numpy columns, status names and messages as lists."""

    machine: str
    t_unix_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    status: list[str] = field(default_factory=list)
    level: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    message: list[str] = field(default_factory=list)
    values: dict[str, np.ndarray] = field(default_factory=lambda: {k: np.zeros(0) for k, _ in TREND_KEYS})
    #: read by the hour: HOURLY_COLUMNS per bucket (the points above are each bucket's last time, last level,
    #: last message and last reported values); None: every row
    hourly: dict[str, np.ndarray] | None = None
    _changes: list[dict] | None = field(default=None, repr=False, compare=False)

    def row_count(self) -> int:
        """The history rows the trend stands for."""
        return len(self.t_unix_s) if self.hourly is None else int(self.hourly["rows"].sum())

    def first_t(self) -> float:
        """The time of the first row [unix s]."""
        return float(self.t_unix_s[0] if self.hourly is None else self.hourly["t_first"][0])

    def points(self, key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(times, values, status names) to draw of a trend key or "level", in time order: every row; by
        the hour each bucket's minimum at its first time and its maximum at its last, so the figure's envelope
        holds every extreme of the rows."""
        values = self.level.astype(float) if key == "level" else np.asarray(self.values[key], dtype=float)
        status = np.asarray(self.status, dtype=object)
        if self.hourly is None:
            return np.asarray(self.t_unix_s, dtype=float), values, status
        low, high = (("level_min", "level_max") if key == "level" else (f"{key}_min", f"{key}_max"))
        t = np.concatenate((self.hourly["t_first"], self.t_unix_s))
        order = np.argsort(t, kind="stable")
        v = np.concatenate((self.hourly[low].astype(float), self.hourly[high].astype(float)))
        return t[order], v[order], np.concatenate((status, status))[order]

    def _rows_of_status(self) -> dict[str, np.ndarray]:
        """Each status name's row indices, ascending."""
        names = np.asarray(self.status, dtype=object)
        return {name: np.flatnonzero(names == name) for name in dict.fromkeys(self.status)}

    def level_changes(self) -> list[dict]:
        """Every change of level of one status, in row order: {t_unix_s, status, from, to, message}. Read by
        the hour, they were found in the rows when read (`read_trends`)."""
        if self._changes is None:
            at, before = [], []                 # the row of each change, and the status's level before it
            for rows in self._rows_of_status().values():
                levels = self.level[rows]
                changed = np.flatnonzero(levels[1:] != levels[:-1])
                at.append(rows[changed + 1])
                before.append(levels[changed])
            rows = np.concatenate(at) if at else np.zeros(0, dtype=np.int64)
            previous = np.concatenate(before) if before else np.zeros(0, dtype=np.int64)
            order = np.argsort(rows, kind="stable")
            self._changes = [{"t_unix_s": float(self.t_unix_s[i]), "status": self.status[i],
                              "from": LEVEL_NAMES.get(was, str(was)),
                              "to": LEVEL_NAMES.get(int(self.level[i]), str(int(self.level[i]))),
                              "message": self.message[i]}
                             for i, was in zip(rows[order].tolist(), previous[order].tolist())]
        return self._changes

    def latest(self, key: str) -> float:
        """The latest finite value of a trend key (NaN: none); by the hour, the hour whose last report of it
        is the newest (of equal times the last)."""
        finite = np.flatnonzero(np.isfinite(self.values[key]))
        if not finite.size:
            return math.nan
        if self.hourly is None:
            return float(self.values[key][finite[-1]])
        reported = self.hourly[f"{key}_t_last"][finite]
        return float(self.values[key][finite[np.flatnonzero(reported == reported.max())[-1]]])

    def latest_level(self) -> int:
        """The worst of the latest level of each status."""
        rows = self._rows_of_status()
        return max(int(self.level[r[-1]]) for r in rows.values()) if rows else 3


#: the trend keys are the history's REAL columns (io/outputs/fleet_history.py, layout 2)
_TREND_COLUMNS = ", ".join(key for key, _ in TREND_KEYS)


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def read_trends(db: Path, machine: str | None = None, days: float | None = None,
                resolution: str = "auto") -> dict[str, MachineTrend]:
    """The history of every machine (or only ``machine``; only the last ``days`` before the newest row),
    read-only, at ``resolution`` (RESOLUTIONS: "auto" reads by the hour when a layout-3 history holds more
    than RAW_ROWS_MAX rows in the window); InputError for a file that is not a fleet history."""
    if resolution not in RESOLUTIONS:
        raise InputError(f"resolution must be one of {', '.join(RESOLUTIONS)}, got {resolution!r}")
    if not db.is_file():
        raise InputError(f"fleet history not found: {db}")
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        try:
            layout = check_history_layout(db, con)
            if resolution == "hourly" and layout < 3:
                raise InputError(f"{db}: a history of layout {layout} has no hourly rows; open it once with "
                                 "fleet_monitor (history_file:=<this file>), which adds them")
            window = _hourly_where(con, machine, days) if layout >= 3 and resolution != "rows" else None
            hourly = window is not None and (resolution == "hourly" or _rows_in_window(con, window) > RAW_ROWS_MAX)
            trends = _hourly_trends(con, window) if hourly else _row_trends(con, machine, days)
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{db}: not a fleet history (fleet_monitor history_file): {exc}") from None
    if machine is not None and not trends:
        known = _machines(db)
        raise InputError(f"{db}: no history of machine '{machine}'; machines: {', '.join(known) or 'none'}")
    return trends


def _machine_where(machine: str | None) -> tuple[list[str], list]:
    """The WHERE terms and arguments of the machine filter (none: every machine)."""
    return (["1"], []) if machine is None else (["1", "hardware_id = ?"], [machine])


def _row_trends(con: sqlite3.Connection, machine: str | None, days: float | None) -> dict[str, MachineTrend]:
    where, args = _machine_where(machine)
    if days is not None:
        where.append("t_unix_s >= (SELECT MAX(t_unix_s) FROM fleet_history) - ?")
        args.append(days * 86400.0)
    rows = con.execute(f"SELECT t_unix_s, hardware_id, name, level, message, {_TREND_COLUMNS} FROM "
                       f"fleet_history WHERE {' AND '.join(where)} ORDER BY t_unix_s", args).fetchall()
    return _machine_trends(rows)


def _hourly_where(con: sqlite3.Connection, machine: str | None, days: float | None) -> tuple[str, list]:
    """The WHERE clause and arguments of the hourly rows of the window: whole hours from the one holding
    (newest row - days)."""
    where, args = _machine_where(machine)
    if days is not None:
        newest = con.execute("SELECT MAX(t_last) FROM fleet_history_hourly").fetchone()[0]
        if newest is not None:
            where.append("hour >= ?")
            args.append(math.floor((newest - days * 86400.0) / SECONDS_PER_BUCKET))
    return " AND ".join(where), args


def _rows_in_window(con: sqlite3.Connection, window: tuple[str, list]) -> int:
    """The history rows the hourly rows of the window (_hourly_where) stand for."""
    where, args = window
    return int(con.execute(f"SELECT coalesce(SUM(rows), 0) FROM fleet_history_hourly WHERE {where}",
                           args).fetchone()[0])


def _hourly_trends(con: sqlite3.Connection, window: tuple[str, list]) -> dict[str, MachineTrend]:
    """The trends from the hourly rows of the window (_hourly_where; points: each hour's last time, level,
    message and values), with the exact level changes (_hourly_level_changes)."""
    where, args = window
    last = ", ".join(f"{k}_last" for k, _ in TREND_KEYS)
    rows = con.execute(f"SELECT t_last, hardware_id, name, level_last, message_last, {last}, "
                       f"{', '.join(HOURLY_COLUMNS)} FROM fleet_history_hourly WHERE {where} "
                       f"ORDER BY t_last, hardware_id, name", args).fetchall()
    width = 5 + len(TREND_KEYS)
    trends = _machine_trends([r[:width] for r in rows], extra=[r[width:] for r in rows])
    for trend in trends.values():
        trend._changes = _hourly_level_changes(con, trend)
    return trends


def _hourly_level_changes(con: sqlite3.Connection, trend: MachineTrend) -> list[dict]:
    """The level changes of a trend read by the hour, as level_changes finds them in the rows: an hour can
    hold one only if its level is not constant or its first level differs from the hour before (in the
    window) ended with; only those hours' rows, and the last row before each, are read."""
    found = []
    h = trend.hourly
    for name, rows in trend._rows_of_status().items():
        first, lo, hi = h["level_first"][rows], h["level_min"][rows], h["level_max"][rows]
        suspect = (lo != hi) | np.r_[False, first[1:] != trend.level[rows][:-1]]
        for k in np.flatnonzero(suspect).tolist():
            since = trend.t_unix_s[rows[k - 1]] if k > 0 else h["t_first"][rows[k]]
            raw = con.execute("SELECT t_unix_s, rowid, level, message FROM fleet_history WHERE hardware_id = ? "
                              "AND name = ? AND t_unix_s >= ? AND t_unix_s <= ? ORDER BY t_unix_s, rowid",
                              (trend.machine, name, float(since), float(trend.t_unix_s[rows[k]]))).fetchall()
            found += [(t, rowid, name, was, level, message)
                      for (_, _, was, _), (t, rowid, level, message) in zip(raw, raw[1:]) if level != was]
    found.sort(key=lambda c: (c[0], c[1]))
    return [{"t_unix_s": float(t), "status": name, "from": LEVEL_NAMES.get(was, str(was)),
             "to": LEVEL_NAMES.get(level, str(level)), "message": message}
            for t, _, name, was, level, message in found]


def _real_column(column: tuple) -> np.ndarray:
    """A REAL column as floats (NULL: NaN); a migrated value may be a text (_number, NaN if unreadable)."""
    try:
        return np.array(column, dtype=float)
    except (TypeError, ValueError):
        return np.array([_number(v) for v in column], dtype=float)


def _machine_trends(rows: list, extra: list | None = None) -> dict[str, MachineTrend]:
    """Every machine's trend from the rows (t, hardware_id, name, level, message, *TREND_KEYS) in time order
    (and per row its HOURLY_COLUMNS in ``extra``: read by the hour): transposed once (zip, in C), grouped by a
    stable sort of the machine, so a machine keeps its rows' time order; machines in the order of their first
    row."""
    if not rows:
        return {}
    t, hw, names, levels, messages, *columns = zip(*rows)
    machines, first, code = np.unique(np.array(hw, dtype=object), return_index=True, return_inverse=True)
    by_first = np.argsort(first, kind="stable")
    rank = np.empty(machines.size, dtype=np.int64)
    rank[by_first] = np.arange(machines.size)           # machine -> place of its first row
    row_rank = rank[code.ravel()]
    order = np.argsort(row_rank, kind="stable")
    ends = np.cumsum(np.bincount(row_rank, minlength=machines.size))
    t_all, level_all = np.array(t, dtype=float)[order], np.array(levels, dtype=np.int64)[order]
    names_all, messages_all = np.array(names, dtype=object)[order], np.array(messages, dtype=object)[order]
    values_all = {key: _real_column(column)[order] for (key, _), column in zip(TREND_KEYS, columns)}
    hourly_all = None
    if extra is not None:
        hourly_all = {name: (np.array(column, dtype=np.int64) if name.startswith(("rows", "level"))
                             else _real_column(column))[order] for name, column in zip(HOURLY_COLUMNS, zip(*extra))}
    trends = {}
    for m, lo, hi in zip(machines[by_first].tolist(), [0, *ends[:-1].tolist()], ends.tolist()):
        trends[m] = MachineTrend(m, t_all[lo:hi], names_all[lo:hi].tolist(), level_all[lo:hi],
                                 messages_all[lo:hi].tolist(), {k: v[lo:hi] for k, v in values_all.items()},
                                 None if hourly_all is None else {k: v[lo:hi] for k, v in hourly_all.items()})
    return trends


def check_history_layout(db: Path, con: sqlite3.Connection) -> int:
    """The file's layout (2, or 3 with the hourly rows); InputError unless it holds a fleet history this
    reader reads."""
    layout = history_layout(con)
    if layout == 1:
        raise InputError(f"{db}: a fleet history of layout 1 (values_json); open it once with fleet_monitor "
                         "(history_file:=<this file>), which migrates it, then read it")
    if layout not in (2, LAYOUT):
        raise InputError(f"{db}: not a fleet history of layout 2 or {LAYOUT} (fleet_monitor history_file; "
                         f"found {'no fleet_history table' if layout == 0 else f'layout {layout}'})")
    return layout


def _machines(db: Path) -> list[str]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return [r[0] for r in con.execute("SELECT DISTINCT hardware_id FROM fleet_history ORDER BY 1")]
    finally:
        con.close()


def safe_name(machine: str) -> str:
    """A file name for a machine id."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", machine) or "_"


def iso(t_unix_s: float) -> str:
    return datetime.fromtimestamp(t_unix_s, tz=UTC).strftime("%Y-%m-%d %H:%M:%S")


def iso_array(t_unix_s) -> list[str]:
    """`iso` of many times at once (numpy datetime64, rounded to the microsecond as datetime is, then cut to
    the second): the per-row datetime call was most of a machine's CSV time."""
    us = np.round(np.asarray(t_unix_s, dtype=float) * 1e6).astype(np.int64).astype("datetime64[us]")
    return [text.replace("T", " ") for text in np.datetime_as_string(us, unit="s").tolist()]


def _number_texts(values: np.ndarray) -> list[str]:
    """A trend column's CSV texts: 6 significant digits, '' for NaN (not reported)."""
    return ["" if v != v else f"{v:.6g}" for v in values.tolist()]


def write_trend_csv(path: Path, trend: MachineTrend) -> None:
    """Every row: time (unix s and UTC), status, level name, the trend keys, message. Read by the hour, one row
    per status and hour: its first and last time, rows, first, last, least and worst level, per trend key its
    minimum, maximum and last value, the last message."""
    levels = [LEVEL_NAMES.get(level, level) for level in trend.level.tolist()]
    if trend.hourly is None:
        header = ["t_unix_s", "time_utc", "status", "level", *[k for k, _ in TREND_KEYS], "message"]
        columns = [[f"{t:.3f}" for t in trend.t_unix_s.tolist()], iso_array(trend.t_unix_s), trend.status, levels,
                   *[_number_texts(trend.values[k]) for k, _ in TREND_KEYS], trend.message]
    else:
        h = trend.hourly
        level_names = {edge: [LEVEL_NAMES.get(v, v) for v in h[f"level_{edge}"].tolist()]
                       for edge in ("first", "min", "max")}
        header = ["hour_utc", "t_first_unix_s", "t_last_unix_s", "status", "rows", "level_first", "level_last",
                  "level_least", "level_worst",
                  *[f"{k}_{edge}" for k, _ in TREND_KEYS for edge in ("min", "max", "last")], "message_last"]
        hour_start = np.floor(np.asarray(h["t_first"]) / SECONDS_PER_BUCKET) * SECONDS_PER_BUCKET
        columns = [iso_array(hour_start), [f"{t:.3f}" for t in h["t_first"].tolist()],
                   [f"{t:.3f}" for t in trend.t_unix_s.tolist()], trend.status, h["rows"].tolist(),
                   level_names["first"], levels, level_names["min"], level_names["max"],
                   *[_number_texts(v) for k, _ in TREND_KEYS
                     for v in (h[f"{k}_min"], h[f"{k}_max"], trend.values[k])], trend.message]
    with open_output(path) as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(zip(*columns))


def ranking(trends: dict[str, MachineTrend]) -> list[dict]:
    """One row per machine, least remaining life first (machines without one last)."""
    rows = [{"machine": m, "level": LEVEL_NAMES.get(t.latest_level(), "?"),
             **{k: t.latest(k) for k, _ in TREND_KEYS},
             "level_changes": len(t.level_changes()), "rows": t.row_count(),
             "last_seen_utc": iso(t.t_unix_s[-1])} for m, t in trends.items()]
    rows.sort(key=lambda r: (math.isnan(r["remaining_life_h"]), r["remaining_life_h"], r["machine"]))
    return rows
