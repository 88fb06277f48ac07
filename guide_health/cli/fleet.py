"""`guide-health fleet replay|diagnose|trend|prior`: a fleet of machines at once (docs/fleet.md).

* ``fleet replay|diagnose BAG_OR_DIR... --params FILE``: every bag through the single-bag command on Dask
  (analysis/fleet.py), a combined table (CSV, Markdown, JSON) and a PNG ranking the machines.
  Exit status 0 when every bag succeeded, :data:`PARTIAL_EXIT_STATUS` (3) when some failed (the table
  names them with their errors), 2 on bad input (no bag succeeded is still 3: the table says why).
* ``fleet trend HISTORY.db``: the fleet_monitor history as per-machine trends and an HTML page.
* ``fleet prior FLEET.json... --machine-type T``: the empirical-Bayes K prior of a machine type.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
from functools import partial
from pathlib import Path

from guide_health.analysis.fleet import expand_bags, run_fleet
from guide_health.analysis.fleet_report import plot_ranking, table_rows, write_tables
from guide_health.analysis.fleet_trend import RAW_ROWS_MAX, RESOLUTIONS
from guide_health.cli.app import load_command
from guide_health.cli.command import Command
from guide_health.cli.text import jsonable
from guide_health.errors import InputError
from guide_health.io.outputs.files import write_text
from guide_health.io.outputs.json_text import json_text

#: exit status of a fleet run in which some bags failed (the others completed and are reported)
PARTIAL_EXIT_STATUS = 3
#: the single-bag command behind each fleet command (guide_health.cli module:Command)
SINGLE_BAG_COMMANDS = {"replay": "replay:REPLAY", "diagnose": "diagnose:DIAGNOSE"}


def run_single_bag(command: str, bag: str, params_files: tuple[str, ...], out: str,
                   options: tuple[str, ...] = ()) -> dict:
    """One bag through the single-bag `command` (replay|diagnose) as a user runs it, its arguments parsed by
    its own parser (same defaults as on the command line), its stderr chatter dropped: the JSON-able result.
    The fleet runner's `run_one` (analysis/fleet.py) as partial(run_single_bag, command)."""
    cmd = load_command(SINGLE_BAG_COMMANDS[command])
    parser = argparse.ArgumentParser(prog=f"guide-health {command}")
    cmd.add_arguments(parser)
    args = parser.parse_args([bag, *[a for f in params_files for a in ("--params", f)], "--out", out, *options])
    with contextlib.redirect_stderr(io.StringIO()):
        return jsonable(cmd.run(args))


def _add_fleet_arguments(parser, command: str) -> None:
    parser.add_argument("bags", nargs="+", metavar="BAG_OR_DIR",
                        help="bag directories, or directories whose sub-directories are bags")
    parser.add_argument("--params", required=True, action="append",
                        help="ROS 2 parameters YAML (wear_monitor section) of every bag; several merge in order")
    parser.add_argument("--workers", type=int, default=None,
                        help="local Dask worker processes (default: the CPU count); 0 = one bag after another "
                             "in this process, without Dask")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="an existing Dask distributed scheduler, e.g. tcp://10.0.0.5:8786 (its workers need "
                             "guide_health and the same paths to the bags, params and --out)")
    parser.add_argument("--out", default=None, help=f"output directory (default: ./fleet_{command})")
    parser.add_argument("--namespace", default=None, help="topic namespace in the bags (default: detect)")
    parser.add_argument("--no-plot", action="store_true", help="no per-bag PNG (the ranking PNG is kept)")
    parser.add_argument("--progress", action="store_true", help="force the progress bar even without a TTY")
    if command == "diagnose":
        parser.add_argument("--heldout-fraction", type=float, default=None,
                            help="as for `guide-health diagnose` (default 0.25)")
        parser.add_argument("--bic-threshold", type=float, default=None,
                            help="as for `guide-health diagnose` (default 10)")


def _single_bag_options(args, command: str) -> tuple[str, ...]:
    """The options passed on to each single-bag command."""
    options: list[str] = []
    if args.namespace is not None:
        options += ["--namespace", args.namespace]
    if args.no_plot:
        options.append("--no-plot")
    if command == "diagnose":
        if args.heldout_fraction is not None:
            options += ["--heldout-fraction", repr(args.heldout_fraction)]
        if args.bic_threshold is not None:
            options += ["--bic-threshold", repr(args.bic_threshold)]
    return tuple(options)


def _bag_progress(force: bool):
    """progress(done, total) over bags: a tqdm bar on stderr (a TTY, or ``force``)."""
    from tqdm import tqdm

    state: dict = {}

    def progress(done: int, total: int) -> None:
        if "bar" not in state:
            state["bar"] = tqdm(total=total, unit="bag", desc="fleet", file=sys.stderr, ascii=".#",
                                disable=not (force or sys.stderr.isatty()), dynamic_ncols=True)
        bar = state["bar"]
        bar.update(done - bar.n)
        if done >= total:
            bar.close()
    return progress


def fleet_params(paths: list[str], command: str) -> dict:
    """The parameters every bag's command reads, checked once before any worker starts (bad params: one
    error): the wear_monitor section; a replay fleet of slewing bearings only (the files have a slewing_monitor
    section and no wear_monitor one): the slewing_monitor section, with no machine type or K prior."""
    from guide_health.params import node_sections, slewing_monitor_params_from, wear_monitor_params

    slewing_only = command == "replay" and not any(node_sections(p, "wear_monitor", required=False) for p in paths) \
        and any(node_sections(p, "slewing_monitor", required=False) for p in paths)
    if not slewing_only:
        return wear_monitor_params(paths)
    slewing_monitor_params_from(paths)
    return {"machine_type": "", "wear_coefficient": None, "wear_coefficient_prior_rel_sd": None}


def run_fleet_command(args, command: str) -> dict:
    import time

    params = fleet_params(args.params, command)
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    if workers < 0:
        raise InputError("--workers must be >= 0")
    if args.scheduler and args.workers is not None:
        raise InputError("--workers starts local workers; with --scheduler the cluster's workers are used")
    bags = expand_bags(args.bags)
    out = Path(args.out or f"fleet_{command}")
    t0 = time.perf_counter()
    load_command(SINGLE_BAG_COMMANDS[command])      # imported before any local worker forks: they inherit it
    entries = run_fleet(command, partial(run_single_bag, command), bags, args.params, out,
                        _single_bag_options(args, command), workers=workers, scheduler=args.scheduler,
                        progress=_bag_progress(args.progress))
    wall_s = time.perf_counter() - t0
    failed = [e for e in entries if not e["ok"]]
    summary = {"command": command, "bags": len(entries), "ok": len(entries) - len(failed), "failed": len(failed),
               "engine": args.scheduler or ("serial" if workers == 0 else f"LocalCluster({workers} processes)"),
               "wall_s": wall_s, "machine_type": params["machine_type"],
               "prior": {k: params[k] for k in ("wear_coefficient", "wear_coefficient_prior_rel_sd")}}
    rows = table_rows(command, entries, params["machine_type"])
    files = write_tables(out, rows, entries, summary)
    files["png"] = str(out / "fleet_ranking.png")
    plot_ranking(Path(files["png"]), rows, f"fleet {command}: {summary['ok']} of {len(entries)} bags")
    return {**summary, "exit_status": PARTIAL_EXIT_STATUS if failed else 0,
            "failed_bags": [{"bag": e["bag"], "error": e["error"]} for e in failed],
            "rows": rows, "files": files, "results": entries}


def _hours(value) -> str:
    return f"{value:.4g} h" if isinstance(value, float) else "not known"


def format_fleet_text(result: dict) -> str:
    lines = [f"fleet {result['command']}: {result['bags']} bags on {result['engine']} in {result['wall_s']:.1f} s, "
             f"{result['ok']} ok, {result['failed']} failed"]
    for row in result["rows"]:
        if row["status"] != "ok":
            continue
        if result["command"] == "replay" and row.get("kind") == "slewing":
            lines.append(f"  {row['machine']:<16} {row['level_name']:<5} fatigue {row['fatigue_governing_row']} row "
                         f"damage {row['fatigue_damage']:.3g}, remaining {row['fatigue_remaining_life_h']:.4g} h; "
                         f"S0 {row['static_safety_factor']:.3g}; to the clearance limit "
                         f"{_hours(row['raceway_wear_remaining_life_h'])}")
        elif result["command"] == "replay":
            lines.append(f"  {row['machine']:<16} {row['level_name']:<5} remaining life "
                         f"{row['remaining_life_h']:10.1f} h  (90 %: {row['remaining_life_h_low']:.1f} .. "
                         f"{row['remaining_life_h_high']:.1f} h)"
                         f"  K {row['wear_coefficient']:.4g}")
        else:
            lines.append(f"  {row['machine']:<16} K {row['wear_coefficient']:.4g}  effects: "
                         f"{row['named_effects'] or 'none'}")
    for bad in result["failed_bags"]:
        lines.append(f"  FAILED {bad['bag']}: {bad['error']}")
    lines.append(f"  files: {', '.join(result['files'].values())}")
    return "\n".join(lines)


FLEET_REPLAY = Command(lambda p: _add_fleet_arguments(p, "replay"), lambda a: run_fleet_command(a, "replay"),
                       format_fleet_text)
FLEET_DIAGNOSE = Command(lambda p: _add_fleet_arguments(p, "diagnose"), lambda a: run_fleet_command(a, "diagnose"),
                         format_fleet_text)


def add_trend_arguments(parser) -> None:
    parser.add_argument("history", metavar="HISTORY.db", help="fleet_monitor history_file (SQLite)")
    parser.add_argument("--machine", default=None, help="only this machine (hardware_id)")
    parser.add_argument("--days", type=float, default=None, help="only the last DAYS before the newest row")
    parser.add_argument("--out", default=None, help="output directory (default: <history>.trend beside it)")
    from guide_health.analysis.fleet_trend_report import DEFAULT_MACHINE_PLOTS

    parser.add_argument("--resolution", choices=RESOLUTIONS, default="auto",
                        help="rows: every history row; hourly: the history's hourly rows (figures keep each hour's "
                             "least and largest value, level changes stay exact); auto (default): hourly above "
                             f"{RAW_ROWS_MAX:,} rows in the window")

    parser.add_argument("--plots", type=int, default=DEFAULT_MACHINE_PLOTS, metavar="N",
                        help="per-machine figures for the first N machines of the ranking, least remaining life "
                             f"first (default {DEFAULT_MACHINE_PLOTS}; every machine keeps its CSV)")


def run_trend(args) -> dict:
    from guide_health.analysis.fleet_trend_report import write_trend_report

    if args.days is not None and not args.days > 0:
        raise InputError("--days must be > 0")
    if args.plots < 0:
        raise InputError("--plots must be >= 0")
    db = Path(args.history)
    out = Path(args.out) if args.out else db.with_name(db.name + ".trend")
    return write_trend_report(db, out, args.machine, args.days, args.plots, args.resolution)


def format_trend_text(result: dict) -> str:
    by_hour = " (read by the hour)" if result.get("resolution") == "hourly" else ""
    lines = [f"fleet trend: {result['machines']} machines, {result['rows']} status rows{by_hour} from "
             f"{result['history']}"]
    for r in result["ranking"]:
        lines.append(f"  {r['machine']:<16} {r['level']:<5} remaining life {r['remaining_life_h']:10.1f} h  "
                     f"straightness {r['straightness_um']:7.2f} um  {r['level_changes']} level changes")
    lines.append(f"  page: {result['files']['html']}")
    return "\n".join(lines)


FLEET_TREND = Command(add_trend_arguments, run_trend, format_trend_text)


def add_prior_arguments(parser) -> None:
    parser.add_argument("results", nargs="+", metavar="FLEET_JSON",
                        help="fleet.json of `fleet replay|diagnose` (or its output directory)")
    parser.add_argument("--machine-type", default=None,
                        help="the machine type (params machine_type; default: the only one in the results)")
    parser.add_argument("--params", default=None, metavar="BASE",
                        help="a new machine's own params file: the prior is checked loaded after it (nothing of "
                             "it is copied; optional)")
    parser.add_argument("--out", default="fleet_prior.yaml", help="params file to write (default fleet_prior.yaml)")
    parser.add_argument("--min-machines", type=int, default=3, help="fewest machines for a prior (default 3)")


def run_prior(args) -> dict:
    from guide_health.analysis.fleet_prior import fleet_prior, load_fleet_results, write_prior_params
    from guide_health.params import wear_monitor_params

    if args.min_machines < 2:
        raise InputError("--min-machines must be >= 2")
    base_type = wear_monitor_params(args.params)["machine_type"] if args.params else ""
    prior = fleet_prior(load_fleet_results(args.results), args.machine_type, args.min_machines)
    if base_type and base_type != prior["machine_type"]:
        raise InputError(f"{args.params}: machine_type '{base_type}', but the prior is of machine type "
                         f"'{prior['machine_type']}' (choose it with --machine-type)")
    out = Path(args.out)
    write_prior_params(out, prior)
    wear_monitor_params([args.params, out] if args.params else out)   # as a wear_monitor will read it: now
    write_text(out.with_suffix(".json"), json_text(prior, indent=1) + "\n")
    return {**prior, "files": {"params": str(out), "json": str(out.with_suffix(".json"))}}


def format_prior_text(r: dict) -> str:
    lk = r["log_k"]
    return "\n".join([
        f"fleet prior of machine type '{r['machine_type']}': {r['machines']} machines ({r['bags']} bags)",
        f"  log K population:  mu {lk['mean']:.4f} (median K {r['wear_coefficient_median']:.4g}), "
        f"tau {lk['tau']:.3f}, se(mu) {lk['mean_std_error']:.3f}",
        f"  new machine prior: wear_coefficient {r['wear_coefficient']:.4g}, "
        f"wear_coefficient_prior_rel_sd {r['wear_coefficient_prior_rel_sd']:.3f}",
        *[f"  effect {k}: mean {v['mean']:.4g}, tau {v['tau']:.3g} ({v['machines']} machines)"
          for k, v in r["effects"].items()],
        f"  files: {', '.join(r['files'].values())}",
    ])


FLEET_PRIOR = Command(add_prior_arguments, run_prior, format_prior_text)
