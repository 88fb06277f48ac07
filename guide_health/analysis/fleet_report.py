"""The combined fleet table (CSV, Markdown, JSON) and the PNG ranking machines by remaining life."""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from guide_health.io.outputs.files import open_output, write_text
from guide_health.io.outputs.json_text import json_text

#: table columns of each command, in order (after machine, bag, status); missing values are blank
REPLAY_COLUMNS = ("level_name", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
                  "straightness_um", "straightness_measured_um", "wear_coefficient", "wear_coefficient_low",
                  "wear_coefficient_high", "wear_coefficient_configured", "measurements", "duration_h", "messages")
#: a slewing bag's replay (analysis/slewing_replay.py): the governing row's fatigue, the static safety, the
#: raceway wear's life to the replacement clearance
SLEWING_REPLAY_COLUMNS = ("kind", "level_name", "fatigue_governing_row", "fatigue_damage", "fatigue_remaining_life_h",
                          "static_safety_factor", "static_safety_row", "tilting_clearance_predicted_mm",
                          "tilting_clearance_measured_mm", "raceway_wear_remaining_life_h",
                          "raceway_wear_remaining_life_low_h", "raceway_wear_remaining_life_high_h",
                          "duration_h", "messages")
DIAGNOSE_COLUMNS = ("named_effects", "wear_coefficient", "wear_coefficient_std_error", "rmse_um",
                    "heldout_rmse_um", "measurements", "duration_h", "messages")


def table_rows(command: str, entries: list[dict[str, Any]], machine_type: str = "") -> list[dict[str, Any]]:
    """One row per bag: machine, machine_type, bag, status (ok|error), the command's columns, error."""
    rows = []
    for e in entries:
        row: dict[str, Any] = {"machine": e["machine"], "machine_type": machine_type, "bag": e["bag"],
                               "status": "ok" if e["ok"] else "error"}
        r = e.get("result") or {}
        if command == "replay" and r.get("kind") == "slewing":
            governing = r.get("fatigue_governing_row")
            row.update({k: r.get(k, "") for k in SLEWING_REPLAY_COLUMNS},
                       fatigue_damage=r.get(f"fatigue_damage_{governing}", ""),
                       fatigue_remaining_life_h=r.get(f"fatigue_remaining_life_{governing}_h", ""))
        elif command == "replay":
            row.update({k: r.get(k, "") for k in REPLAY_COLUMNS})
        elif r:
            final = r["final"]
            row.update(named_effects=" ".join(r["named_effects"]), wear_coefficient=final["wear_coefficient"],
                       wear_coefficient_std_error=final["wear_coefficient_std_error"],
                       rmse_um=final["rmse_um"], heldout_rmse_um=final["heldout_rmse_um"],
                       measurements=r["data"]["measurements"], duration_h=r["data"]["duration_h"],
                       messages=r.get("messages", ""))
        else:
            row.update({k: "" for k in DIAGNOSE_COLUMNS})
        row["error"] = e["error"]
        rows.append(row)
    return rows


def _cell(value) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def write_tables(out: Path, rows: list[dict[str, Any]], entries: list[dict[str, Any]],
                 summary: dict[str, Any]) -> dict[str, str]:
    """fleet.csv, fleet.md and fleet.json (summary + every bag's full result) in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"csv": str(out / "fleet.csv"), "md": str(out / "fleet.md"), "json": str(out / "fleet.json")}
    # a fleet of guides and slewing bearings: every column of either, in first-seen order, blank where none
    columns = list(dict.fromkeys(c for row in rows for c in row)) if rows else ["machine", "bag", "status", "error"]
    with open_output(files["csv"]) as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        writer.writerows([[_cell(row.get(c, "")) for c in columns] for row in rows])
    lines = [f"# Fleet {summary['command']}: {summary['bags']} bags, {summary['ok']} ok, {summary['failed']} failed",
             "", "| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row.get(c, "")).replace("|", "/") for c in columns) + " |")
    write_text(files["md"], "\n".join(lines) + "\n")
    write_text(files["json"], json_text({"summary": summary, "bags": entries}, indent=1) + "\n")
    return files


def ranking(rows: list[dict[str, Any]]) -> tuple[str, list[dict[str, Any]]]:
    """(key, rows) of the ranking: by remaining precision life [h] ascending when the rows have it, else (a
    fleet of slewing bearings) by the governing row's remaining fatigue life, else by the wear coefficient
    descending (diagnose); failed bags and rows without the number are left out."""
    key = next((k for k in ("remaining_life_h", "fatigue_remaining_life_h")
                if any(isinstance(r.get(k), float) for r in rows)), "wear_coefficient")
    ok = [r for r in rows if r["status"] == "ok" and isinstance(r.get(key), (int, float))
          and not math.isnan(r[key])]
    ok.sort(key=lambda r: r[key], reverse=key == "wear_coefficient")
    return key, ok


def plot_ranking(path: Path, rows: list[dict[str, Any]], title: str) -> None:
    """Horizontal bars, worst machine on top: remaining life with its 90 % interval (replay), or K
    with +-1 standard error (diagnose)."""
    from guide_health.analysis.report_plots import _pyplot, _save_figure

    plt = _pyplot()
    key, ranked = ranking(rows)
    fig, ax = plt.subplots(figsize=(7.5, 1.6 + 0.32 * max(1, len(ranked))))
    labels = [r["machine"] if r["machine"] == Path(r["bag"]).name else f"{r['machine']} ({Path(r['bag']).name})"
              for r in ranked]
    y = list(range(len(ranked)))[::-1]
    if key == "remaining_life_h":
        values = [min(r[key], 1e9) for r in ranked]
        lo = [max(0.0, v - r["remaining_life_h_low"]) for v, r in zip(values, ranked)]
        hi = [max(0.0, min(r["remaining_life_h_high"], 1e9) - v) for v, r in zip(values, ranked)]
        colors = ["#c0392b" if r.get("level_name") == "ERROR" else "#e69f00" if r.get("level_name") == "WARN"
                  else "#2e86c1" for r in ranked]
        ax.barh(y, values, xerr=[lo, hi], color=colors, capsize=3)
        ax.set_xlabel("remaining precision life [h] (90 % interval)")
    elif key == "fatigue_remaining_life_h":
        ax.barh(y, [min(r[key], 1e12) for r in ranked], color="#2e86c1")
        ax.set_xscale("log")
        ax.set_xlabel("remaining fatigue life of the governing row [h] (the duty so far, continued)")
    else:
        values = [r[key] for r in ranked]
        err = [r.get("wear_coefficient_std_error") or 0.0 for r in ranked]
        ax.barh(y, values, xerr=err, color="#2e86c1", capsize=3)
        ax.set_xlabel("wear coefficient K (+-1 s.e.), highest first")
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_title(title, fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    _save_figure(plt, fig, path)
