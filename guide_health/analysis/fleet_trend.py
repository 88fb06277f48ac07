"""The fleet_monitor history (io/outputs/fleet_history.py) as per-machine trends: the data (`read_trends`,
`MachineTrend`), the ranking by latest remaining life and the per-machine CSV. The plots are
fleet_trend_plots.py, the whole report (`guide-health fleet trend`) fleet_trend_report.py.
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
from guide_health.io.outputs.fleet_history import LAYOUT, history_layout
from guide_health.models.fleet import FLEET_VALUES
from guide_health.models.levels import LEVEL_NAMES

#: the trend quantities: status key, label with unit (the history's value columns)
TREND_KEYS = FLEET_VALUES


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
    _changes: list[dict] | None = field(default=None, init=False, repr=False, compare=False)

    def _rows_of_status(self) -> dict[str, np.ndarray]:
        """Each status name's row indices, ascending."""
        names = np.asarray(self.status, dtype=object)
        return {name: np.flatnonzero(names == name) for name in dict.fromkeys(self.status)}

    def level_changes(self) -> list[dict]:
        """Every change of level of one status, in row order: {t_unix_s, status, from, to, message}."""
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
        """The latest finite value of a trend key (NaN: none)."""
        finite = np.flatnonzero(np.isfinite(self.values[key]))
        return float(self.values[key][finite[-1]]) if finite.size else math.nan

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


def read_trends(db: Path, machine: str | None = None, days: float | None = None) -> dict[str, MachineTrend]:
    """The history of every machine (or only ``machine``; only the last ``days`` before the newest row),
    read-only; InputError for a file that is not a fleet history."""
    if not db.is_file():
        raise InputError(f"fleet history not found: {db}")
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        try:
            where, args = ["1"], []
            if machine is not None:
                where.append("hardware_id = ?")
                args.append(machine)
            if days is not None:
                where.append("t_unix_s >= (SELECT MAX(t_unix_s) FROM fleet_history) - ?")
                args.append(days * 86400.0)
            check_history_layout(db, con)
            rows = con.execute(f"SELECT t_unix_s, hardware_id, name, level, message, {_TREND_COLUMNS} FROM "
                               f"fleet_history WHERE {' AND '.join(where)} ORDER BY t_unix_s", args).fetchall()
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{db}: not a fleet history (fleet_monitor history_file): {exc}") from None
    trends = _machine_trends(rows)
    del rows
    if machine is not None and not trends:
        known = _machines(db)
        raise InputError(f"{db}: no history of machine '{machine}'; machines: {', '.join(known) or 'none'}")
    return trends


def _real_column(column: tuple) -> np.ndarray:
    """A REAL column as floats (NULL: NaN); a migrated value may be a text (_number, NaN if unreadable)."""
    try:
        return np.array(column, dtype=float)
    except (TypeError, ValueError):
        return np.array([_number(v) for v in column], dtype=float)


def _machine_trends(rows: list) -> dict[str, MachineTrend]:
    """Every machine's trend from the rows (t, hardware_id, name, level, message, *TREND_KEYS) in time order:
    transposed once (zip, in C), grouped by a stable sort of the machine, so a machine keeps its rows' time
    order; machines in the order of their first row."""
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
    trends = {}
    for m, lo, hi in zip(machines[by_first].tolist(), [0, *ends[:-1].tolist()], ends.tolist()):
        trends[m] = MachineTrend(m, t_all[lo:hi], names_all[lo:hi].tolist(), level_all[lo:hi],
                                 messages_all[lo:hi].tolist(), {k: v[lo:hi] for k, v in values_all.items()})
    return trends


def check_history_layout(db: Path, con: sqlite3.Connection) -> None:
    """InputError unless the file holds a fleet history of the layout this reader reads."""
    layout = history_layout(con)
    if layout == 1:
        raise InputError(f"{db}: a fleet history of layout 1 (values_json); open it once with fleet_monitor "
                         "(history_file:=<this file>), which migrates it, then read it")
    if layout != LAYOUT:
        raise InputError(f"{db}: not a fleet history of layout {LAYOUT} (fleet_monitor history_file; "
                         f"found {'no fleet_history table' if layout == 0 else f'layout {layout}'})")


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
    """One row per status row: time (unix s and UTC), status, level name, the trend keys, message."""
    levels = [LEVEL_NAMES.get(level, level) for level in trend.level.tolist()]
    columns = [[f"{t:.3f}" for t in trend.t_unix_s.tolist()], iso_array(trend.t_unix_s), trend.status, levels,
               *[_number_texts(trend.values[k]) for k, _ in TREND_KEYS], trend.message]
    with open_output(path) as handle:
        writer = csv.writer(handle)
        writer.writerow(["t_unix_s", "time_utc", "status", "level", *[k for k, _ in TREND_KEYS], "message"])
        writer.writerows(zip(*columns))


def ranking(trends: dict[str, MachineTrend]) -> list[dict]:
    """One row per machine, least remaining life first (machines without one last)."""
    rows = [{"machine": m, "level": LEVEL_NAMES.get(t.latest_level(), "?"),
             **{k: t.latest(k) for k, _ in TREND_KEYS},
             "level_changes": len(t.level_changes()), "rows": len(t.t_unix_s),
             "last_seen_utc": iso(t.t_unix_s[-1])} for m, t in trends.items()]
    rows.sort(key=lambda r: (math.isnan(r["remaining_life_h"]), r["remaining_life_h"], r["machine"]))
    return rows
