"""fleet_monitor parameters: one status for a fleet of machines and an SQLite history of their health."""
from __future__ import annotations

from typing import Any

from guide_health.errors import InputError
from guide_health.params.schema import NodeSchema, Param

FLEET_MONITOR_PARAMS = (
    Param("machine_id", "fleet", "", "", "hardware_id of the fleet status"),
    Param("diagnostics_period_s", 1.0, "s", "(0, inf)", "period of the fleet status on /diagnostics"),
    Param("stale_after_s", 10.0, "s", "(0, inf)", "a machine status older than this counts as STALE",
          dynamic=True),
    Param("history_file", "", "", "", "SQLite history of every status; '' = none"),
    Param("history_period_s", 60.0, "s", "(0, inf)", "at most one history row per status per period",
          dynamic=True),
)


def _fleet_cross_checks(params: dict[str, Any]) -> None:
    for key in ("diagnostics_period_s", "stale_after_s", "history_period_s"):
        if not params[key] > 0:
            raise InputError(f"{key} must be > 0")


FLEET_MONITOR_SCHEMA = NodeSchema("fleet_monitor", FLEET_MONITOR_PARAMS, _fleet_cross_checks)
