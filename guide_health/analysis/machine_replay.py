"""Offline replay of a whole-machine bag: every axis through its :class:`AxisMonitor` (the live node's model
object per axis), the report ``{"axes": {axis: <axis precision status values>}, ...}``."""
from __future__ import annotations

import csv
import math
import time
from pathlib import Path

from guide_health.analysis.rejections import InputTally
from guide_health.analysis.replay import add_rejections, maintenance_list, model_curve
from guide_health.analysis.report_plots import plot_straightness_report
from guide_health.io.bag.bag_set import iter_source_chunks, source_events
from guide_health.io.outputs.files import open_output, write_text
from guide_health.io.outputs.json_text import json_text
from guide_health.models.levels import LEVEL_NAMES
from guide_health.models.wear.axis import PRECISION_KEYS, AxisMonitor
from guide_health.params.typed import wear_axis_params

ROLES = ("guide/load", "guide/straightness", "guide/temperature")
TOPIC_KEYS = ("load_topic", "straightness_topic", "temperature_topic")


def axis_topics(params: dict) -> dict[str, str]:
    """{role: relative topic} of an axis (io.bag.reader.iter_machine_bag's ``topics``)."""
    return dict(zip(ROLES, (params[k] for k in TOPIC_KEYS)))


def axis_report(model: AxisMonitor) -> dict:
    """The axis's `<axis> precision` values (+ ``fatigue`` for rolling guides, ``guides`` for several)."""
    report = model.report()
    for key in PRECISION_KEYS:                # every key of the status, nan where it has none (sliding)
        report.setdefault(key, math.nan)
    if model.rolling is not None:
        report["fatigue"] = model.fatigue_report()
    if len(model.guides) > 1:
        report["guides"] = model.guide_reports()
    report["level_name"] = LEVEL_NAMES[int(report["level"])]
    return report


def analyse_machine_bag(bag, axes: dict[str, dict], namespace: str | None = None, progress=None,
                        chunk_messages: int = 200_000) -> tuple[dict[str, AxisMonitor], dict]:
    """Every axis of ``axes`` (params/machine.py axes_params) over the bag, one pass per axis, with the bag's
    maintenance events (maintenance/events) applied at their stamps; ``bag``: a path or a BagSet (several bags
    in time order). Returns the models and the report."""
    models = {}
    t0 = time.perf_counter()
    bag_events = source_events(bag, namespace)
    stamps = []
    messages = 0
    tallies = {}
    for axis, params in axes.items():
        model = models[axis] = AxisMonitor(wear_axis_params(params))
        tally = tallies[axis] = InputTally()
        for event in bag_events:
            if event.axis == axis:
                model.schedule(event)
        for chunk in iter_source_chunks(bag, joint=params["joint"], namespace=namespace, progress=progress,
                                        chunk_messages=chunk_messages, topics=axis_topics(params)):
            model.process_run(chunk)
            tally.add(chunk)
            messages += chunk.messages if axis == next(iter(axes)) else chunk.messages - chunk.joint_t_ns.size
            stamps.extend(int(a[i]) for a in (chunk.joint_t_ns, chunk.load_t_ns) if a.size for i in (0, -1))
    reports = {axis: dict(axis_report(model), maintenance_events=maintenance_list(model))
               for axis, model in models.items()}
    for axis, model in models.items():
        add_rejections(reports[axis], model.rejected, tallies[axis], axes[axis])
    worst = min(reports, key=lambda a: (-int(reports[a]["level"]), _life(reports[a]["remaining_life_h"])))
    report = {
        "axes": reports,
        "machine_id": next(iter(axes.values()))["machine_id"],
        "level": int(reports[worst]["level"]),
        "level_name": LEVEL_NAMES[int(reports[worst]["level"])],
        "message": f"{worst}: {reports[worst]['message']}",
        "messages": messages,
        "duration_h": (max(stamps) - min(stamps)) * 1e-9 / 3600.0 if stamps else 0.0,
        "model_s": time.perf_counter() - t0,
    }
    return models, report


def _life(life_h: float) -> float:
    return math.inf if math.isnan(life_h) else life_h


def write_machine_outputs(out: Path, models: dict[str, AxisMonitor], report: dict, plot: bool) -> dict[str, str]:
    """report.json and, per axis, straightness_<axis>.csv (measured, model, residual at the measurements of
    its worst guide) and with ``plot`` straightness_<axis>.png; returns the files written."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json")}
    for axis, model in models.items():
        guide = model.guide(report["axes"][axis].get("guide", model.primary_name))
        t_h, measured, fitted = model_curve(guide)
        files[f"csv_{axis}"] = str(out / f"straightness_{axis}.csv")
        with open_output(files[f"csv_{axis}"]) as handle:
            writer = csv.writer(handle)
            writer.writerow(["time_h", "straightness_measured_um", "straightness_model_um", "residual_um"])
            for row in zip(t_h, measured, fitted, measured - fitted):
                writer.writerow([f"{v:.6f}" for v in row])
        if plot:
            files[f"png_{axis}"] = str(out / f"straightness_{axis}.png")
            plot_straightness_report(Path(files[f"png_{axis}"]), guide, report["axes"][axis], t_h, measured, fitted,
                                     name=f"axis {axis} (guide {guide.name})")
    report["files"] = files
    write_text(files["json"], json_text(report, indent=2, default=float) + "\n")
    return files
