"""The maintenance plan of one machine: every guide of every axis under each scenario (models/wear/planning.py)
as rows, and its files (plan.csv, plan.json, plan_<machine>.png)."""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from guide_health.analysis.plan_plots import plot_plan
from guide_health.errors import InputError
from guide_health.io.outputs.files import open_output, write_text
from guide_health.io.outputs.json_text import json_text
from guide_health.models.wear.planning import (
    Scenario,
    observed_utilisation,
    plan_scenario,
    scenario_from_items,
)

#: plan.csv's columns, in order
PLAN_COLUMNS = ("machine", "axis", "guide", "scenario", "limit_date_utc", "limit_date_utc_low",
                "limit_date_utc_high", "life_h", "life_h_low", "life_h_high", "utilisation", "utilisation_cv_daily",
                "utilisation_days", "straightness_um", "straightness_limit_um", "regrind_utc", "regrind_late")


def scenarios_from_yaml(data: Any, source: str) -> list[Scenario]:
    """The scenarios of a YAML file: ``scenarios:`` (or the top level) a list of mappings (``name`` and the
    keys of planning.parse_scenario) or a mapping name -> keys; a ValueError naming ``source`` otherwise."""
    body = data.get("scenarios", data) if isinstance(data, dict) else data
    if isinstance(body, dict):
        body = [{"name": name, **(items or {})} for name, items in body.items()]
    if not isinstance(body, list) or not all(isinstance(item, dict) for item in body):
        raise ValueError(f"{source}: scenarios must be a list of mappings (name, load, speed, stroke, relube, "
                         "shift, regrind) or a mapping name -> keys")
    out = []
    for i, item in enumerate(body):
        items = {k: v for k, v in item.items() if k != "name"}
        try:
            out.append(scenario_from_items(str(item.get("name", f"scenario {i + 1}")), items))
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from None
    return out


def plan_axis(machine: str, axis_model, scenarios: list[Scenario]) -> list[dict[str, Any]]:
    """One row per guide and scenario of one axis (models/wear/axis.AxisMonitor), the no-change scenario
    first; each guide's present is its latest sample, its utilisation its running clock's."""
    rows = []
    for name, guide in axis_model.guides.items():
        clock = guide.integrator.clock
        if clock.last_t_ns is None:
            raise InputError(f"axis {axis_model.axis}: no accepted joint sample, nothing to plan from")
        report = axis_model.guide_report(name)
        inputs, observed = axis_model.life_inputs(name), observed_utilisation(clock)
        for scenario in [Scenario(), *scenarios]:
            row = plan_scenario(inputs, observed, clock.last_t_ns, scenario)
            rows.append({"machine": machine, "axis": axis_model.axis, "guide": name, **row,
                         "straightness_um": report["straightness_um"],
                         "straightness_limit_um": report["straightness_limit_um"],
                         "straightness_initial_um": guide.params.straightness_initial_m * 1e6,
                         "now_t_ns": clock.last_t_ns})
    return rows


def _cell(value) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return "" if value is None else str(value)


def write_plan_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    with open_output(path) as handle:
        writer = csv.writer(handle)
        writer.writerow(PLAN_COLUMNS)
        writer.writerows([[_cell(row.get(c)) for c in PLAN_COLUMNS] for row in rows])


def write_plan(out: Path, machine: str, rows: list[dict[str, Any]], plot: bool = True) -> dict[str, str]:
    """plan.csv, plan.json and (``plot``) plan_<machine>.png in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"csv": str(out / "plan.csv"), "json": str(out / "plan.json")}
    write_plan_csv(Path(files["csv"]), rows)
    if plot:
        files["png"] = str(out / f"plan_{machine}.png")
        plot_plan(Path(files["png"]), machine, rows)
    write_text(files["json"], json_text({"machine": machine, "rows": rows, "files": files}, indent=2,
                                        default=float) + "\n")
    return files


def plan_table_text(rows: list[dict[str, Any]]) -> str:
    """The plan as a fixed-width text table."""
    head = ("axis", "guide", "scenario", "limit date (90 %)", "running life h", "u")
    lines = [f"{head[0]:<6} {head[1]:<8} {head[2]:<28} {head[3]:<44} {head[4]:>22} {head[5]:>5}"]
    for r in rows:
        date = (f"{r['limit_date_utc'][:10] or '-'} ({r['limit_date_utc_low'][:10] or '-'} .. "
                f"{r['limit_date_utc_high'][:10] or 'never'})")
        life = f"{r['life_h']:.0f} ({r['life_h_low']:.0f}..{r['life_h_high']:.0f})"
        late = "  regrind too late" if r.get("regrind_late") else ""
        lines.append(f"{r['axis']:<6} {r['guide']:<8} {r['scenario'][:28]:<28} {date:<44} {life:>22} "
                     f"{r['utilisation']:5.2f}{late}")
    return "\n".join(lines)
