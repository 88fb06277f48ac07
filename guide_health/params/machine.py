"""A whole machine in one wear_monitor: the axes list and each axis's own parameters (pure Python, no ROS).

``axes: [x, y, z]`` in the wear_monitor section makes one node monitor several axes (joints). Every wear
parameter that is not machine-wide (:data:`MACHINE_WIDE`) may be set per axis in a nested mapping named
after the axis (``x: {rail_length_m: 1.2}``); rcl flattens it to ``x.rail_length_m``, and so does the
loader here. A per-axis value overrides the section's top-level value, which is the default of every axis.
:data:`AXIS_PARAMS` are the parameters only an axis has: its joint name, its topics and its guides (rails
or ways) with their share of the axis load. The same nesting works in ``guide_health_simulation`` (the
duty of each axis). Without ``axes`` (the default) the node monitors the single ``joint`` with the
root topics, exactly as before.
"""
from __future__ import annotations

import re
from typing import Any

from guide_health.errors import InputError
from guide_health.params.schema import NodeSchema, Param, check_unknown_keys, coerce_value

#: wear_monitor parameters that hold for the whole node (not overridable per axis)
MACHINE_WIDE = ("machine_id", "machine_type", "axes", "joint", "diagnostics_period_s", "input_timeout_s",
                "checkpoint_period_s", "input_align_window_s", "executor", "state_file", "maintenance_guide",
                "maintenance_straightness_m", "maintenance_time_s", "maintenance_note", "maintenance_repeat_window_s",
                "plan_scenario")
#: guide_health_simulation parameters shared by all axes (one JointState carries every joint)
SIMULATION_WIDE = ("duration_h", "joint_state_rate_hz", "measurement_interval_h")

AXES_PARAM = Param("axes", [], "", "", "joints monitored by this node (e.g. [x, y, z]); empty = the single "
                   "'joint' with the root topics. Each axis may override any non machine-wide parameter in a "
                   "nested mapping named after it (docs/machine.md)")

#: the values a maintenance service call takes (set them, then call maintenance/<axis>/<kind>; they are
#: cleared after each call), and the repeat window of the calls: docs/machine.md
MAINTENANCE_PARAMS = (
    Param("maintenance_guide", "", "", "", "guide of the next maintenance call ('' = every guide of the axis)",
          dynamic=True),
    Param("maintenance_straightness_m", 0.0, "m", "[0, 0.01]",
          "straightness measured after the next regrind/rail replacement, or the next manual measurement "
          "(0 = not measured: A0)", dynamic=True),
    Param("maintenance_time_s", 0.0, "s", "[0, 1e10]",
          "time of the next manual measurement [s since the epoch, machine time base]; 0 = the axis's latest "
          "joint_states stamp", dynamic=True),
    Param("maintenance_note", "", "", "", "free text recorded with the next maintenance call (who, what)",
          dynamic=True),
    Param("maintenance_repeat_window_s", 60.0, "s", "[0, 1e7]",
          "the same maintenance (axis, guide, kind, value) stamped again within this time of an applied one "
          "is a repeat: refused ('already applied at ...'), never applied twice [s, machine time base]",
          dynamic=True),
)

#: the scenario the `plan` service answers (std_srvs/Trigger; docs/planning.md)
PLAN_PARAMS = (
    Param("plan_scenario", "", "", "", "what-if of the next `plan` service call, the `guide-health plan --scenario` "
          "grammar ('load=0.8, shift=8x5'); '' = as observed", dynamic=True),
)

AXIS_PARAMS = (
    Param("joint", "", "", "", "the axis's name in sensor_msgs/JointState; '' = the axis name"),
    Param("load_topic", "", "", "", "WrenchStamped load topic of the axis (force.z); '' = <axis>/guide/load"),
    Param("straightness_topic", "", "", "", "Float64 straightness topic [m]; '' = <axis>/guide/straightness"),
    Param("temperature_topic", "", "", "", "Temperature topic; '' = <axis>/guide/temperature"),
    Param("guides", ["guide"], "", "", "the guides (rails or ways) of the axis, each with its own model and "
          "state key <machine_id>/<axis>/<guide>/precision (one guide: <machine_id>/<axis>/precision)"),
    Param("guide_load_weights", [1.0], "-", "(0, 1e6]",
          "share of the axis load carried by each guide, normalised (one value: equal shares)"),
)
AXIS_SCHEMA = NodeSchema("wear_monitor axis", AXIS_PARAMS)
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def axis_names(schema: NodeSchema) -> list[str]:
    """Every name an axis mapping of ``schema``'s section may hold: for wear_monitor the axis parameters and
    the overridable wear parameters; for the simulation the per-axis duty parameters."""
    if schema.section == "wear_monitor":
        return [p.name for p in AXIS_PARAMS] + [p.name for p in schema.params if p.name not in MACHINE_WIDE]
    return [p.name for p in schema.params if p.name not in SIMULATION_WIDE]


def flatten(section: dict) -> dict:
    """Nested mappings as rcl reads them: ``{x: {a: 1}}`` -> ``{'x.a': 1}``."""
    flat = {}
    for key, value in section.items():
        if isinstance(value, dict):
            for sub, inner in flatten(value).items():
                flat[f"{key}.{sub}"] = inner
        else:
            flat[str(key)] = value
    return flat


def coerce_axis_value(name: str, value: Any, default: Any) -> Any:
    """``coerce_value``, with the variable-length lists of :data:`AXIS_PARAMS` (guides: names, weights)."""
    if isinstance(default, list) and (not default or isinstance(default[0], str)):
        if (not isinstance(value, (list, tuple)) or not value
                or not all(isinstance(v, str) and _NAME.match(v) for v in value)):
            raise InputError(f"parameter {name} must be a non-empty list of names ([A-Za-z][A-Za-z0-9_]*), "
                             f"got {value!r}")
        return list(value)
    if name.rsplit(".", 1)[-1] == "guide_load_weights":
        if not isinstance(value, (list, tuple)) or not value:
            raise InputError(f"parameter {name} must be a non-empty list of numbers, got {value!r}")
        return [coerce_value(f"{name}[{i}]", v, 1.0) for i, v in enumerate(value)]
    return coerce_value(name, value, default)


def check_axis_keys(section: str, names, axes: list[str], wear_schema: NodeSchema, source: str = "") -> None:
    """InputError for a dotted name whose axis is not in ``axes`` or whose parameter an axis cannot hold."""
    known = axis_names(wear_schema)
    for name in names:
        axis, _, param = name.partition(".")
        if axis not in axes:
            prefix = f"{source}: " if source else ""
            raise InputError(f"{prefix}parameter '{name}' of {section}: '{axis}' is not one of axes {axes}")
        check_unknown_keys(f"{section} axis '{axis}'", [param], known, source)


def axis_default(name: str, schema: NodeSchema) -> Any:
    """The default (hence the type) of an axis parameter of ``schema``'s section."""
    if schema.section == "wear_monitor" and name in AXIS_SCHEMA.by_name:
        return AXIS_SCHEMA[name].default
    return schema[name].default


def _axis_topics(axis: str, p: dict, single: bool) -> None:
    for key, rel in (("load_topic", "guide/load"), ("straightness_topic", "guide/straightness"),
                     ("temperature_topic", "guide/temperature")):
        if not p[key]:
            p[key] = rel if single else f"{axis}/{rel}"
    p["output_prefix"] = "guide" if single else f"{axis}/guide"


def axes_params(params: dict, validate=None) -> dict[str, dict]:
    """{axis: the axis's full parameter dict} of a loaded wear_monitor section (dotted per-axis keys).

    Single-joint (no ``axes``): one axis named after ``joint`` on the root topics. ``validate``: the wear
    schema's validation, run on every axis (its message names the axis)."""
    top = {k: v for k, v in params.items() if "." not in k}
    axes = list(top.get("axes") or [])
    single = not axes
    if single:
        axes = [top["joint"]]
    if len(set(axes)) != len(axes):
        raise InputError(f"axes {axes}: an axis is listed twice")
    result = {}
    for axis in axes:
        if not single and not _NAME.match(axis):
            raise InputError(f"axes: '{axis}' is not a valid axis name ([A-Za-z][A-Za-z0-9_]*)")
        p = dict(top)
        p.update({a.name: a.default for a in AXIS_PARAMS})
        p.update({k.partition(".")[2]: v for k, v in params.items() if k.partition(".")[0] == axis and "." in k})
        p["axis"] = axis
        p["joint"] = p["joint"] or (top["joint"] if single else axis)
        _axis_topics(axis, p, single)
        _check_guides(axis, p)
        if validate is not None:
            try:
                validate(p)
            except InputError as exc:
                raise InputError(f"axis '{axis}': {exc}") from None
        result[axis] = p
    return result


def _check_guides(axis: str, p: dict) -> None:
    guides, weights = list(p["guides"]), list(p["guide_load_weights"])
    if len(set(guides)) != len(guides):
        raise InputError(f"axis '{axis}': guides {guides}: a guide is listed twice")
    if len(weights) == 1:
        weights = weights * len(guides)
    if len(weights) != len(guides):
        raise InputError(f"axis '{axis}': guide_load_weights has {len(weights)} values for {len(guides)} guides")
    if not all(w > 0 for w in weights):
        raise InputError(f"axis '{axis}': guide_load_weights must be > 0, got {weights}")
    total = sum(weights)
    p["guide_load_shares"] = [w / total for w in weights]


def simulation_axes(sim: dict, axes: list[str]) -> dict[str, dict]:
    """{axis: scenario} of a loaded guide_health_simulation section (dotted per-axis keys)."""
    top = {k: v for k, v in sim.items() if "." not in k}
    out = {}
    for axis in axes:
        p = dict(top)
        for key, value in sim.items():
            a, _, name = key.partition(".")
            if a == axis and name:
                if name in SIMULATION_WIDE:
                    raise InputError(f"guide_health_simulation: {name} is the same for every axis "
                                     f"(set it once, not under '{axis}')")
                p[name] = value
        out[axis] = p
    return out
