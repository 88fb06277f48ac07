"""`guide-health plan BAG --params BASE --params MODEL.yaml [--scenario TEXT ...] [--scenarios FILE.yaml]`:
replay the machine's bag with its model file, then the date each axis reaches its straightness limit at the
observed utilisation and under each scenario (models/wear/planning.py; docs/planning.md)."""
from __future__ import annotations

import sys
from pathlib import Path

from guide_health.analysis.machine_replay import analyse_machine_bag
from guide_health.analysis.plan_report import plan_axis, plan_table_text, scenarios_from_yaml, write_plan
from guide_health.analysis.replay import analyse_bag
from guide_health.cli.command import Command, check_out_path, value_errors_as_input_errors
from guide_health.errors import InputError
from guide_health.io.bag.bag_set import BagSet, resolve_bags
from guide_health.io.outputs.progress import ProgressBar
from guide_health.models.wear.planning import parse_scenario
from guide_health.params import validate_wear_params, wear_monitor_params
from guide_health.params.machine import axes_params


def add_arguments(parser) -> None:
    parser.add_argument("bag", nargs="+", help="rosbag2 directory of the machine's recent running (or several "
                                               "bags / a directory of bags, replayed in time order)")
    parser.add_argument("--params", required=True, action="append",
                        help="ROS 2 parameters YAML (wear_monitor section); several merge in order (e.g. "
                             "--params BASE --params DIR/model.yaml, the model file diagnose wrote)")
    parser.add_argument("--scenario", action="append", default=[],
                        help="a what-if: '[NAME:] key=value, ...' with load=, speed=, stroke= (scales), "
                             "relube= (interval: 250h, 2w), shift= (HOURSxDAYS: 8x5), regrind= (UTC date); "
                             "repeatable")
    parser.add_argument("--scenarios", help="YAML file of scenarios (docs/planning.md)")
    parser.add_argument("--out", help="output directory (default: <bag>.plan beside the bag)")
    parser.add_argument("--namespace", default=None, help="topic namespace in the bag (default: detect)")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.add_argument("--progress", action="store_true", help="force the progress bar even without a TTY")


def read_scenarios(args) -> list:
    """The --scenario texts, then the --scenarios file's; a bad one is a one-line InputError."""
    with value_errors_as_input_errors():
        scenarios = [parse_scenario(text) for text in args.scenario]
        if args.scenarios:
            import yaml

            try:
                data = yaml.safe_load(Path(args.scenarios).read_text())
            except yaml.YAMLError as exc:
                raise InputError(f"--scenarios {args.scenarios}: not YAML ({str(exc).splitlines()[0]})") from None
            scenarios += scenarios_from_yaml(data, f"--scenarios {args.scenarios}")
    return scenarios


def run(args) -> dict:
    scenarios = read_scenarios(args)
    bag = resolve_bags(args.bag)
    params = wear_monitor_params(args.params)
    machine = str(params["machine_id"])
    bar = ProgressBar("replay", force=args.progress)
    if params["axes"]:
        models, _ = analyse_machine_bag(bag, axes_params(params, validate_wear_params), namespace=args.namespace,
                                        progress=bar)
    else:
        monitor, _, _ = analyse_bag(bag, params, namespace=args.namespace, progress=bar)
        models = {monitor.axis.axis: monitor.axis}
    bar.close()
    with value_errors_as_input_errors():
        rows = [row for model in models.values() for row in plan_axis(machine, model, scenarios)]
    first = Path(args.bag[0]) if isinstance(bag, BagSet) else bag
    out = check_out_path(args.out if args.out else first.with_name(first.name + ".plan"))
    files = write_plan(out, machine, rows, plot=not args.no_plot)
    print(f"{len(rows)} rows ({len(scenarios) + 1} scenarios); plan in {out}", file=sys.stderr)
    return {"machine": machine, "rows": rows, "files": files}


def format_text(result: dict) -> str:
    return "\n".join([f"maintenance plan of machine {result['machine']} (limit date and 90 % band at each "
                      "scenario's utilisation)", plan_table_text(result["rows"]),
                      f"files: {', '.join(result['files'].values())}"])


PLAN = Command(add_arguments, run, format_text)
