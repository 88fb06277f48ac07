"""`guide-health` command line: one module per sub-command under guide_health/commands/.

Every sub-command module defines ``add_arguments(parser)`` and ``run(args) -> dict``. With ``--json``
the returned dict is printed as exactly one JSON object on stdout; otherwise ``format_text(result)``
(when the module defines it) or an indented key/value listing. Progress and logs go to stderr.
Bad input raises :class:`guide_health.errors.InputError` and ends as one line on stderr, exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import sys

from guide_health.errors import InputError

# (command path, module, help)
COMMANDS: list[tuple[tuple[str, ...], str, str]] = [
    (("simulate",), "simulate", "write a rosbag2 bag of a simulated machine run"),
    (("replay",), "replay", "offline analysis of a bag with the live node's models"),
    (("diagnose",), "diagnose", "find and name the physics the model misses (discrepancy workflow)"),
    (("calibrate", "pin-on-disc"), "calibrate_pin_on_disc", "wear coefficient K from pin-on-disc rows"),
    (("contact", "slewing"), "contact_slewing", "slewing-bearing roller/raceway stresses"),
    (("contact", "rolling"), "contact_rolling", "rolling-guide ball/groove contact and lubrication"),
    (("life",), "life", "rating life, Miner consumption and C from life tests"),
]


def _jsonable(value):
    """numpy scalars/arrays to plain Python for json (NaN/inf stay floats: json writes NaN/Infinity)."""
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if np is not None:
        if isinstance(value, np.ndarray):
            return _jsonable(value.tolist())
        if isinstance(value, np.generic):
            return value.item()
    return value


def _format_plain(result: dict, indent: str = "") -> str:
    lines = []
    for key, value in result.items():
        if isinstance(value, dict):
            lines.append(f"{indent}{key}:")
            lines.append(_format_plain(value, indent + "  "))
        elif isinstance(value, float):
            lines.append(f"{indent}{key}: {value:.6g}" if math.isfinite(value) else f"{indent}{key}: {value}")
        else:
            lines.append(f"{indent}{key}: {value}")
    return "\n".join(lines)


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


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    parser = OneLineErrorParser(
        prog="guide-health",
        description="Guideway and slewing-bearing condition monitoring: models, bags and reports.",
    )
    top = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    groups: dict[str, argparse._SubParsersAction] = {}
    for path, module_name, help_text in COMMANDS:
        if len(path) == 1:
            sub = top.add_parser(path[0], help=help_text, description=help_text)
        else:
            if path[0] not in groups:
                group_parser = top.add_parser(path[0], help=f"{path[0]} sub-commands")
                groups[path[0]] = group_parser.add_subparsers(dest="subcommand", metavar="KIND", required=True)
            sub = groups[path[0]].add_parser(path[1], help=help_text, description=help_text)
        sub.set_defaults(_module=module_name)
        sub.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
        if not _selected(path, argv):
            continue
        try:
            module = importlib.import_module(f"guide_health.commands.{module_name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"guide_health.commands.{module_name}":
                raise
            sub.set_defaults(_missing=True)
            continue
        module.add_arguments(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if getattr(args, "_missing", False):
        print(f"guide-health: error: '{args.command}' is not available in this build", file=sys.stderr)
        return 2
    module = importlib.import_module(f"guide_health.commands.{args._module}")
    try:
        result = module.run(args)
    except InputError as exc:
        print(f"guide-health: error: {exc}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        print(f"guide-health: error: {exc.strerror}: {exc.filename}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("guide-health: interrupted", file=sys.stderr)
        return 130
    if result is None:
        return 0
    try:
        if args.json:
            json.dump(_jsonable(result), sys.stdout, allow_nan=True)
            sys.stdout.write("\n")
        else:
            formatter = getattr(module, "format_text", None)
            print(formatter(result) if formatter else _format_plain(_jsonable(result)))
        sys.stdout.flush()
    except BrokenPipeError:          # `guide-health ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
