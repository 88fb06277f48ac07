"""The fleet's maintenance schedule: every machine/axis whose limit date at the 90 % lower bound falls within
the horizon, sorted, grouped into planned stops (docs/planning.md), from a ``fleet replay`` directory or the
fleet_monitor history; written as CSV, an iCalendar file and a section of the fleet trend page.

Grouping rule: the dues sorted by their lower-bound date; a stop opens at the earliest due not yet in a stop
(not before the plan's start) and takes every due whose lower-bound date is within ``group_days`` after it;
the next due opens the next stop. Each stop is on its earliest member's date, so no machine in it passes its
lower bound before it; a due whose lower bound is already past at the start is ``overdue`` and goes in the
first stop, at the start.
"""
from __future__ import annotations

import csv
import html
import math
import sqlite3
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from guide_health.analysis.fleet_prior import load_fleet_results
from guide_health.analysis.fleet_trend import check_history_layout
from guide_health.errors import InputError
from guide_health.io.outputs.files import open_output, write_text
from guide_health.io.outputs.ical import AllDayEvent, calendar_text
from guide_health.models.wear.planning import LIMIT_KEYS

DAY_S = 86400.0


@dataclass(frozen=True)
class Due:
    """One machine/axis: its limit date and 90 % band [unix s] (inf: never at the present duty)."""

    machine: str
    axis: str
    limit_s: float
    limit_low_s: float
    limit_high_s: float


def unix_s(text: str) -> float:
    """An ISO-8601 UTC date text (limit_date_utc) -> unix seconds; '' (unknown or infinite) -> inf."""
    if not text:
        return math.inf
    return datetime.fromisoformat(str(text).replace("Z", "+00:00")).timestamp()


def _due(machine: str, axis: str, values: dict) -> Due | None:
    """The Due of a status's or report's values; None without the limit dates or with one unreadable."""
    if LIMIT_KEYS[1] not in values:
        return None
    try:
        return Due(machine, axis, *(unix_s(values.get(k, "")) for k in LIMIT_KEYS))
    except (TypeError, ValueError):
        return None


def dues_from_fleet_dir(path: Path) -> list[Due]:
    """From a ``fleet replay`` output (fleet.json): every axis of every machine; a machine's later bag (in
    the file's order) replaces its earlier one."""
    found: dict[tuple[str, str], Due] = {}
    for entry in load_fleet_results([str(path)]):
        if entry["summary"]["command"] != "replay":
            raise InputError(f"{path}: a fleet diagnose forecasts no date; give a fleet replay directory")
        r = entry.get("result") or {}
        # a machine report: its axes; a single guide's report: one axis, named "axis"
        axes = r["axes"] if "axes" in r and isinstance(r["axes"], dict) else {"axis": r}
        for axis, values in axes.items():
            due = _due(entry["machine"], axis, values) if isinstance(values, dict) else None
            if due is not None:
                found[(due.machine, due.axis)] = due
    return list(found.values())


def dues_from_history(db: Path) -> tuple[list[Due], float]:
    """From the fleet_monitor history: each machine's statuses' latest row with the limit dates (the axis is
    the status name); and the newest row's time [unix s]. Layout 3: the hourly rows name each status's newest
    row with a lower date, read through the index fleet_history_machine; layout 2: SQLite finds it in every
    row. Only a status whose newest dates are unreadable (or whose newest dated row retention just deleted)
    reads its older rows, through the index."""
    dates, low = ", ".join(f"f.{k}" for k in LIMIT_KEYS), LIMIT_KEYS[1]
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        try:
            layout = check_history_layout(db, con)
            if layout >= 3:
                newest_of = ("SELECT hardware_id, name, MAX(dates_t_last) AS t FROM fleet_history_hourly WHERE "
                             "dates_t_last IS NOT NULL GROUP BY hardware_id, name")
                dated = {(machine, name) for machine, name, _ in con.execute(newest_of)}
            else:
                newest_of = (f"SELECT hardware_id, name, MAX(t_unix_s) AS t FROM fleet_history WHERE {low} IS NOT "
                             "NULL GROUP BY hardware_id, name")
            newest_rows = con.execute(
                f"SELECT f.t_unix_s, f.hardware_id, f.name, {dates} FROM fleet_history f JOIN ({newest_of}) g "
                f"ON f.hardware_id = g.hardware_id AND f.name = g.name AND f.t_unix_s = g.t WHERE f.{low} IS NOT NULL "
                "ORDER BY f.t_unix_s").fetchall()
            found = _newest_readable_dues(newest_rows)
            unread = {(machine, name) for _, machine, name, *_ in newest_rows} - found.keys()
            if layout >= 3:
                unread |= dated - {(machine, name) for _, machine, name, *_ in newest_rows}
            for machine, name in sorted(unread):
                rows = con.execute(f"SELECT t_unix_s, hardware_id, name, {', '.join(LIMIT_KEYS)} FROM fleet_history "
                                   f"WHERE hardware_id = ? AND name = ? AND {low} IS NOT NULL ORDER BY t_unix_s",
                                   (machine, name)).fetchall()
                found.update(_newest_readable_dues(rows))
            newest = con.execute("SELECT MAX(t_last) FROM fleet_history_hourly" if layout >= 3 else
                                 "SELECT MAX(t_unix_s) FROM fleet_history").fetchone()[0]
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{db}: not a fleet history (fleet_monitor history_file): {exc}") from None
    return list(found.values()), float(newest) if newest is not None else math.nan


def _newest_readable_dues(rows) -> dict[tuple[str, str], Due]:
    """Per (machine, status) the Due of its last row (rows in time order) whose dates are readable."""
    found: dict[tuple[str, str], Due] = {}
    unreadable: set[tuple] = set()          # date texts that gave no Due: a status repeats its texts
    for _, machine, name, *dates in reversed(list(rows)):
        if (machine, name) in found or tuple(dates) in unreadable:
            continue
        due = _due(machine, name, {k: v for k, v in zip(LIMIT_KEYS, dates) if v is not None})
        if due is None:
            unreadable.add(tuple(dates))
        else:
            found[(machine, name)] = due
    return found


def schedule(dues: list[Due], start_s: float, horizon_s: float, group_days: float) -> list[dict[str, Any]]:
    """The stops (module text): [{date_s, dues: [Due ...], overdue: [bool ...]}], dues with a lower-bound date
    up to start + horizon, sorted by it (then machine, axis)."""
    inside = sorted((d for d in dues if d.limit_low_s <= start_s + horizon_s),
                    key=lambda d: (d.limit_low_s, d.machine, d.axis))
    stops: list[dict[str, Any]] = []
    for d in inside:
        if stops and d.limit_low_s <= stops[-1]["opened_s"] + group_days * DAY_S:
            stops[-1]["dues"].append(d)
            continue
        stops.append({"opened_s": d.limit_low_s, "date_s": max(d.limit_low_s, start_s), "dues": [d]})
    for stop in stops:
        stop["overdue"] = [d.limit_low_s < start_s for d in stop["dues"]]
    return stops


def _day(t_s: float) -> str:
    return datetime.fromtimestamp(t_s, tz=UTC).strftime("%Y-%m-%d")


def _iso(t_s: float) -> str:
    return datetime.fromtimestamp(t_s, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ") if math.isfinite(t_s) else ""


def plan_rows(stops: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per due: its stop (1..), the stop's date, machine, axis, the limit dates, overdue."""
    return [{"stop": i, "stop_date": _day(stop["date_s"]), "machine": d.machine, "axis": d.axis,
             "limit_date_utc_low": _iso(d.limit_low_s), "limit_date_utc": _iso(d.limit_s),
             "limit_date_utc_high": _iso(d.limit_high_s), "overdue": late}
            for i, stop in enumerate(stops, start=1) for d, late in zip(stop["dues"], stop["overdue"])]


def stop_events(stops: list[dict[str, Any]]) -> list[AllDayEvent]:
    """One all-day event per stop: the machines/axes in its summary, their limit dates in its description."""
    events = []
    for stop in stops:
        names = ", ".join(f"{d.machine} {d.axis}" for d in stop["dues"])
        lines = [f"{d.machine} {d.axis}: limit {_iso(d.limit_s) or 'never'} (90 %: {_iso(d.limit_low_s)} .. "
                 f"{_iso(d.limit_high_s) or 'never'}){' OVERDUE' if late else ''}"
                 for d, late in zip(stop["dues"], stop["overdue"])]
        events.append(AllDayEvent(datetime.fromtimestamp(stop["date_s"], tz=UTC).date(),
                                  f"guide regrind stop: {names}", "\n".join(lines)))
    return events


def write_fleet_plan(out: Path, stops: list[dict[str, Any]], stamp: datetime) -> dict[str, str]:
    """fleet_plan.csv (one row per due) and fleet_plan.ics (one event per stop) in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"csv": str(out / "fleet_plan.csv"), "ics": str(out / "fleet_plan.ics")}
    rows = plan_rows(stops)
    columns = ["stop", "stop_date", "machine", "axis", "limit_date_utc_low", "limit_date_utc", "limit_date_utc_high",
               "overdue"]
    with open_output(files["csv"]) as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    write_text(files["ics"], calendar_text(stop_events(stops), stamp))
    return files


def plan_section_html(stops: list[dict[str, Any]], start_s: float, horizon_s: float, group_days: float) -> str:
    """The fleet trend page's section: the stops and their machines/axes as a table."""
    e = html.escape
    body = "".join(f"<tr><td>{r['stop']}</td><td>{e(r['stop_date'])}</td><td>{e(r['machine'])}</td>"
                   f"<td>{e(r['axis'])}</td><td>{e(r['limit_date_utc_low'])}</td><td>{e(r['limit_date_utc'])}</td>"
                   f"<td>{'overdue' if r['overdue'] else ''}</td></tr>" for r in plan_rows(stops))
    return (f"<h2 id='plan'>Maintenance plan</h2><p>Every machine/axis whose limit date at the 90 % lower bound "
            f"falls before {e(_day(start_s + horizon_s))} ({horizon_s / DAY_S / 7:.0f} weeks from "
            f"{e(_day(start_s))}), grouped into stops of {group_days:g} days (docs/planning.md): "
            f"{len(stops)} stops.</p><table><tr><th>stop</th><th>date</th><th>machine</th><th>axis</th>"
            f"<th>limit, 90 % low</th><th>limit</th><th></th></tr>{body}</table>")


def plan_summary(stops: list[dict[str, Any]]) -> dict[str, Any]:
    """The stops as JSON: date, and per due machine, axis and the limit dates ('' = never)."""
    return {"stops": [{"date": _day(s["date_s"]), "overdue": s["overdue"],
                       "dues": [{"machine": d.machine, "axis": d.axis, "limit_date_utc": _iso(d.limit_s),
                                 "limit_date_utc_low": _iso(d.limit_low_s), "limit_date_utc_high": _iso(d.limit_high_s)}
                                for d in s["dues"]]} for s in stops]}
