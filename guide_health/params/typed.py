"""Frozen, typed parameter objects, generated from the schema: the one place a parameter dict becomes a typed
object (field names = parameter names, defaults = the schema's defaults, list values as tuples).

The classes are generated (``dataclasses.make_dataclass``) rather than written out: the schema already declares
every parameter once with its type and default, and a hand-written class of the same ~200 names would be a
second declaration to keep in step. The field types come from the defaults' types (``Param.type_name``).

* :class:`SlewingMonitorParams`, :class:`VibrationMonitorParams`, :class:`FleetMonitorParams`,
  :class:`WearMonitorParams`, :class:`SimulationParams`, :class:`SlewingSimulationParams`,
  :class:`LifeTestSimulationParams`: one per schema (YAML section);
* :class:`GuideParams`: the physics of one guide of a wear_monitor axis (the wear parameters an axis may
  override, i.e. all but the machine-wide ones); :class:`AxisParams`: an axis's own parameters (joint, topics,
  guides and their load shares); :class:`WearAxisParams`: both of one axis, what the wear core of an axis
  (models/wear/axis.AxisMonitor, its gate and its guides) takes.

Builders: ``slewing_monitor_params(values)`` etc. merge a dict over the schema's defaults, validate it with the
schema (ranges and cross-checks, the InputError messages of the loader) and return the frozen object;
``guide_params(axis_values)`` converts an already validated wear_monitor axis dict (params/machine.py);
``wear_axis_params(axis_values)`` the same dict (or a single-joint wear_monitor section) for the wear core.
``with_changes(obj, changed)``: the object with an accepted run-time change (``ros2 param set``) applied.
"""
from __future__ import annotations

import dataclasses
from typing import Any

from guide_health.params.fleet_monitor import FLEET_MONITOR_SCHEMA
from guide_health.params.machine import AXIS_PARAMS, MACHINE_WIDE
from guide_health.params.schema import NodeSchema, Param
from guide_health.params.simulation import SIMULATION_SCHEMA, SLEWING_SIMULATION_SCHEMA
from guide_health.params.slewing_monitor import SLEWING_MONITOR_SCHEMA
from guide_health.params.vibration_monitor import LIFE_TEST_SIMULATION_SCHEMA, VIBRATION_MONITOR_SCHEMA
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA

_TYPES = {"bool": bool, "int": int, "float": float, "string": str, "string[]": tuple[str, ...]}


def _frozen(value: Any) -> Any:
    """A list value as a tuple (the objects are immutable); anything else as it is."""
    return tuple(value) if isinstance(value, list) else value


def _field_type(param: Param) -> Any:
    return _TYPES.get(param.type_name, tuple[float, ...])


def _typed_class(name: str, params: tuple[Param, ...], doc: str,
                 extra: tuple[tuple[str, Any, Any], ...] = ()) -> type:
    """A frozen dataclass with one field per parameter (its schema default) and the ``extra`` derived fields
    (name, type, default)."""
    fields = [(p.name, _field_type(p), dataclasses.field(default=_frozen(p.default))) for p in params]
    fields += [(n, t, dataclasses.field(default=d)) for n, t, d in extra]
    cls = dataclasses.make_dataclass(name, fields, frozen=True, namespace={"__doc__": doc})
    cls.__module__ = __name__
    return cls


def _from_values(cls: type, values: dict[str, Any]) -> Any:
    """``cls`` from the names of ``values`` it declares (missing names: the schema default)."""
    names = [f.name for f in dataclasses.fields(cls)]
    return cls(**{n: _frozen(values[n]) for n in names if n in values})


def _node_class(schema: NodeSchema, name: str) -> type:
    return _typed_class(name, schema.params, f"The {schema.section} parameters (guide_health.params schema).")


SlewingMonitorParams = _node_class(SLEWING_MONITOR_SCHEMA, "SlewingMonitorParams")
VibrationMonitorParams = _node_class(VIBRATION_MONITOR_SCHEMA, "VibrationMonitorParams")
FleetMonitorParams = _node_class(FLEET_MONITOR_SCHEMA, "FleetMonitorParams")
WearMonitorParams = _node_class(WEAR_MONITOR_SCHEMA, "WearMonitorParams")
SimulationParams = _node_class(SIMULATION_SCHEMA, "SimulationParams")
SlewingSimulationParams = _node_class(SLEWING_SIMULATION_SCHEMA, "SlewingSimulationParams")
LifeTestSimulationParams = _node_class(LIFE_TEST_SIMULATION_SCHEMA, "LifeTestSimulationParams")

#: the wear parameters of one guide: every wear_monitor parameter an axis may override (params/machine.py)
GUIDE_PARAMS = tuple(p for p in WEAR_MONITOR_SCHEMA.params if p.name not in MACHINE_WIDE)
GuideParams = _typed_class("GuideParams", GUIDE_PARAMS,
                           "The wear and rolling-guide physics of one guide of a wear_monitor axis.")
AxisParams = _typed_class(
    "AxisParams", AXIS_PARAMS, "An axis's own parameters: joint, topics, guides (axes_params fills the topics).",
    extra=(("axis", str, ""), ("output_prefix", str, "guide"), ("guide_load_shares", tuple[float, ...], (1.0,)),
           # machine-wide, read by the axis's maintenance (a repeated event within the window is refused)
           ("maintenance_repeat_window_s", float,
            WEAR_MONITOR_SCHEMA.by_name["maintenance_repeat_window_s"].default)))

WearAxisParams = _typed_class(
    "WearAxisParams", GUIDE_PARAMS + AXIS_PARAMS,
    "One wear_monitor axis as the wear core takes it: its guides' physics and its own parameters.",
    extra=(("axis", str, ""), ("output_prefix", str, "guide"), ("guide_load_shares", tuple[float, ...], (1.0,)),
           # machine-wide, read by the axis's maintenance (a repeated event within the window is refused)
           ("maintenance_repeat_window_s", float,
            WEAR_MONITOR_SCHEMA.by_name["maintenance_repeat_window_s"].default)))

#: the typed class of every schema by its section name
TYPED_CLASSES: dict[str, type] = {
    SLEWING_MONITOR_SCHEMA.section: SlewingMonitorParams, VIBRATION_MONITOR_SCHEMA.section: VibrationMonitorParams,
    FLEET_MONITOR_SCHEMA.section: FleetMonitorParams, WEAR_MONITOR_SCHEMA.section: WearMonitorParams,
    SIMULATION_SCHEMA.section: SimulationParams, SLEWING_SIMULATION_SCHEMA.section: SlewingSimulationParams,
    LIFE_TEST_SIMULATION_SCHEMA.section: LifeTestSimulationParams,
}
_SCHEMAS = {s.section: s for s in (SLEWING_MONITOR_SCHEMA, VIBRATION_MONITOR_SCHEMA, FLEET_MONITOR_SCHEMA,
                                   WEAR_MONITOR_SCHEMA, SIMULATION_SCHEMA, SLEWING_SIMULATION_SCHEMA,
                                   LIFE_TEST_SIMULATION_SCHEMA)}


def typed_params(section: str, values: dict[str, Any] | None = None, validate: bool = True) -> Any:
    """The frozen parameter object of ``section`` from ``values`` merged over the schema's defaults, validated
    by the schema (InputError with the loader's one-line message); names ``values`` holds beyond the section's
    are not taken. ``validate=False``: a section read as it is (commands that never validated it)."""
    schema = _SCHEMAS[section]
    merged = schema.defaults()
    merged.update(values or {})
    if validate:
        schema.validate(merged)
    return _from_values(TYPED_CLASSES[section], merged)


def slewing_monitor_params(values: dict[str, Any] | None = None) -> Any:
    """:class:`SlewingMonitorParams` of a slewing_monitor dict (over the defaults), validated."""
    return typed_params(SLEWING_MONITOR_SCHEMA.section, values)


def vibration_monitor_params(values: dict[str, Any] | None = None) -> Any:
    """:class:`VibrationMonitorParams` of a vibration_monitor dict (over the defaults), validated."""
    return typed_params(VIBRATION_MONITOR_SCHEMA.section, values)


def fleet_monitor_params(values: dict[str, Any] | None = None) -> Any:
    """:class:`FleetMonitorParams` of a fleet_monitor dict (over the defaults), validated."""
    return typed_params(FLEET_MONITOR_SCHEMA.section, values)


def life_test_simulation_params(values: dict[str, Any] | None = None) -> Any:
    """:class:`LifeTestSimulationParams` of a guide_health_life_test_simulation dict, validated."""
    return typed_params(LIFE_TEST_SIMULATION_SCHEMA.section, values)


def guide_params(values: dict[str, Any]) -> Any:
    """:class:`GuideParams` of one wear_monitor axis dict (already validated by the loader: no second check)."""
    return _from_values(GuideParams, values)


def axis_params(values: dict[str, Any]) -> Any:
    """:class:`AxisParams` of one wear_monitor axis dict (params/machine.axes_params)."""
    return _from_values(AxisParams, values)


def wear_axis_params(values: dict[str, Any]) -> Any:
    """:class:`WearAxisParams` of one wear_monitor axis dict (params/machine.axes_params, already validated) or
    of a single-joint wear_monitor section: its axis is named after its joint, its guides share the load
    equally unless ``guide_load_shares`` says otherwise."""
    merged = {**{p.name: p.default for p in AXIS_PARAMS}, **WEAR_MONITOR_SCHEMA.defaults(), **values}
    merged.setdefault("axis", merged["joint"])
    merged.setdefault("guide_load_shares", [1.0 / len(merged["guides"])] * len(merged["guides"]))
    return _from_values(WearAxisParams, merged)


def with_changes(obj: Any, changed: dict[str, Any]) -> Any:
    """``obj`` with the changed values of the parameters it holds (an accepted ``ros2 param set``)."""
    names = {f.name for f in dataclasses.fields(obj)}
    own = {name: _frozen(value) for name, value in changed.items() if name in names}
    return dataclasses.replace(obj, **own) if own else obj


def as_dict(obj: Any) -> dict[str, Any]:
    """{name: value} of a parameter object (tuples as lists, as the loader returns them)."""
    return {f.name: list(v) if isinstance(v := getattr(obj, f.name), tuple) else v
            for f in dataclasses.fields(obj)}
