"""Every parameter of guide_health, declared once: the live nodes and the offline CLI read the same schema.

One ROS 2 parameters YAML (``<node>: ros__parameters: {...}``, ``/**`` wildcard allowed) drives both the
node and ``guide-health ... --params FILE``, so live and offline results come from the same numbers.

* ``schema.py``: :class:`Param` (name, type via the default, unit, range, description, dynamic) and
  :class:`NodeSchema` (ranges + cross-checks, unknown-key suggestions, defaults), ``markdown_table``.
* ``wear_monitor.py``, ``slewing_monitor.py``, ``fleet_monitor.py``, ``simulation.py``: the schemas.
* ``schemas.py``: every schema by section name.
* ``loader.py``: YAML files (the only file I/O); ``ros.py``: descriptors and ``declare_parameters``.
* ``typed.py``: the frozen, typed parameter objects generated from the schemas (what the models take).

The ``*_DEFAULTS`` dicts are views of the schemas ({name: default}) for the call sites that merge over them.
"""
from __future__ import annotations

from guide_health.params.fleet_monitor import FLEET_MONITOR_SCHEMA
from guide_health.params.loader import (
    load_node_params,
    machine_axes_params,
    node_sections,
    simulation_params,
    slewing_monitor_params_from,
    wear_monitor_params,
)
from guide_health.params.ros import declare_parameters, descriptor_for
from guide_health.params.schema import NodeSchema, Param, check_unknown_keys, markdown_table
from guide_health.params.schemas import SCHEMAS, schema_for
from guide_health.params.simulation import SIMULATION_SCHEMA, SLEWING_SIMULATION_SCHEMA, slewing_simulation_params
from guide_health.params.slewing_monitor import SLEWING_MONITOR_SCHEMA, validate_slewing_params
from guide_health.params.vibration_monitor import LIFE_TEST_SIMULATION_SCHEMA, VIBRATION_MONITOR_SCHEMA
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA, validate_wear_params

WEAR_MONITOR_DEFAULTS = WEAR_MONITOR_SCHEMA.defaults()
SLEWING_MONITOR_DEFAULTS = SLEWING_MONITOR_SCHEMA.defaults()
SLEWING_SIMULATION_DEFAULTS = SLEWING_SIMULATION_SCHEMA.defaults()


__all__ = [
    "FLEET_MONITOR_SCHEMA", "LIFE_TEST_SIMULATION_SCHEMA", "NodeSchema", "Param", "SCHEMAS", "SIMULATION_SCHEMA",
    "SLEWING_MONITOR_DEFAULTS", "SLEWING_MONITOR_SCHEMA", "SLEWING_SIMULATION_DEFAULTS", "SLEWING_SIMULATION_SCHEMA",
    "VIBRATION_MONITOR_SCHEMA", "WEAR_MONITOR_DEFAULTS", "WEAR_MONITOR_SCHEMA",
    "check_unknown_keys", "declare_parameters", "descriptor_for", "load_node_params", "machine_axes_params",
    "markdown_table", "node_sections", "schema_for", "simulation_params", "slewing_monitor_params_from",
    "slewing_simulation_params", "validate_slewing_params",
    "validate_wear_params", "wear_monitor_params",
]
