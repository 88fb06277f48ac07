"""Every node's schema by its YAML section / node name (`SCHEMAS`), and `schema_for` a name."""
from __future__ import annotations

import difflib

from guide_health.errors import InputError
from guide_health.params.fleet_monitor import FLEET_MONITOR_SCHEMA
from guide_health.params.schema import NodeSchema
from guide_health.params.simulation import SIMULATION_SCHEMA, SLEWING_SIMULATION_SCHEMA
from guide_health.params.slewing_monitor import SLEWING_MONITOR_SCHEMA
from guide_health.params.vibration_monitor import LIFE_TEST_SIMULATION_SCHEMA, VIBRATION_MONITOR_SCHEMA
from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA

#: every schema by its YAML section / node name
SCHEMAS: dict[str, NodeSchema] = {s.section: s for s in (
    WEAR_MONITOR_SCHEMA, SLEWING_MONITOR_SCHEMA, FLEET_MONITOR_SCHEMA, SIMULATION_SCHEMA, SLEWING_SIMULATION_SCHEMA,
    VIBRATION_MONITOR_SCHEMA, LIFE_TEST_SIMULATION_SCHEMA)}


def schema_for(section: str) -> NodeSchema:
    """The schema of a node/section name; InputError naming the closest known name otherwise."""
    if section not in SCHEMAS:
        close = difflib.get_close_matches(section, list(SCHEMAS), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise InputError(f"no parameter schema for '{section}'{hint}; known: {', '.join(SCHEMAS)}")
    return SCHEMAS[section]
