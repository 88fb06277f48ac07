"""fleet_monitor parameters: one status for a fleet of machines and an SQLite history of their health."""
from __future__ import annotations

from typing import Any

from guide_health.errors import InputError
from guide_health.params.schema import NodeSchema, Param

FLEET_MONITOR_PARAMS = (
    Param("machine_id", "fleet", "", "", "hardware_id of the fleet status"),
    Param("diagnostics_period_s", 1.0, "s", "[0.01, 3600]", "period of the fleet status on /diagnostics", dynamic=True),
    Param("stale_after_s", 10.0, "s", "(0, 1e6]", "a machine status older than this counts as STALE",
          dynamic=True),
    Param("forget_after_s", 86400.0, "s", "(0, 1e8]",
          "a status silent for longer is dropped from the board (a retired machine; > stale_after_s)",
          dynamic=True),
    Param("max_statuses", 10000, "-", "[1, 10000000]",
          "at most this many statuses on the board; an unseen one beyond it is ignored and counted"),
    Param("history_file", "", "", "", "SQLite history of every status; '' = none"),
    Param("history_period_s", 60.0, "s", "(0, 1e6]",
          "at most one history row per status per period; a level change is always recorded", dynamic=True),
    Param("history_retention_days", 365.0, "d", "[0, 36500]",
          "history rows older than this are deleted (hourly); 0 = keep every row"),
)


def _fleet_cross_checks(params: dict[str, Any]) -> None:
    for key in ("diagnostics_period_s", "stale_after_s", "history_period_s"):
        if not params[key] > 0:
            raise InputError(f"{key} must be > 0")
    if not params["forget_after_s"] > params["stale_after_s"]:
        raise InputError(f"forget_after_s ({params['forget_after_s']!r} s) must be above stale_after_s "
                         f"({params['stale_after_s']!r} s)")


FLEET_MONITOR_SCHEMA = NodeSchema("fleet_monitor", FLEET_MONITOR_PARAMS, _fleet_cross_checks)
