"""ROS 2 parameters YAML files for the offline CLI (the only file I/O of guide_health.params).

One file (``<node>: ros__parameters: {...}``, ``/**`` wildcard allowed) drives both the node and
``guide-health ... --params FILE``, so live and offline results come from the same numbers.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from guide_health.errors import InputError
from guide_health.params.schema import check_unknown_keys, coerce_value
from guide_health.params.simulation import SIMULATION_SCHEMA
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA, validate_wear_params


def _load_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"parameters file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise InputError(f"parameters file {path} is not valid YAML: {exc}".splitlines()[0]) from exc
    if not isinstance(data, dict):
        raise InputError(f"parameters file {path} holds no '<node>: ros__parameters:' mapping")
    return data


def load_node_params(path: str | Path | None, node_name: str, defaults: dict[str, Any],
                     strict: bool = False) -> dict[str, Any]:
    """Parameters of ``node_name`` from a ROS 2 parameters YAML, merged over ``defaults``.

    ``/**`` entries apply first, then ``node_name`` (with or without a leading slash/namespace).
    Unknown names are kept (a file may carry other tools' parameters) unless ``strict``, which rejects
    them naming the closest known name.
    """
    params = dict(defaults)
    if path is None:
        return params
    data = _load_yaml(path)
    sections = []
    for key, section in data.items():
        base = str(key).rstrip("/").split("/")[-1]
        if key == "/**" or base == node_name:
            if not isinstance(section, dict) or not isinstance(section.get("ros__parameters", {}), dict):
                raise InputError(f"{path}: section '{key}' has no 'ros__parameters' mapping")
            sections.append((0 if key == "/**" else 1, section.get("ros__parameters", {})))
    if not sections and strict:
        raise InputError(f"{path}: no section for node '{node_name}'")
    for _, section in sorted(sections, key=lambda s: s[0]):
        if strict:
            check_unknown_keys(node_name, section, defaults, source=str(path))
        for name, value in section.items():
            params[name] = coerce_value(name, value, defaults[name]) if name in defaults else value
    return params


def wear_monitor_params(path: str | Path | None) -> dict[str, Any]:
    """wear_monitor parameters, validated (positive sizes, known model names, declared ranges)."""
    p = load_node_params(path, WEAR_MONITOR_SCHEMA.section, WEAR_MONITOR_SCHEMA.defaults())
    validate_wear_params(p)
    return p


def simulation_params(path: str | Path | None) -> dict[str, Any]:
    """Scenario of ``guide-health simulate`` (section ``guide_health_simulation``), validated."""
    p = load_node_params(path, SIMULATION_SCHEMA.section, SIMULATION_SCHEMA.defaults())
    SIMULATION_SCHEMA.validate(p)
    return p
