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
    """The history rows of one machine (every status of its monitors), oldest first."""

    machine: str
    t_unix_s: list[float] = field(default_factory=list)
    status: list[str] = field(default_factory=list)
    level: list[int] = field(default_factory=list)
    message: list[str] = field(default_factory=list)
    values: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k, _ in TREND_KEYS})

    def level_changes(self) -> list[dict]:
        """Every change of level of one status: {t_unix_s, status, from, to, message}."""
        last: dict[str, int] = {}
        changes = []
        for t, name, level, text in zip(self.t_unix_s, self.status, self.level, self.message):
            if name in last and last[name] != level:
                changes.append({"t_unix_s": t, "status": name, "from": LEVEL_NAMES.get(last[name], str(last[name])),
                                "to": LEVEL_NAMES.get(level, str(level)), "message": text})
            last[name] = level
        return changes

    def latest(self, key: str) -> float:
        """The latest finite value of a trend key (NaN: none)."""
        for v in reversed(self.values[key]):
            if math.isfinite(v):
                return v
        return math.nan

    def latest_level(self) -> int:
        """The worst of the latest level of each status."""
        latest: dict[str, int] = {}
        for name, level in zip(self.status, self.level):
            latest[name] = level
        return max(latest.values()) if latest else 3


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
    groups: dict[str, list] = {}            # a machine's rows, machines in the order of their first row
    for row in rows:
        groups.setdefault(row[1], []).append(row)
    del rows
    trends = {hw: _machine_trend(hw, machine_rows) for hw, machine_rows in groups.items()}
    if machine is not None and not trends:
        known = _machines(db)
        raise InputError(f"{db}: no history of machine '{machine}'; machines: {', '.join(known) or 'none'}")
    return trends


def _machine_trend(machine: str, rows: list) -> MachineTrend:
    """A machine's trend from its rows (t, hardware_id, name, level, message, *TREND_KEYS), transposed in C
    (zip); a REAL column's value is a float or NULL, a migrated one may be a text (_number)."""
    t, _, names, levels, messages, *columns = zip(*rows)
    return MachineTrend(machine, list(map(float, t)), list(names), list(map(int, levels)), list(messages),
                        {key: [v if type(v) is float else _number(v) for v in column]
                         for (key, _), column in zip(TREND_KEYS, columns)})


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


def write_trend_csv(path: Path, trend: MachineTrend) -> None:
    times = iso_array(trend.t_unix_s)
    with open_output(path) as handle:
        writer = csv.writer(handle)
        writer.writerow(["t_unix_s", "time_utc", "status", "level", *[k for k, _ in TREND_KEYS], "message"])
        for i, t in enumerate(trend.t_unix_s):
            writer.writerow([f"{t:.3f}", times[i], trend.status[i], LEVEL_NAMES.get(trend.level[i], trend.level[i]),
                             *["" if math.isnan(trend.values[k][i]) else f"{trend.values[k][i]:.6g}"
                               for k, _ in TREND_KEYS], trend.message[i]])


def ranking(trends: dict[str, MachineTrend]) -> list[dict]:
    """One row per machine, least remaining life first (machines without one last)."""
    rows = [{"machine": m, "level": LEVEL_NAMES.get(t.latest_level(), "?"),
             **{k: t.latest(k) for k, _ in TREND_KEYS},
             "level_changes": len(t.level_changes()), "rows": len(t.t_unix_s),
             "last_seen_utc": iso(t.t_unix_s[-1])} for m, t in trends.items()]
    rows.sort(key=lambda r: (math.isnan(r["remaining_life_h"]), r["remaining_life_h"], r["machine"]))
    return rows
