"""`guide-health fleet plan FLEET_REPLAY_DIR|HISTORY_DB [--horizon 12w] [--group-days 7] [--from DATE]`: the
machines/axes whose limit date at the 90 % lower bound falls within the horizon, grouped into planned stops
(analysis/fleet_plan.py; docs/planning.md), as fleet_plan.csv and fleet_plan.ics."""
from __future__ import annotations

import math
import time
from datetime import UTC, datetime
from pathlib import Path

from guide_health.analysis.fleet_plan import (
    dues_from_fleet_dir,
    dues_from_history,
    plan_rows,
    plan_summary,
    schedule,
    write_fleet_plan,
)
from guide_health.cli.command import Command, check_out_path, value_errors_as_input_errors
from guide_health.errors import InputError
from guide_health.models.wear.planning import NS_PER_S, date_ns, duration_s


def add_arguments(parser) -> None:
    parser.add_argument("source", metavar="FLEET_REPLAY_DIR|HISTORY_DB",
                        help="output directory (or fleet.json) of `fleet replay`, or the fleet_monitor history")
    parser.add_argument("--horizon", default="12w", help="how far ahead: 12w, 90d, 2000h (default 12w)")
    parser.add_argument("--group-days", type=float, default=7.0,
                        help="a stop takes every due within this many days after its first (default 7)")
    parser.add_argument("--from", dest="start", default=None,
                        help="the plan's start, a UTC date (default: the history's newest row; for a replay "
                             "directory, now)")
    parser.add_argument("--out", default=None, help="output directory (default: <source>.plan beside it)")


def run(args) -> dict:
    source = Path(args.source)
    with value_errors_as_input_errors():
        horizon_s = duration_s(args.horizon)
        start_s = date_ns(args.start) / NS_PER_S if args.start else math.nan
    if not (horizon_s > 0 and args.group_days >= 0):
        raise InputError("--horizon must be > 0 and --group-days >= 0")
    if source.is_dir() or source.suffix == ".json":
        dues = dues_from_fleet_dir(source)
        newest = time.time()
    elif source.is_file():
        dues, newest = dues_from_history(source)
    else:
        raise InputError(f"{source}: neither a fleet replay directory nor a fleet history file")
    start_s = newest if math.isnan(start_s) else start_s
    stops = schedule(dues, start_s, horizon_s, args.group_days)
    out = check_out_path(args.out if args.out else source.with_name(source.name + ".plan"))
    files = write_fleet_plan(out, stops, datetime.now(UTC))
    return {"source": str(source), "start_utc": datetime.fromtimestamp(start_s, tz=UTC).isoformat(),
            "horizon_s": horizon_s, "group_days": args.group_days, "axes": len(dues),
            "rows": plan_rows(stops), **plan_summary(stops), "files": files}


def format_text(result: dict) -> str:
    lines = [f"fleet plan from {result['start_utc'][:10]}: {len(result['rows'])} of {result['axes']} "
             f"machine axes due, {len(result['stops'])} stops"]
    last = None
    for r in result["rows"]:
        if r["stop"] != last:
            lines.append(f"  stop {r['stop']} on {r['stop_date']}:")
            last = r["stop"]
        lines.append(f"    {r['machine']} {r['axis']}: limit {r['limit_date_utc'][:10] or 'never'} (90 % low "
                     f"{r['limit_date_utc_low'][:10]}){' OVERDUE' if r['overdue'] else ''}")
    lines.append(f"  files: {', '.join(result['files'].values())}")
    return "\n".join(lines)


FLEET_PLAN = Command(add_arguments, run, format_text)
