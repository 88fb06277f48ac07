"""ROS 2 parameters YAML files, read strictly (the only file I/O of guide_health.params).

One file (``/**/<node>: ros__parameters: {...}``) drives both the node and ``guide-health ... --params FILE``,
so live and offline results come from the same numbers. The file is read as rcl reads it (``rcl_yaml.py``:
libyaml, rcl's scalar typing, aliases refused, plus a size limit and duplicate keys refused), and a section
applies to a node as rcl applies it (``rcl_yaml.applies``): ``/**`` and ``/**/wear_monitor`` everywhere,
``wear_monitor`` (= ``/wear_monitor``) only in the root namespace, ``/m1/wear_monitor`` only in ``/m1``.
The CLI reads a file as the node in the root namespace would; the node (``ros_args.py``) with its full
name, before rcl reads the files. Sections apply in file order, the later overriding, as in rcl.

Strict by default, so that a typo never goes unnoticed:

* the node's own section may hold only the node's declared parameters (and ROS's own, e.g. ``use_sim_time``):
  an unknown name is an error naming the closest declared one;
* a wildcard section (``/**``, ``/**/*``) may hold only names some guide_health schema declares;
* a section for the node whose key beside ``ros__parameters`` is neither a nested node nor it
  (``ros__parameter``) is an error; other tools' sections in the same file are left alone;
* a file with no section for the node is an error where the command needs that node's parameters
  (``required``), naming the file, its sections and the node's full name;
* a section whose node name is within edit distance 2 of a guide_health node's (``wear_monitr``) is
  warned about: rcl applies it to no node.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from guide_health.errors import InputError
from guide_health.params.machine import axes_params, axis_default, check_axis_keys, coerce_axis_value, flatten
from guide_health.params.rcl_yaml import VALUE_CHARS, applies, edit_distance, sections, short
from guide_health.params.schema import check_unknown_keys, coerce_value
from guide_health.params.schemas import SCHEMAS, schema_for
from guide_health.params.simulation import SIMULATION_SCHEMA
from guide_health.params.slewing_monitor import SLEWING_MONITOR_SCHEMA, validate_slewing_params
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA, hardness_units_warning, validate_wear_params

#: parameters every rclpy node has (or reads) besides its schema's: accepted in any section, not returned
ROS_NODE_PARAMS = ("use_sim_time", "start_type_description_service", "qos_overrides")
#: node names within this edit distance of a guide_health node's are warned about as likely typos
TYPO_DISTANCE = 2
_LOG = logging.getLogger("guide_health.params")
_warned: set[tuple[str, str]] = set()


def _all_known_names() -> set[str]:
    return {name for schema in SCHEMAS.values() for name in schema.by_name}


def _warn_typos(path: Path, names: list[str]) -> None:
    """One warning per (file, section) whose last name part is a near miss of a guide_health node name."""
    for name in names:
        base = name.rstrip("/").split("/")[-1]
        if base in SCHEMAS or "*" in base or (str(path), name) in _warned:
            continue
        close = sorted((edit_distance(base, node), node) for node in SCHEMAS)
        if close and close[0][0] <= TYPO_DISTANCE:
            _warned.add((str(path), name))
            _LOG.warning("guide-health: warning: %s: section '%s' applies to no guide_health node: a typo of "
                         "'%s'? (its parameters are not used)", path, name, close[0][1])


def node_sections(path: str | Path, node_name: str, required: bool = True,
                  fqn: str | None = None) -> list[tuple[str, dict]]:
    """The (section name, ros__parameters) entries of ``path`` that rcl applies to the node ``fqn``
    (default: ``/<node_name>``, the root namespace), in file order. ``required``: InputError when none."""
    path = Path(path)
    fqn = fqn or "/" + node_name
    found = sections(path)
    _warn_typos(path, [section.name for section in found])
    chosen = [section for section in found if applies(section.name, fqn)]
    for section in chosen:
        if section.stray:
            key = section.stray[0]
            hint = " (did you mean 'ros__parameters'?)" if key != "ros__parameters" else " (not a mapping)"
            raise InputError(f"{path}: section '{section.name}' has an unknown key '{key}'{hint}")
    if not chosen and required:
        names = ", ".join(f"'{section.name}'" for section in found) or "none"
        raise InputError(f"{path}: no section for node '{node_name}' (full name {fqn}); the file's sections: "
                         f"{names}; '/**/{node_name}:' applies in any namespace")
    return [(section.name, section.params) for section in chosen]


def _generic(section_name: str) -> bool:
    """A section for every node (``/**``, ``/**/*``, ``/*``): its names are checked against every schema."""
    return section_name.rstrip("/").split("/")[-1] in ("*", "**", "")


def clip_values(exc: InputError, values: list) -> InputError:
    """``exc`` with every long value it quotes cut to rcl_yaml.VALUE_CHARS characters."""
    message = str(exc)
    for value in values:
        for text in {repr(value), str(value)}:
            if len(text) > VALUE_CHARS and text in message:
                message = message.replace(text, short(value))
    return InputError(message[:2000])


def load_node_params(path: str | Path | None, node_name: str, defaults: dict[str, Any],
                     strict: bool = True, required: bool = True, fqn: str | None = None,
                     applied: list | None = None) -> dict[str, Any]:
    """Parameters of ``node_name`` (full name ``fqn``, default the root namespace's) from a ROS 2 parameters
    YAML, merged over ``defaults`` (see the module text for what ``strict`` and ``required`` refuse).
    ``strict=False`` keeps unknown names (for a caller that reads only a few names of a section).
    ``applied``: (file, section name) of each section used is appended to it."""
    params = dict(defaults)
    if path is None:
        return params
    for key, section in node_sections(path, node_name, required, fqn):
        if applied is not None:
            applied.append((str(path), key))
        section = flatten(section)     # nested mappings (per-axis parameters) as rcl reads them: 'x.name'
        try:
            _section_values(path, node_name, key, section, params, defaults, strict)
        except InputError as exc:
            exc = clip_values(exc, [*section.values(), *section])
            raise exc if str(path) in str(exc) else InputError(f"{path}: section '{key}': {exc}") from None
    return params


def _section_values(path, node_name: str, key: str, section: dict, params: dict, defaults: dict,
                    strict: bool) -> None:
    names = [name for name in section if name not in ROS_NODE_PARAMS and "." not in name]
    if strict:
        generic = _generic(key)
        known = sorted(_all_known_names() | set(defaults)) if generic else list(defaults)
        source = f"{path}: section '{key}'" if generic else str(path)
        check_unknown_keys(node_name, names, known, source=source)
    for name in names:
        value = section[name]
        params[name] = coerce_value(name, value, defaults[name]) if name in defaults else value
    _axis_values(path, node_name, section, params, defaults, strict)


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


def slewing_monitor_params_from(paths: list | tuple) -> dict[str, Any]:
    """slewing_monitor parameters of several files merged in order (the later overriding), validated once."""
    params = SLEWING_MONITOR_SCHEMA.defaults()
    for path in paths:
        params = load_node_params(path, SLEWING_MONITOR_SCHEMA.section, params)
    validate_slewing_params(params)
    return params


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
        exc = clip_values(exc, list(params.values()))
        if path is None or str(exc).startswith(str(path)):
            raise exc from None
        raise InputError(f"{path}: section '{section}': {exc}") from None
