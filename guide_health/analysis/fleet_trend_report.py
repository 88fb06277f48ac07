"""`guide-health fleet trend`: per machine a CSV of its statuses over time (remaining life, straightness,
fatigue life used, end-stress ratio, level) and a PNG; for the fleet an overview PNG and ``index.html``, one
static self-contained page (images and CSV tables embedded as data URIs, no link to a file beside it, no
server, no script) with the ranking by latest remaining life. The data are fleet_trend.py's, the plots
fleet_trend_plots.py's.
"""
from __future__ import annotations

import base64
import csv
import html
import math
from pathlib import Path

from guide_health.analysis.fleet_plan import dues_from_history, plan_section_html, schedule
from guide_health.analysis.fleet_trend import MachineTrend, iso, ranking, read_trends, safe_name, write_trend_csv
from guide_health.analysis.fleet_trend_plots import MachineFigures, plot_fleet_overview, plot_machine_trend
from guide_health.errors import InputError
from guide_health.io.outputs.files import open_output, write_text

#: the page's maintenance plan: `fleet plan`'s defaults
PLAN_HORIZON_S, PLAN_GROUP_DAYS = 12 * 7 * 86400.0, 7.0
#: per-machine figures drawn by default: the page's time is one matplotlib figure per machine (72 s for 20
#: machines x 30 days on the loaded 2-core host, bench/bench_fleet_monitor.py), so a fleet of hundreds gets
#: figures for the machines a reader looks at first (the least remaining life); every machine keeps its CSV
DEFAULT_MACHINE_PLOTS = 24


def write_trend_report(db: Path, out: Path, machine: str | None = None, days: float | None = None,
                       max_plots: int = DEFAULT_MACHINE_PLOTS, resolution: str = "auto") -> dict:
    """CSV per machine, a PNG for the first ``max_plots`` machines of the ranking (least remaining life
    first), fleet_overview.png, ranking.csv and index.html in ``out``; the history read at ``resolution``
    (fleet_trend.read_trends)."""
    trends = read_trends(db, machine, days, resolution)
    if not trends:
        raise InputError(f"{db}: the fleet history is empty")
    hourly = next(iter(trends.values())).hourly is not None
    out.mkdir(parents=True, exist_ok=True)
    rows = ranking(trends)
    plotted = {r["machine"] for r in rows[:max_plots]}
    files: dict[str, dict[str, str]] = {}
    figures = MachineFigures()
    for m, trend in trends.items():
        base = out / f"machine_{safe_name(m)}"
        files[m] = {"csv": str(base.with_suffix(".csv"))}
        write_trend_csv(Path(files[m]["csv"]), trend)
        if m in plotted:
            files[m]["png"] = str(base.with_suffix(".png"))
            plot_machine_trend(Path(files[m]["png"]), trend, figures)
    overview = out / "fleet_overview.png"
    plot_fleet_overview(overview, trends, rows)
    with open_output(out / "ranking.csv") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    page = out / "index.html"
    write_text(page, trend_html(db, rows, trends, overview, files, plan_section(db)))
    return {"history": str(db), "machines": len(trends), "rows": sum(t.row_count() for t in trends.values()),
            "resolution": "hourly" if hourly else "rows",
            "ranking": rows, "level_changes": {m: t.level_changes() for m, t in trends.items()},
            "files": {"html": str(page), "overview_png": str(overview), "ranking_csv": str(out / "ranking.csv"),
                      "machines": files}}


def _data_uri(path: Path, media_type: str = "image/png") -> str:
    """The file's bytes as an RFC 2397 data URI: the page carries it, so it still works mailed alone."""
    return f"data:{media_type};base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _embedded_csv(path: Path) -> str:
    """A download link carrying the CSV itself (saved under its own name)."""
    name = html.escape(path.name)
    return f"<a download='{name}' href='{_data_uri(path, 'text/csv')}'>{name}</a>"


def _fmt(value: float, digits: str = ".1f") -> str:
    return "&ndash;" if not isinstance(value, float) or math.isnan(value) else format(value, digits)


def plan_section(db: Path) -> str:
    """The maintenance plan's section (analysis/fleet_plan.py, `fleet plan`'s defaults: 12 weeks from the
    newest row, stops of 7 days); '' when no status carries a limit date."""
    dues, newest = dues_from_history(db)
    if not dues:
        return ""
    return plan_section_html(schedule(dues, newest, PLAN_HORIZON_S, PLAN_GROUP_DAYS), newest, PLAN_HORIZON_S,
                             PLAN_GROUP_DAYS)


def trend_html(db: Path, rows: list[dict], trends: dict[str, MachineTrend], overview: Path,
               files: dict[str, dict[str, str]], plan_html: str = "") -> str:
    """The static page: ranking table, the maintenance plan, fleet overview, per machine its plot and level
    changes."""
    e = html.escape
    hourly = (" read by the hour (figures: each hour's least and largest value; tables: one row per status and "
              "hour; level changes: every one)" if any(t.hourly is not None for t in trends.values()) else "")
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
        figure = (f"<img alt='trend of {e(m)}' src='{_data_uri(Path(files[m]['png']))}'>" if "png" in files[m]
                  else "<p>No figure (beyond the first machines of the ranking, <code>--plots</code>): its data "
                       "below.</p>")
        sections.append(f"<h2 id='m-{e(safe_name(m))}'>{e(m)}</h2>{figure}<h3>Level changes</h3><ul>{items}</ul>"
                        f"<p>Data (embedded): {_embedded_csv(Path(files[m]['csv']))}</p>")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Fleet trend: {e(db.name)}</title>
<style>body{{font-family:sans-serif;margin:1.5em;max-width:1100px}}table{{border-collapse:collapse}}
td,th{{border:1px solid #999;padding:3px 8px;text-align:right}}td:nth-child(2),td:nth-child(3){{text-align:left}}
img{{max-width:100%;border:1px solid #ccc}}</style></head><body>
<h1>Fleet trend</h1>
<p>History {e(str(db))}: {len(trends)} machines, {sum(t.row_count() for t in trends.values())} status rows{hourly},
{e(iso(min(t.first_t() for t in trends.values())))} .. {e(iso(max(t.t_unix_s[-1] for t in trends.values())))} UTC.
Ranked by the latest remaining precision life (least first).</p>
<table><tr><th>#</th><th>machine</th><th>level</th><th>remaining life [h]</th><th>straightness [um]</th>
<th>life used</th><th>end-stress ratio</th><th>level changes</th><th>last seen (UTC)</th></tr>{table}</table>
<p>Data (embedded): {_embedded_csv(overview.parent / "ranking.csv")}</p>
{plan_html}
<h2>Fleet overview</h2><img alt="fleet overview" src="{_data_uri(overview)}">
{''.join(sections)}
</body></html>
"""
