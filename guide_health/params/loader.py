"""ROS 2 parameters YAML files, read strictly (the only file I/O of guide_health.params).

One file (``<node>: ros__parameters: {...}``, ``/**`` wildcard allowed) drives both the node and
``guide-health ... --params FILE``, so live and offline results come from the same numbers. The node checks
its ``--params-file`` arguments with the same loader before rcl reads them (``ros_args.py``).

Strict by default, so that a typo never goes unnoticed:

* the node's own section may hold only the node's declared parameters (and ROS's own, e.g. ``use_sim_time``):
  an unknown name is an error naming the closest declared one;
* a ``/**`` section may hold only names some guide_health schema declares (it applies to every node);
* a section for the node (or ``/**``) whose only key is not ``ros__parameters`` (``ros__parameter``) is an
  error; other tools' sections in the same file are left alone;
* a file with no section for the node is an error where the command needs that node's parameters
  (``required``), naming a close section name if there is one (``wear_monitr``).
"""
from __future__ import annotations

import difflib
import logging
from pathlib import Path
from typing import Any

import yaml

from guide_health.errors import InputError
from guide_health.params.machine import axes_params, axis_default, check_axis_keys, coerce_axis_value, flatten
from guide_health.params.schema import check_unknown_keys, coerce_value
from guide_health.params.schemas import SCHEMAS, schema_for
from guide_health.params.simulation import SIMULATION_SCHEMA
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA, hardness_units_warning, validate_wear_params

#: parameters every rclpy node has (or reads) besides its schema's: accepted in any section, not returned
ROS_NODE_PARAMS = ("use_sim_time", "start_type_description_service", "qos_overrides")


def _load_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"parameters file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text(encoding="utf8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"parameters file {path} cannot be read: {exc}".splitlines()[0]) from None
    except yaml.YAMLError as exc:
        raise InputError(" ".join(f"parameters file {path} is not valid YAML: {exc}".split())) from None
    if not isinstance(data, dict):
        raise InputError(f"parameters file {path} holds no '<node>: ros__parameters:' mapping")
    return data


def _section_params(path: Path, key: str, section: Any) -> dict:
    """The ``ros__parameters`` mapping of one section for this node; InputError for a misspelt key."""
    if not isinstance(section, dict):
        raise InputError(f"{path}: section '{key}' has no 'ros__parameters' mapping")
    extra = [str(k) for k in section if k != "ros__parameters"]
    if extra:
        close = difflib.get_close_matches(extra[0], ["ros__parameters"], n=1, cutoff=0.6)
        hint = " (did you mean 'ros__parameters'?)" if close else ""
        raise InputError(f"{path}: section '{key}' has an unknown key '{extra[0]}'{hint}")
    params = section.get("ros__parameters", {})
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise InputError(f"{path}: section '{key}': 'ros__parameters' is not a mapping")
    return params


def _all_known_names() -> set[str]:
    return {name for schema in SCHEMAS.values() for name in schema.by_name}


def node_sections(path: str | Path, node_name: str, required: bool = True) -> list[tuple[str, dict]]:
    """The (section key, ros__parameters) entries of ``path`` that apply to ``node_name``, ``/**`` first.

    A key applies when it is ``/**`` or its last ``/``-part is the node name (``/m1/wear_monitor``,
    ``/**/wear_monitor``). ``required``: InputError when none applies."""
    path = Path(path)
    data = _load_yaml(path)
    sections = []
    for key, section in data.items():
        base = str(key).rstrip("/").split("/")[-1]
        if key == "/**" or base == node_name:
            sections.append((0 if key == "/**" else 1, str(key), _section_params(path, str(key), section)))
    if not sections and required:
        bases = [str(k).rstrip("/").split("/")[-1] for k in data]
        close = difflib.get_close_matches(node_name, bases, n=1, cutoff=0.7)
        hint = f" (did you mean '{close[0]}'? it is read as another tool's section)" if close else ""
        raise InputError(f"{path}: no section for node '{node_name}'{hint}; "
                         f"expected '{node_name}: ros__parameters: ...'")
    return [(key, params) for _, key, params in sorted(sections, key=lambda s: s[0])]


def load_node_params(path: str | Path | None, node_name: str, defaults: dict[str, Any],
                     strict: bool = True, required: bool = True) -> dict[str, Any]:
    """Parameters of ``node_name`` from a ROS 2 parameters YAML, merged over ``defaults`` (see the module
    text for what ``strict`` and ``required`` refuse). ``strict=False`` keeps unknown names (old behaviour,
    for a caller that reads only a few names of a section)."""
    params = dict(defaults)
    if path is None:
        return params
    for key, section in node_sections(path, node_name, required):
        section = flatten(section)     # nested mappings (per-axis parameters) as rcl reads them: 'x.name'
        names = [name for name in section if name not in ROS_NODE_PARAMS and "." not in name]
        if strict:
            known = list(defaults) if key != "/**" else sorted(_all_known_names() | set(defaults))
            source = str(path) if key != "/**" else f"{path}: section '/**'"
            check_unknown_keys(node_name, names, known, source=source)
        for name in names:
            value = section[name]
            params[name] = coerce_value(name, value, defaults[name]) if name in defaults else value
        _axis_values(path, node_name, section, params, defaults, strict)
    return params


def _axis_values(path, node_name: str, section: dict, params: dict, defaults: dict, strict: bool) -> None:
    """The dotted per-axis names of a section (params/machine.py): checked against ``axes`` (or, for the
    simulation section, which has no axes list, any axis name) and coerced by their parameter's type."""
    dotted = [name for name in section if "." in name and name.partition(".")[2] not in ROS_NODE_PARAMS]
    if not dotted:
        return
    schema = schema_for(node_name)
    axes = list(params["axes"]) if "axes" in params else sorted({n.partition(".")[0] for n in dotted})
    if strict:
        check_axis_keys(node_name, dotted, axes, schema, source=str(path))
    for name in dotted:
        default = axis_default(name.partition(".")[2], schema)
        params[name] = coerce_axis_value(name, section[name], default)


def wear_monitor_params(path: str | Path | list | tuple | None) -> dict[str, Any]:
    """wear_monitor parameters, validated (positive sizes, known model names, declared ranges). Several files
    (``--params BASE --params DIR/model.yaml``) merge in order, the later overriding, as rcl merges several
    ``--params-file``; the merged result is validated once."""
    paths = [path] if path is None or isinstance(path, (str, Path)) else list(path)
    p = WEAR_MONITOR_SCHEMA.defaults()
    for one in paths:
        p = load_node_params(one, WEAR_MONITOR_SCHEMA.section, p)
    named = None if paths == [None] else ", ".join(str(one) for one in paths)
    _validate_from(named, WEAR_MONITOR_SCHEMA.section, validate_wear_params, p)
    _validate_from(named, WEAR_MONITOR_SCHEMA.section, lambda q: axes_params(q, validate_wear_params), p)
    warning = hardness_units_warning(p)
    if warning is not None:     # one stderr line in the CLI (logging's last-resort handler), the node logs its own
        logging.getLogger("guide_health.params").warning("guide-health: warning: %s", warning)
    return p


def machine_axes_params(path: str | Path | list | tuple | None) -> dict[str, dict]:
    """{axis: parameters} of the wear_monitor section (one axis named after ``joint`` without ``axes``)."""
    return axes_params(wear_monitor_params(path), validate_wear_params)


def simulation_params(path: str | Path | None) -> dict[str, Any]:
    """Scenario of ``guide-health simulate`` (section ``guide_health_simulation``), validated."""
    p = load_node_params(path, SIMULATION_SCHEMA.section, SIMULATION_SCHEMA.defaults())
    _validate_from(path, SIMULATION_SCHEMA.section, SIMULATION_SCHEMA.validate, p)
    return p


def _validate_from(path, section: str, validate, params: dict) -> None:
    """``validate(params)``; its InputError names the file and section too."""
    try:
        validate(params)
    except InputError as exc:
        if path is None or str(exc).startswith(str(path)):
            raise
        raise InputError(f"{path}: section '{section}': {exc}") from None
