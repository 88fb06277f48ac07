"""`guide-health fleet trend`: the fleet_monitor history (io/outputs/fleet_history.py) as per-machine trends.

Per machine: a CSV of its statuses over time (remaining life, straightness, fatigue life used, end-stress
ratio, level) and a PNG; for the fleet an overview PNG and ``index.html``, one static self-contained page
(images embedded as data URIs, no server, no script) with the ranking by latest remaining life.
"""
from __future__ import annotations

import base64
import csv
import html
import json
import math
import re
import sqlite3
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from guide_health.errors import InputError
from guide_health.io.outputs.files import open_output, write_text
from guide_health.models.levels import LEVEL_NAMES

#: the trend quantities: status key, label with unit
TREND_KEYS = (("remaining_life_h", "remaining precision life [h]"), ("straightness_um", "straightness [um]"),
              ("life_used_fraction", "fatigue life used [-]"), ("end_stress_ratio", "end-stress ratio [-]"))


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
            rows = con.execute("SELECT t_unix_s, hardware_id, name, level, message, values_json FROM fleet_history "
                               f"WHERE {' AND '.join(where)} ORDER BY t_unix_s", args).fetchall()
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{db}: not a fleet history (fleet_monitor history_file): {exc}") from None
    trends: dict[str, MachineTrend] = {}
    for t, hw, name, level, message, values_json in rows:
        try:
            values = json.loads(values_json)
        except ValueError:
            values = {}
        trend = trends.setdefault(hw, MachineTrend(hw))
        trend.t_unix_s.append(float(t))
        trend.status.append(name)
        trend.level.append(int(level))
        trend.message.append(message)
        for key, _ in TREND_KEYS:
            trend.values[key].append(_number(values.get(key)) if isinstance(values, dict) else math.nan)
    if machine is not None and not trends:
        known = _machines(db)
        raise InputError(f"{db}: no history of machine '{machine}'; machines: {', '.join(known) or 'none'}")
    return trends


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


def write_trend_csv(path: Path, trend: MachineTrend) -> None:
    with open_output(path) as handle:
        writer = csv.writer(handle)
        writer.writerow(["t_unix_s", "time_utc", "status", "level", *[k for k, _ in TREND_KEYS], "message"])
        for i, t in enumerate(trend.t_unix_s):
            writer.writerow([f"{t:.3f}", iso(t), trend.status[i], LEVEL_NAMES.get(trend.level[i], trend.level[i]),
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


def write_trend_report(db: Path, out: Path, machine: str | None = None, days: float | None = None) -> dict:
    """CSV + PNG per machine, fleet_overview.png, ranking.csv and index.html in ``out``."""
    from guide_health.analysis.fleet_trend_plots import plot_fleet_overview, plot_machine_trend

    trends = read_trends(db, machine, days)
    if not trends:
        raise InputError(f"{db}: the fleet history is empty")
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, dict[str, str]] = {}
    for m, trend in trends.items():
        base = out / f"machine_{safe_name(m)}"
        files[m] = {"csv": str(base.with_suffix(".csv")), "png": str(base.with_suffix(".png"))}
        write_trend_csv(Path(files[m]["csv"]), trend)
        plot_machine_trend(Path(files[m]["png"]), trend)
    rows = ranking(trends)
    overview = out / "fleet_overview.png"
    plot_fleet_overview(overview, trends, rows)
    with open_output(out / "ranking.csv") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    page = out / "index.html"
    write_text(page, trend_html(db, rows, trends, overview, files))
    return {"history": str(db), "machines": len(trends), "rows": sum(len(t.t_unix_s) for t in trends.values()),
            "ranking": rows, "level_changes": {m: t.level_changes() for m, t in trends.items()},
            "files": {"html": str(page), "overview_png": str(overview), "ranking_csv": str(out / "ranking.csv"),
                      "machines": files}}


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _fmt(value: float, digits: str = ".1f") -> str:
    return "&ndash;" if not isinstance(value, float) or math.isnan(value) else format(value, digits)


def trend_html(db: Path, rows: list[dict], trends: dict[str, MachineTrend], overview: Path,
               files: dict[str, dict[str, str]]) -> str:
    """The static page: ranking table, fleet overview, per machine its plot and level changes."""
    e = html.escape
    colour = {"OK": "#d5f5e3", "WARN": "#fdebd0", "ERROR": "#f5b7b1", "STALE": "#e5e7e9"}
    table = "".join(
        f"<tr style='background:{colour.get(r['level'], '#fff')}'><td>{i}</td>"
        f"<td><a href='#m-{e(safe_name(r['machine']))}'>"
        f"{e(r['machine'])}</a></td><td>{e(r['level'])}</td><td>{_fmt(r['remaining_life_h'])}</td>"
        f"<td>{_fmt(r['straightness_um'], '.2f')}</td><td>{_fmt(r['life_used_fraction'], '.3f')}</td>"
        f"<td>{_fmt(r['end_stress_ratio'], '.3f')}</td><td>{r['level_changes']}</td>"
        f"<td>{e(r['last_seen_utc'])}</td></tr>"
        for i, r in enumerate(rows, start=1))
    sections = []
    for r in rows:
        m = r["machine"]
        changes = trends[m].level_changes()
        items = "".join(f"<li>{e(iso(c['t_unix_s']))} {e(c['status'])}: {e(c['from'])} &rarr; {e(c['to'])} "
                        f"({e(c['message'])})</li>" for c in changes) or "<li>none</li>"
        sections.append(f"<h2 id='m-{e(safe_name(m))}'>{e(m)}</h2><img alt='trend of {e(m)}' "
                        f"src='{_data_uri(Path(files[m]['png']))}'><h3>Level changes</h3><ul>{items}</ul>"
                        f"<p>Data: <a href='{e(Path(files[m]['csv']).name)}'>{e(Path(files[m]['csv']).name)}</a></p>")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Fleet trend: {e(db.name)}</title>
<style>body{{font-family:sans-serif;margin:1.5em;max-width:1100px}}table{{border-collapse:collapse}}
td,th{{border:1px solid #999;padding:3px 8px;text-align:right}}td:nth-child(2),td:nth-child(3){{text-align:left}}
img{{max-width:100%;border:1px solid #ccc}}</style></head><body>
<h1>Fleet trend</h1>
<p>History {e(str(db))}: {len(trends)} machines, {sum(len(t.t_unix_s) for t in trends.values())} status rows,
{e(iso(min(t.t_unix_s[0] for t in trends.values())))} .. {e(iso(max(t.t_unix_s[-1] for t in trends.values())))} UTC.
Ranked by the latest remaining precision life (least first).</p>
<table><tr><th>#</th><th>machine</th><th>level</th><th>remaining life [h]</th><th>straightness [um]</th>
<th>life used</th><th>end-stress ratio</th><th>level changes</th><th>last seen (UTC)</th></tr>{table}</table>
<h2>Fleet overview</h2><img alt="fleet overview" src="{_data_uri(overview)}">
{''.join(sections)}
</body></html>
"""
