"""DiagnosticStatus building with diagnostic_updater conventions (INTERFACES.md).

``name`` = "<node name>: <task>", ``hardware_id`` = machine_id, levels OK/WARN/ERROR/STALE, one human
sentence as ``message``, numbers as KeyValues (plain decimal via repr(float); 'nan' when unknown).
"""
from __future__ import annotations

import math
from typing import Iterable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

LEVEL_BYTES = {0: DiagnosticStatus.OK, 1: DiagnosticStatus.WARN, 2: DiagnosticStatus.ERROR,
               3: DiagnosticStatus.STALE}

PRECISION_KEYS = ("straightness_um", "straightness_measured_um", "straightness_limit_um", "remaining_life_h",
                  "remaining_life_h_low", "remaining_life_h_high", "wear_volume_mm3", "sliding_distance_m",
                  "wear_coefficient", "lubrication_regime")
EXTRA_PRECISION_KEYS = ("wear_coefficient_low", "wear_coefficient_high", "measurements", "duty_load_speed_w",
                        "stroke_min_m", "stroke_max_m", "strokes", "rejected_samples", "samples")
FATIGUE_KEYS = ("equivalent_load_n", "rating_life_km", "travel_km", "life_used_fraction", "remaining_life_km")
ROLLER_CONTACT_KEYS = ("roller_load_max_n", "p0_hertz_MPa", "p0_center_MPa", "p0_end_MPa", "end_stress_ratio",
                       "von_mises_max_MPa", "von_mises_depth_mm", "shear_max_MPa", "allowable_MPa")


def format_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if value is None:
        return "nan"
    return str(value)


def make_status(node_name: str, task: str, machine_id: str, level: int, message: str, values: dict,
                keys: Iterable[str]) -> DiagnosticStatus:
    status = DiagnosticStatus()
    status.level = LEVEL_BYTES[level]
    status.name = f"{node_name}: {task}"
    status.hardware_id = machine_id
    status.message = message
    status.values = [KeyValue(key=k, value=format_value(values.get(k, math.nan))) for k in keys
                     if k in values or k in PRECISION_KEYS + FATIGUE_KEYS + ROLLER_CONTACT_KEYS]
    return status


def make_array(stamp, statuses: list[DiagnosticStatus]) -> DiagnosticArray:
    array = DiagnosticArray()
    array.header.stamp = stamp
    array.status = statuses
    return array


def status_values(status: DiagnosticStatus) -> dict[str, str]:
    """KeyValues of a status as a dict (for tests and fleet aggregation)."""
    return {kv.key: kv.value for kv in status.values}
