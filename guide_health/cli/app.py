"""The `guide-health` argparse tree and ``main``: one Command per sub-command in the modules of this package.

Every sub-command is a :class:`guide_health.cli.command.Command`: options, run(args) -> dict, and an
optional format_text. With ``--json`` the returned dict is printed as exactly one JSON object on stdout;
otherwise ``format_text(result)`` (when the command has one) or an indented key/value listing. Progress and
logs go to stderr. Bad input raises :class:`guide_health.errors.InputError` and ends as one line on
stderr, exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings

from guide_health.cli.command import FILE_OUTPUTS, Command, check_out_path
from guide_health.cli.text import format_key_values, jsonable
from guide_health.errors import InputError
from guide_health.io.outputs.json_text import json_text

# (command path, "module:Command" in guide_health.cli, help)
COMMANDS: list[tuple[tuple[str, ...], str, str]] = [
    (("simulate",), "simulate:SIMULATE", "write a rosbag2 bag of a simulated machine run"),
    (("replay",), "replay:REPLAY", "offline analysis of a bag with the live node's models"),
    (("plan",), "plan:PLAN", "limit dates at the observed utilisation and under what-if scenarios"),
    (("diagnose",), "diagnose:DIAGNOSE", "find and name the physics the model misses (discrepancy workflow)"),
    (("calibrate", "pin-on-disc"), "calibrate:PIN_ON_DISC", "wear coefficient K from pin-on-disc rows"),
    (("contact", "slewing"), "contact:SLEWING", "slewing-bearing roller/raceway stresses"),
    (("contact", "rolling"), "contact:ROLLING", "rolling-guide ball/groove contact and lubrication"),
    (("life",), "life:LIFE", "rating life, Miner consumption and C from life tests"),
    (("fleet", "replay"), "fleet:FLEET_REPLAY", "replay many bags on Dask: one report each, a fleet table"),
    (("fleet", "diagnose"), "fleet:FLEET_DIAGNOSE", "diagnose many bags on Dask: one report each, a fleet table"),
    (("fleet", "plan"), "fleet_plan:FLEET_PLAN", "machines/axes due for a regrind within a horizon, grouped stops"),
    (("fleet", "prior"), "fleet:FLEET_PRIOR", "K prior of a machine type from its replayed/diagnosed machines"),
    (("fleet", "trend"), "fleet:FLEET_TREND", "per-machine trends and an HTML page from the fleet_monitor history"),
    (("maintenance",), "maintenance:MAINTENANCE", "enter a maintenance event on a running wear_monitor (rclpy)"),
]


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line (INTERFACES.md: one-line error, non-zero exit)."""

    def error(self, message: str):  # noqa: D401
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _selected(path: tuple[str, ...], argv: list[str] | None) -> bool:
    """Is `path` the command named by argv? (None: all.) Only that command's module is imported, so
    `guide-health replay` does not pay for the imports of every other sub-command."""
    if argv is None:
        return True
    words = [a for a in argv if not a.startswith("-")][:len(path)]
    return words[:1] == [path[0]] and (len(words) < 2 or words[1] == path[1])


def load_command(target: str) -> Command:
    """The Command named ``module:NAME`` (module in guide_health.cli)."""
    module_name, name = target.split(":")
    return getattr(importlib.import_module(f"guide_health.cli.{module_name}"), name)


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    parser = OneLineErrorParser(
        prog="guide-health",
        description="Guideway and slewing-bearing condition monitoring: models, bags and reports.",
    )
    top = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    groups: dict[str, argparse._SubParsersAction] = {}
    for path, target, help_text in COMMANDS:
        if len(path) == 1:
            sub = top.add_parser(path[0], help=help_text, description=help_text)
        else:
            if path[0] not in groups:
                group_parser = top.add_parser(path[0], help=f"{path[0]} sub-commands")
                groups[path[0]] = group_parser.add_subparsers(dest="subcommand", metavar="KIND", required=True)
            sub = groups[path[0]].add_parser(path[1], help=help_text, description=help_text)
        sub.set_defaults(_command=target)
        sub.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
        if not _selected(path, argv):
            continue
        module_name = f"guide_health.cli.{target.split(':')[0]}"
        try:
            command = load_command(target)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
            sub.set_defaults(_missing=True)
            continue
        command.add_arguments(sub)
    return parser


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning of a command (skipped messages, stale bag metadata) as one line on stderr."""
    print(f"guide-health: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if getattr(args, "_missing", False):
        print(f"guide-health: error: '{args.command}' is not available in this build", file=sys.stderr)
        return 2
    command = load_command(args._command)
    warnings.showwarning = _warning_line
    try:
        if getattr(args, "out", None):
            check_out_path(args.out, directory=args._command not in FILE_OUTPUTS)
        result = command.run(args)
    except InputError as exc:
        print(f"guide-health: error: {exc}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        print(f"guide-health: error: {exc.strerror}: {exc.filename}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("guide-health: interrupted", file=sys.stderr)
        return 130
    if result is not None:
        print_result(command, result, as_json=args.json)
    # a command that completed in part (fleet: some bags failed) says so in its result
    return int(result.get("exit_status", 0)) if isinstance(result, dict) else 0


def print_result(command: Command, result: dict, as_json: bool) -> None:
    """One JSON object, or the command's text (an indented key/value listing when it has none)."""
    try:
        if as_json:
            sys.stdout.write(json_text(result) + "\n")
        else:
            text = command.format_text(result) if command.format_text else format_key_values(jsonable(result))
            print(text)
        sys.stdout.flush()
    except BrokenPipeError:          # `guide-health ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
