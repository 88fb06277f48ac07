"""`guide-health diagnose BAG... --params FILE`: the discrepancy workflow on a machine bag (several bags: one
record in time order); on a machine of several axes per axis (``run_axes``)."""
from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

from guide_health.analysis.discrepancy.duty_process import start_duty_cells
from guide_health.analysis.discrepancy.naming_text import naming_lead_lines
from guide_health.analysis.rejections import add_diagnose_rejections, diagnose_lead_lines, diagnose_tail_lines
from guide_health.cli.command import Command, check_out_path
from guide_health.cli.text import bag_set_lines
from guide_health.errors import InputError
from guide_health.io.bag.bag_set import BagSet, resolve_bags, source_events
from guide_health.io.bag.info import is_slewing_bag
from guide_health.io.bag.reader import read_slewing_bag
from guide_health.io.outputs.files import write_text
from guide_health.io.outputs.json_text import json_text
from guide_health.io.outputs.progress import ProgressBar
from guide_health.models.wear.fit_watch import parse_utc_ns
from guide_health.models.wear.maintenance import relubrication_times_s, wear_resets
from guide_health.params import slewing_monitor_params_from, validate_wear_params, wear_monitor_params
from guide_health.params.machine import axes_params
from guide_health.params.typed import slewing_monitor_params


def add_arguments(parser) -> None:
    parser.add_argument("bag", nargs="+", help="rosbag2 directory (sqlite3 or mcap) with joint_states, guide/load, "
                                               "guide/straightness and optionally guide/temperature; or several "
                                               "bags / a directory of bags, read in time order as one record")
    parser.add_argument("--params", required=True, action="append",
                        help="ROS 2 parameters YAML (wear_monitor section); several merge in order, the later "
                             "overriding (as ROS merges several --params-file)")
    parser.add_argument("--out", help="report directory (default: <bag>.diagnose beside the bag)")
    parser.add_argument("--namespace", default=None, help="topic namespace in the bag (default: detect)")
    parser.add_argument("--heldout-fraction", type=float, default=0.25,
                        help="later share of the measurements kept out of every fit, for forecasts (default 0.25)")
    parser.add_argument("--bic-threshold", type=float, default=None,
                        help="BIC drop an effect must earn (default 10)")
    parser.add_argument("--axis", default=None,
                        help="the axis to diagnose on a machine of several axes (default: every axis)")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.add_argument("--progress", action="store_true", help="force the progress bar even without a TTY")
    parser.add_argument("--since", default=None, metavar="DATE",
                        help="analyse the period from DATE (ISO 8601 UTC, e.g. the status's model_fit_since_utc) "
                             "with the record before it as the baseline: names the change (a new wear rate, an "
                             "offset) and writes the model of the machine after it (docs/discrepancy.md)")
    parser.add_argument("--since-baseline", choices=("fit", "params"), default="fit",
                        help="--since's baseline K: fitted on the measurements before the change (default), or "
                             "the K of --params (the model the monitor ran with; A0 from --params when given)")


def run(args) -> dict:
    if not 0.0 <= args.heldout_fraction < 0.9:
        raise InputError("--heldout-fraction must be in [0, 0.9)")
    threshold = _bic_threshold(args.bic_threshold)
    bag = resolve_bags(args.bag)
    if not isinstance(bag, BagSet) and bag.exists() and is_slewing_bag(bag):
        return run_slewing(args, bag, threshold)
    params = wear_monitor_params(args.params)
    if params["straightness_model"] != "eq7":
        print("guide-health diagnose: the effects are defined against Eq. 7; straightness_model "
              f"{params['straightness_model']!r} is read as eq7", file=sys.stderr)
    if params["axes"]:
        if args.since is not None:
            raise InputError("--since: one axis at a time (a parameters file of that axis)")
        return run_axes(args, params, bag, threshold)
    axis = params.get("axis", params["joint"])
    if args.axis is not None and args.axis != axis:
        raise InputError(f"--axis {args.axis}: the parameters describe one axis, {axis} (set 'axes' for a machine)")
    if args.since is not None:
        return run_since(args, params, bag, axis, threshold)
    t0 = time.perf_counter()
    bar = ProgressBar("reading", force=args.progress)
    events = source_events(bag, args.namespace)
    # a large bag is read in a child process while this one imports the fit (about 1 s); the child then
    # imports matplotlib while this one fits, and draws the PNG
    pending = start_duty_cells(bag, params, args.namespace, bar, plot=not args.no_plot,
                               resets=wear_resets(events, axis))
    from guide_health.analysis.discrepancy.model_file import write_model_file
    from guide_health.analysis.discrepancy.report import write_report

    try:
        result, out, t1 = _diagnose(args, params, bag, events, pending, bar, threshold, t0)
        result["files"] = write_report(result, out, bag=str(bag), with_plot=not args.no_plot,
                                       plot_with=pending.plot)
    finally:
        pending.close()
    result["files"]["model"] = str(out / "model.yaml")
    structure = result.get("unexplained_structure", {})
    write_model_file(out / "model.yaml", params, result["model_file"], result["named_effects"], source=str(bag),
                     unexplained=structure.get("message", "") if structure.get("present") else "",
                     left_out=tuple(e for e, c in result["effects"].items() if not c.get("in_model_file", True)))
    result["report_s"] = time.perf_counter() - t1
    result["total_s"] = time.perf_counter() - t0
    result.pop("series")
    print(f"{result['messages']} messages read in {result['read_s']:.1f} s, fitted in {result['fit_s']:.1f} s; "
          f"report in {out}",
          file=sys.stderr)
    return result


def _diagnose(args, params: dict, bag, events: list, pending, bar, threshold, t0: float):
    """The cells (from ``pending``) through the workflow: (result, report directory, time the report starts)."""
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD
    from guide_health.analysis.discrepancy.workflow import diagnose_cells

    threshold = BIC_THRESHOLD if threshold is None else threshold
    cells, messages = pending.result()
    bar.close()
    t_read = time.perf_counter() - t0
    # recorded relubrications (maintenance events in the bag): the relubrication effect's time base
    relube = relubrication_times_s(events, params.get("axis", params["joint"]), cells.t0_ns)
    try:
        result = diagnose_cells(cells, params, heldout_fraction=args.heldout_fraction, bic_threshold=threshold,
                                relubrication_t_s=relube, workers=_fit_workers())
    except ValueError as exc:
        raise InputError(f"{bag}: {exc}") from None
    result["messages"] = messages
    add_diagnose_rejections(result, cells.rejected_samples, cells.inputs, params)
    result["read_s"] = t_read
    if isinstance(bag, BagSet):
        result.update(bag.report())
    return result, report_dir(args), time.perf_counter()


def run_since(args, params: dict, bag, axis: str, threshold) -> dict:
    """``--since DATE``: analysis/discrepancy/since.py on the record's duty cells; DIR/since.json and the
    model of the machine after the change, DIR/model.yaml."""
    from guide_health.analysis.discrepancy.duty import read_duty_cells
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD
    from guide_health.analysis.discrepancy.since import diagnose_since, write_since_model_file

    t0 = time.perf_counter()
    try:
        since_ns = parse_utc_ns(args.since)
        cells, messages = read_duty_cells(bag, params, args.namespace,
                                          resets=wear_resets(source_events(bag, args.namespace), axis))
        result = diagnose_since(cells, params, since_ns, BIC_THRESHOLD if threshold is None else threshold,
                                args.since_baseline)
    except ValueError as exc:
        raise InputError(f"{bag}: {exc}") from None
    out = report_dir(args)
    out.mkdir(parents=True, exist_ok=True)
    result.update(messages=messages, files={"json": str(out / "since.json"), "model": str(out / "model.yaml")})
    write_since_model_file(out / "model.yaml", params, result, source=str(bag))
    result["total_s"] = time.perf_counter() - t0
    write_text(out / "since.json", json_text(result, indent=1))
    return result


def run_slewing(args, bag: Path, threshold) -> dict:
    """A slewing bag (``--params``: the slewing_monitor section): which raceway-wear effect the tilting-clearance
    readings call for (analysis/slewing_diagnose.py); DIR/report.json and DIR/report.md."""
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD
    from guide_health.analysis.slewing_diagnose import diagnose_slewing, slewing_diagnose_lines

    if args.since is not None or args.axis is not None:
        raise InputError("--since and --axis are for machine bags; a slewing bag is diagnosed whole")
    t0 = time.perf_counter()
    params = slewing_monitor_params_from(args.params)
    typed = slewing_monitor_params(params)
    run = read_slewing_bag(bag, namespace=args.namespace, axis_topic=typed.axis_topic, axis_joint=typed.axis_joint)
    try:
        result = diagnose_slewing(run, params, BIC_THRESHOLD if threshold is None else threshold)
    except ValueError as exc:
        raise InputError(f"{bag}: {exc}") from None
    out = report_dir(args)
    out.mkdir(parents=True, exist_ok=True)
    result["files"] = {"json": str(out / "report.json"), "md": str(out / "report.md")}
    result["total_s"] = time.perf_counter() - t0
    write_text(out / "report.md", "# Slewing bearing: diagnose\n\n```\n" + "\n".join(slewing_diagnose_lines(result))
               + "\n```\n")
    write_text(out / "report.json", json_text(result, indent=1) + "\n")
    return result


def report_dir(args) -> Path:
    """--out, else <bag>.diagnose beside the (first) bag named."""
    first = Path(args.bag[0])
    return check_out_path(args.out if args.out else first.with_name(first.name + ".diagnose"))


def _fit_workers() -> int:
    """Processes for the candidate fits: 2 on a multi-core Linux machine when nothing else runs in this
    process (a fork copies only the calling thread), else 1."""
    import threading

    return 2 if sys.platform.startswith("linux") and (os.cpu_count() or 1) >= 2 and threading.active_count() == 1 else 1


def _bic_threshold(value: float | None) -> float | None:
    """The --bic-threshold given (None: the default, known once the selection is imported), checked."""
    if value is not None and not (math.isfinite(value) and value >= 0):
        raise InputError("--bic-threshold must be a number >= 0")
    return value


def format_text(result: dict) -> str:
    if result.get("kind") == "slewing":
        from guide_health.analysis.slewing_diagnose import slewing_diagnose_lines

        return "\n".join(slewing_diagnose_lines(result) + [f"  files: {', '.join(result['files'].values())}"])
    if "change" in result:
        from guide_health.analysis.discrepancy.since import since_text_lines

        return "\n".join(since_text_lines(result) + [f"  files: {', '.join(result['files'].values())}"])
    if "axes" in result:
        return format_axes_text(result)
    model = any(str(f).endswith("model.yaml") for f in result["files"].values())
    return "\n".join(axis_text_lines(result, model) + bag_set_lines(result, "  ")
                     + [f"  files:           {', '.join(result['files'].values())}"])


def axis_text_lines(result: dict, model_file: bool) -> list[str]:
    """The text of one axis's workflow result (without the file list; ``model_file``: with its model.yaml)."""
    b, f = result["baseline"], result["final"]
    named = result["named_effects"]
    structure = result.get("unexplained_structure", {})
    lines = diagnose_lead_lines(result) + ([structure["message"]] if structure.get("present") else [])
    lines += naming_lead_lines(result)
    lines.append(f"discrepancy workflow ({result['data']['duration_h']:.1f} h, {result['data']['measurements']} "
                 f"measurements, {result['messages']} messages)")
    withheld = ("too little data" if result.get("data_resolution", {}).get("too_little_data") else
                "rejected input could explain the misfit" if result.get("rejected_wear", {}).get("explains_misfit")
                else "")
    if structure.get("present") and not (withheld and not named):
        lines.append(f"  fitted effects:  {', '.join(named) if named else 'none'} (NOT an explanation: structure "
                     "remains)")
    else:
        why = withheld or "the baseline explains the data"
        lines.append(f"  named effects:   {', '.join(named) if named else f'none ({why})'}")
    for e in named:
        params = ", ".join(f"{k} = {p['value']:.4g} ± {p['std_error']:.2g}"
                           for k, p in result["effects"][e]["parameters"].items())
        status = f" ({result['effects'][e]['status']})" if "status" in result["effects"][e] else ""
        lines.append(f"    {e}{status}: {params}")
    for tie in result.get("near_ties", []):
        lines.append(f"  near-tie:        {tie['message']}")
    for d in result.get("dropped_by_backward_pass", []):
        lines.append(f"  dropped:         {d['effect']} (backward pass, BIC +{d['delta_bic']:.1f} without it)")
    lines.append(f"  RMSE fit:        {b['rmse_um']:.3f} -> {f['rmse_um']:.3f} um")
    lines.append(f"  RMSE held out:   {b['heldout_rmse_um']:.3f} -> {f['heldout_rmse_um']:.3f} um")
    lines.append(f"  max rel. error:  {b['max_rel_error']:.2%} -> {f['max_rel_error']:.2%} (fit), "
                 f"{b['heldout_max_rel_error']:.2%} -> {f['heldout_max_rel_error']:.2%} (held out)")
    where = result["where_baseline_disagrees"]
    if where["systematic_conditions"]:
        lines.append(f"  baseline residuals follow: {', '.join(where['systematic_conditions'])}")
    if "steady_stage" in result:
        s = result["steady_stage"]
        lines.append(f"  steady stage (from {s['from_h']:.1f} h): max rel. error {s['baseline_max_rel_error']:.1%} -> "
                     f"{s['final_max_rel_error']:.1%}")
    if "read_s" in result:          # one axis (several axes: the machine's read time)
        lines.append(f"  time:            read {result['read_s']:.1f} s, fit {result['fit_s']:.1f} s")
    if model_file:
        from guide_health.analysis.discrepancy.model_file import live_parameter_text

        lines.append(f"  model.yaml:      {live_parameter_text(result['model_file'])} (refitted on every measurement)")
    lines += diagnose_tail_lines(result)
    return lines



# --- a machine of several axes ---------------------------------------------------------------------------
def chosen_axes(axes: dict, axis: str | None) -> list[str]:
    """Every axis, or ``--axis``; InputError (one line naming the axes present) for an unknown one."""
    if axis is None:
        return list(axes)
    if axis not in axes:
        raise InputError(f"--axis {axis}: no such axis (axes present: {', '.join(axes)})")
    return [axis]


def check_counts(cells: dict) -> None:
    """InputError naming the axis and every axis's count when one has too few straightness measurements."""
    from guide_health.analysis.discrepancy.model import MIN_MEASUREMENTS

    counts = {axis: int(c.measurement_m.size) for axis, c in cells.items()}
    short = [axis for axis, n in counts.items() if n < MIN_MEASUREMENTS]
    if short:
        per_axis = ", ".join(f"{a}: {n}" for a, n in counts.items())
        raise InputError(f"axis {short[0]} has {counts[short[0]]} straightness measurements, the discrepancy workflow "
                         f"needs at least {MIN_MEASUREMENTS} per axis ({per_axis}; choose an axis with --axis)")


def read_axes(args, axes: dict, chosen: list[str], bag, events: list) -> tuple[dict, dict]:
    """Duty cells and messages read per chosen axis (one pass each over the bag), one progress bar."""
    from guide_health.analysis.discrepancy.duty import read_duty_cells
    from guide_health.analysis.machine_replay import axis_topics

    bar = ProgressBar("reading", force=args.progress)
    cells, messages = {}, {}
    for k, axis in enumerate(chosen):
        def progress(done, total, k=k):
            bar(k * total + done, len(chosen) * total)
        cells[axis], messages[axis] = read_duty_cells(bag, axes[axis], args.namespace, progress,
                                                      resets=wear_resets(events, axis), topics=axis_topics(axes[axis]))
    bar.close()
    return cells, messages


def run_axes(args, params: dict, bag, threshold) -> dict:
    """A machine of several axes (``axes``): the workflow per axis on the axis's own topics, with its wear
    resets (regrind, new rail) splitting its record; ``--axis`` chooses one. The report holds
    ``axes: {axis: <the single-axis result>}``."""
    from guide_health.analysis.discrepancy.model_file import write_axes_model_file
    from guide_health.analysis.discrepancy.report import write_axes_report
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD
    from guide_health.analysis.discrepancy.workflow import diagnose_cells

    axes = axes_params(params, validate_wear_params)
    chosen = chosen_axes(axes, args.axis)
    t0 = time.perf_counter()
    events = source_events(bag, args.namespace)
    cells, messages = read_axes(args, axes, chosen, bag, events)
    check_counts(cells)
    t_read = time.perf_counter() - t0
    results = {}
    for axis in chosen:
        try:
            results[axis] = diagnose_cells(
                cells[axis], axes[axis], heldout_fraction=args.heldout_fraction,
                bic_threshold=BIC_THRESHOLD if threshold is None else threshold,
                relubrication_t_s=relubrication_times_s(events, axis, cells[axis].t0_ns), workers=_fit_workers())
        except ValueError as exc:
            raise InputError(f"{bag}: axis {axis}: {exc}") from None
        results[axis].update(axis=axis, messages=messages[axis])
        add_diagnose_rejections(results[axis], cells[axis].rejected_samples, cells[axis].inputs, axes[axis])
        if cells[axis].reset_t_s.size:
            results[axis]["data"]["wear_resets"] = [
                {"t_h": float(t / 3600.0), "straightness_after_um": float(a * 1e6)}
                for t, a in zip(cells[axis].reset_t_s, cells[axis].reset_straightness_m)]
    t_fit = time.perf_counter() - t0 - t_read
    out = report_dir(args)
    report = {"machine_id": params["machine_id"], "axes": results, "read_s": t_read, "fit_s": t_fit,
              **(bag.report() if isinstance(bag, BagSet) else {})}
    report["files"] = write_axes_report(report, out, bag=str(bag), with_plot=not args.no_plot)
    report["files"]["model"] = str(out / "model.yaml")
    write_axes_model_file(out / "model.yaml", axes, {a: r["model_file"] for a, r in results.items()},
                          {a: r["named_effects"] for a, r in results.items()}, source=str(bag),
                          unexplained={a: r["unexplained_structure"].get("message", "") for a, r in results.items()
                                       if r["unexplained_structure"].get("present")})
    for r in results.values():
        r.pop("series")
    report["total_s"] = time.perf_counter() - t0
    return report


def format_axes_text(report: dict) -> str:
    lines = [f"machine {report['machine_id']}: discrepancy workflow per axis"]
    for axis, result in report["axes"].items():
        lines.append(f"axis {axis}:")
        lines.extend("  " + line for line in axis_text_lines(result, model_file=True))
    lines.extend(bag_set_lines(report, "  "))
    lines.append(f"  time:  read {report['read_s']:.1f} s, fit {report['fit_s']:.1f} s")
    lines.append(f"  files: {', '.join(report['files'].values())}")
    return "\n".join(lines)

DIAGNOSE = Command(add_arguments, run, format_text)
