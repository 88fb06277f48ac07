"""The node's own check of its ``--ros-args`` parameters, before rcl reads them (pure Python, no ROS).

rcl ignores a parameter a node does not declare, and a node section it does not find (a file written for
``wear_monitor:`` silently gives defaults to ``/m1/wear_monitor``); its YAML errors end as an RCLError
traceback. ``read_ros_args`` reads the same ``--params-file`` files (and ``-p name:=value`` overrides)
with the strict loader of the offline CLI and the node's full name (``-r __ns:=``, ``-r __node:=``),
merges them in rcl's order (files, then ``-p``, later wins) and validates the result: any failure is one
InputError line naming the file, the node and the key; a file none of whose sections applies to the
node's full name is such a failure.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from guide_health.errors import InputError
from guide_health.params.loader import ROS_NODE_PARAMS, clip_values, load_node_params
from guide_health.params.machine import axes_params, axis_default, check_axis_keys, coerce_axis_value
from guide_health.params.rcl_yaml import read_value_text
from guide_health.params.schema import NodeSchema, coerce_value


def _ros_arg_groups(argv: list[str]) -> list[list[str]]:
    """The argument lists between ``--ros-args`` and ``--`` (or the end)."""
    groups, current = [], None
    for arg in argv:
        if arg == "--ros-args":
            current = []
            groups.append(current)
        elif arg == "--" and current is not None:
            current = None
        elif current is not None:
            current.append(arg)
    return groups


def parse_ros_args(argv: list[str], node_name: str) -> tuple[str, list[str], list[tuple[str, str]]]:
    """(node name after ``__node:=`` remapping, params files, [(name, value text)] of ``-p``)."""
    files: list[str] = []
    overrides: list[tuple[str, str]] = []
    name = node_name
    for group in _ros_arg_groups(argv):
        it = iter(group)
        for arg in it:
            if arg == "--params-file":
                files.append(next(it, ""))
            elif arg in ("-p", "--param"):
                overrides.append(tuple(next(it, "").split(":=", 1)) + ("",))   # type: ignore[arg-type]
            elif arg in ("-r", "--remap"):
                rule = next(it, "")
                if rule.split(":=")[0].split(":")[-1] == "__node" and ":=" in rule:
                    name = rule.split(":=", 1)[1]
    return name, files, [(o[0], o[1]) for o in overrides]


def node_full_name(argv: list[str], node_name: str) -> str:
    """The node's fully qualified name after ``-r __ns:=`` and ``-r __node:=`` (``/m1/wear_monitor``)."""
    name, namespace = node_name, "/"
    for group in _ros_arg_groups(argv):
        it = iter(group)
        for arg in it:
            if arg in ("-r", "--remap"):
                rule = next(it, "")
                target, _, value = rule.partition(":=")
                if value and target.split(":")[-1] == "__node":
                    name = value
                elif value and target.split(":")[-1] == "__ns":
                    namespace = "/" + value.strip("/")
    return namespace.rstrip("/") + "/" + name


@dataclass
class RosArgs:
    """What the node's ``--ros-args`` hold: its full name, the merged parameters (None without files or
    ``-p``) and the (file, section) pairs applied, in order."""
    fqn: str
    params: dict | None = None
    applied: list = field(default_factory=list)
    overrides: list = field(default_factory=list)


def check_ros_args(schema: NodeSchema, argv: list[str]) -> dict[str, Any] | None:
    """The node's parameters from its ``--params-file``/``-p`` arguments, strictly loaded and validated;
    None when there are none. InputError (one line) on anything rcl would ignore or choke on."""
    return read_ros_args(schema, argv).params


def read_ros_args(schema: NodeSchema, argv: list[str]) -> RosArgs:
    """:func:`check_ros_args` with the node's full name and the sections applied (the start-up line)."""
    node_name, files, overrides = parse_ros_args(argv, schema.section)
    result = RosArgs(node_full_name(argv, schema.section))
    if not files and not overrides:
        return result
    params = schema.defaults()
    for path in files:
        if not path:
            raise InputError("--params-file needs a file name")
        # over the files before it, as rcl does
        params = load_node_params(path, node_name, params, fqn=result.fqn, applied=result.applied)
    try:
        _apply_overrides(schema, node_name, overrides, params, result)
    except InputError as exc:
        raise clip_values(exc, [text for _, text in overrides] + [f"{i}:={t}" for i, t in overrides]) from None
    try:
        schema.validate(params)
        if schema.section == "wear_monitor":
            axes_params(params, schema.validate)
    except InputError as exc:
        where = ", ".join(files) if files else "-p"
        raise InputError(f"{where}: {clip_values(exc, list(params.values()))}") from None
    result.params = params
    return result


def _apply_overrides(schema: NodeSchema, node_name: str, overrides: list, params: dict, result: RosArgs) -> None:
    """``-p [node:]name:=value`` over the files' values, typed as rcl types them."""
    for item, text in overrides:
        target, _, name = item.rpartition(":")
        if target and target.rstrip("/").split("/")[-1] != node_name:
            continue                                  # -p other_node:name:=value
        if name in ROS_NODE_PARAMS:
            continue
        value = read_value_text(text, f"-p {item}")
        result.overrides.append(f"{item}:={text}")
        if "." in name:                                # a per-axis parameter (params/machine.py)
            check_axis_keys(schema.section, [name], list(params.get("axes") or []), schema,
                            source=f"-p {item}:={text}")
            params[name] = coerce_axis_value(name, value, axis_default(name.partition(".")[2], schema))
            continue
        schema.check_unknown_keys([name], source=f"-p {item}:={text}")
        params[name] = coerce_value(name, value, schema.by_name[name].default)
