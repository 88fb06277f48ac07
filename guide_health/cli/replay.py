"""`guide-health replay BAG --params FILE`: offline analysis of a bag with the live node's model objects
(guide_health/analysis/replay.py); a slewing bag goes through the slewing monitor core."""
from __future__ import annotations

import sys
from pathlib import Path

from guide_health.analysis.machine_replay import analyse_machine_bag, write_machine_outputs
from guide_health.analysis.rejections import rejection_lines, with_rejection_lines
from guide_health.analysis.replay import analyse_bag, analyse_slewing_bag, write_outputs, write_slewing_outputs
from guide_health.cli.command import Command, check_out_path
from guide_health.cli.text import bag_set_lines
from guide_health.errors import InputError
from guide_health.io.bag.bag_set import BagSet, resolve_bags
from guide_health.io.bag.info import is_slewing_bag
from guide_health.io.outputs.progress import ProgressBar
from guide_health.models.levels import LEVEL_NAMES
from guide_health.models.slewing.rating import ROWS
from guide_health.models.wear.fit_watch import parse_utc_ns, utc_text
from guide_health.models.wear.model_load import ModelLoadError
from guide_health.params import slewing_monitor_params_from, validate_wear_params, wear_monitor_params
from guide_health.params.machine import axes_params
from guide_health.params.typed import wear_axis_params


def add_arguments(parser) -> None:
    parser.add_argument("bag", nargs="+", help="rosbag2 directory (sqlite3 or mcap; split files are one bag), "
                                               "or several bags / a directory of bags, replayed in time order")
    parser.add_argument("--params", required=True, action="append",
                        help="ROS 2 parameters YAML (wear_monitor section); several merge in order, the later "
                             "overriding (e.g. --params BASE --params DIR/model.yaml from diagnose --out DIR)")
    parser.add_argument("--out", help="report directory (default: <bag>.report beside the bag)")
    parser.add_argument("--namespace", default=None, help="topic namespace in the bag (default: detect)")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    parser.add_argument("--progress", action="store_true", help="force the progress bar even without a TTY")
    parser.add_argument("--model-file", default=None,
                        help="a model file (e.g. diagnose --since's model.yaml) loaded over the running model at "
                             "--model-at, as wear_monitor's ~/load_model service loads it live")
    parser.add_argument("--model-at", default=None, metavar="DATE",
                        help="when --model-file is loaded (ISO 8601 UTC): the samples stamped at or before it "
                             "go through the model of --params, the rest through the loaded one (default: the "
                             "record's end)")


def report_dir(args, bag) -> Path:
    """--out, else <bag>.report beside the bag (several bags: beside the first one named)."""
    first = Path(args.bag[0]) if isinstance(bag, BagSet) else bag
    return check_out_path(args.out if args.out else first.with_name(first.name + ".report"))


def run_slewing(args, bag: Path) -> dict:
    """A slewing bag: every load through the slewing_monitor core; the worst roller of the run."""
    params = slewing_monitor_params_from(args.params)
    bar = ProgressBar("contact", force=args.progress)
    run, report, series, timing = analyse_slewing_bag(bag, params, namespace=args.namespace, progress=bar)
    bar.close()
    report.update(kind="slewing", read_s=timing["read_s"], model_s=timing["model_s"],
                  level_name=LEVEL_NAMES[int(report.get("level", 1))])
    write_slewing_outputs(report_dir(args, bag), run, params, report, series, plot=not args.no_plot)
    return report


#: --model-at not given: a stamp after any record (the model is loaded at its end)
LATE = 2 ** 62


def model_load(args, params: dict):
    """(at [ns], typed parameters of --params with --model-file merged) or None; one line when wrong."""
    if args.model_file is None:
        if args.model_at is not None:
            raise InputError("--model-at needs --model-file")
        return None
    if params["axes"]:
        raise InputError("--model-file: a single-axis parameters file (a machine of several axes: not yet)")
    merged = wear_monitor_params([*args.params, args.model_file])
    try:
        at = LATE if args.model_at is None else parse_utc_ns(args.model_at, "--model-at")
    except ValueError as exc:
        raise InputError(str(exc)) from None
    return at, wear_axis_params(merged)


def run(args) -> dict:
    bag = resolve_bags(args.bag)
    if isinstance(bag, BagSet):
        if any(is_slewing_bag(p) for p in bag.paths):
            raise InputError("several bags: a slewing bag replays one at a time")
    elif bag.exists() and is_slewing_bag(bag):
        return run_slewing(args, bag)
    params = wear_monitor_params(args.params)
    if params["axes"]:
        return run_machine_axes(args, bag, params)
    load = model_load(args, params)
    bar = ProgressBar("replay", force=args.progress)
    try:
        monitor, report, timing = analyse_bag(bag, params, namespace=args.namespace, progress=bar, load=load)
    except ModelLoadError as exc:
        raise InputError(f"--model-file {args.model_file}: {exc}") from None
    bar.close()
    if load is not None:
        report["model_loaded"] = {"file": args.model_file, "at_utc": utc_text(load[0]) if load[0] < LATE else "end"}
    t_read, t_model = timing["read_s"], timing["model_s"]
    out = report_dir(args, bag)
    if isinstance(bag, BagSet):
        report.update(bag.report())
    report["level_name"] = LEVEL_NAMES[report["level"]]
    report["read_s"] = t_read
    report["model_s"] = t_model
    report["files"] = write_outputs(out, monitor, report, plot=not args.no_plot)
    print(f"{report['messages']} messages in {t_read + t_model:.2f} s "
          f"({report['messages'] / max(t_read + t_model, 1e-9):,.0f} msg/s); report in {out}", file=sys.stderr)
    return report


def run_machine_axes(args, bag, params: dict) -> dict:
    """A machine of several axes: every axis through its AxisMonitor; ``axes`` in the report."""
    axes = axes_params(params, validate_wear_params)
    bar = ProgressBar("replay", force=args.progress)
    models, report = analyse_machine_bag(bag, axes, namespace=args.namespace, progress=bar)
    bar.close()
    out = report_dir(args, bag)
    if isinstance(bag, BagSet):
        report.update(bag.report())
    write_machine_outputs(out, models, report, plot=not args.no_plot)
    print(f"{report['messages']} messages, {len(axes)} axes in {report['model_s']:.2f} s; report in {out}",
          file=sys.stderr)
    return report


def format_machine_text(report: dict) -> str:
    lines = [f"machine {report['machine_id']} ({report['duration_h']:.2f} h, {report['messages']} messages): "
             f"{report['level_name']}: {report['message']}"]
    for axis, r in report["axes"].items():
        lines.append(f"  {axis}: straightness {r['straightness_um']:.2f} um (limit {r['straightness_limit_um']:.0f} "
                     f"um), remaining life {r['remaining_life_h']:.1f} h, K {r['wear_coefficient']:.4g}, "
                     f"{r['level_name']}")
    lines.extend(bag_set_lines(report, "  "))
    lines.append(f"  files: {', '.join(report['files'].values())}")
    first, last = [], []
    for axis, r in report["axes"].items():
        summary = r.get("rejections", {})
        (first if summary.get("leads") else last).extend(rejection_lines(summary, axis))
    return "\n".join(first + lines[:-1] + last + lines[-1:])


def format_text(report: dict) -> str:
    if "axes" in report:
        return format_machine_text(report)
    if report.get("kind") == "slewing":
        return format_slewing_text(report)
    return "\n".join(with_rejection_lines([
        f"guide precision report ({report['duration_h']:.2f} h, {report['messages']} messages)",
        f"  status:                {report['level_name']}: {report['message']}",
        f"  straightness (model):  {report['straightness_um']:.2f} um   (last measured "
        f"{report['straightness_measured_um']:.2f} um, limit {report['straightness_limit_um']:.0f} um)",
        f"  remaining life:        {report['remaining_life_h']:.1f} h   (90 %: "
        f"{report['remaining_life_h_low']:.1f} .. {report['remaining_life_h_high']:.1f} h)",
        f"  wear coefficient K:    {report['wear_coefficient']:.4g}   (configured "
        f"{report['wear_coefficient_configured']:.4g}, {report['measurements']} measurements)",
        f"  wear volume:           {report['wear_volume_mm3']:.3f} mm^3 over {report['sliding_distance_m']:.1f} m",
        f"  strokes:               {report['strokes']} between {report['stroke_min_m'] * 1e3:.1f} and "
        f"{report['stroke_max_m'] * 1e3:.1f} mm",
        *bag_set_lines(report, "  "),
        f"  files:                 {', '.join(report['files'].values())}",
    ], report.get("rejections", {})))


def format_slewing_text(report: dict) -> str:
    """The slewing report: the worst roller contact; with an axis angle in the bag also the fatigue damage and
    remaining life per row, the static safety, and with tilting-clearance readings the raceway wear."""
    nan = float("nan")
    lines = [
        f"slewing bearing report ({report['duration_h']:.2f} h, {report['messages']} loads)",
        f"  worst roller:      {report.get('p_max_MPa', nan):.0f} MPa at "
        f"{report.get('roller_load_max_n', nan) / 1e3:.1f} kN ({report['level_name']}: {report.get('message', '')})",
        f"  samples:           {report['samples_ok']} OK, {report['samples_warn']} WARN, "
        f"{report['samples_error']} ERROR, {report['rejected_loads']} rejected",
    ]
    if "fatigue_governing_row" in report:
        for row in ROWS:
            lines.append(f"  fatigue {row + ':':<13} damage {report[f'fatigue_damage_{row}']:.3g}, remaining "
                         f"{report[f'fatigue_remaining_life_{row}_h']:.4g} h")
        lines += [
            f"  governing row:     {report['fatigue_governing_row']} ({report['fatigue_message']}); "
            f"{report['oscillation_strokes']} strokes, {report['oscillation_strokes_below_critical']} below the "
            "critical angle",
            f"  static safety S0:  {report['static_safety_factor']:.3g} ({report['static_safety_row'] or '-'} row), "
            f"limiting curve {report['limiting_curve_safety']:.3g}",
        ]
    if report.get("tilting_clearance_measurements"):
        lines += [
            f"  tilting clearance: {report['tilting_clearance_predicted_mm']:.4f} mm predicted, "
            f"{report['tilting_clearance_measured_mm']:.4f} mm last measured "
            f"({report['tilting_clearance_measurements']} readings), limit "
            f"{report['tilting_clearance_limit_mm']:.3f} mm",
            f"  raceway wear k:    {report['raceway_wear_coefficient_m2_n']:.4g} m^2/N (90 %: "
            f"{report['raceway_wear_coefficient_low_m2_n']:.3g} .. {report['raceway_wear_coefficient_high_m2_n']:.3g})",
            f"  to the limit:      {report['raceway_wear_remaining_life_h']:.4g} h (90 %: "
            f"{report['raceway_wear_remaining_life_low_h']:.4g} .. "
            f"{report['raceway_wear_remaining_life_high_h']:.4g} h)",
        ]
    lines.append(f"  files:             {', '.join(report['files'].values())}")
    return "\n".join(lines)


REPLAY = Command(add_arguments, run, format_text)
