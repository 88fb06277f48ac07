"""Offline replay of a bag with the live nodes' model objects, and the report files it leaves.

A machine bag goes through the wear node's :class:`PrecisionMonitor` chunk by chunk (memory bounded by
one chunk); a slewing bag through the slewing node's core (analysis/slewing_replay.py). The report
directory holds report.json, the series as CSV and a PNG (analysis/report_plots.py).
"""
from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

from guide_health.analysis.rejections import InputTally, rejection_summary
from guide_health.analysis.report_plots import plot_slewing_contact_series, plot_straightness_report
from guide_health.io.bag.bag_set import iter_source_chunks, source_events
from guide_health.io.bag.reader import read_slewing_bag
from guide_health.io.outputs.files import open_output, write_text
from guide_health.io.outputs.json_text import json_text
from guide_health.models.wear.axis import AxisMonitor, split_run
from guide_health.models.wear.model_load import load_model
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params.typed import slewing_monitor_params, wear_axis_params


def monitor_report(monitor: PrecisionMonitor) -> dict:
    """The monitor's report, with the rolling-guide fatigue report when the guide rolls."""
    report = monitor.report()
    if monitor.rolling is not None:
        report["fatigue"] = monitor.fatigue_report()
    return report


def analyse(run, params: dict, progress=None) -> tuple[PrecisionMonitor, dict]:
    """Run the precision model over a MachineRun; returns the monitor and its report."""
    monitor = PrecisionMonitor(wear_axis_params(params))
    monitor.process_run(run, progress=progress)
    report = monitor_report(monitor)
    report["messages"] = run.messages
    report["duration_h"] = run.duration_s / 3600.0
    tally = InputTally()
    tally.add(run)
    add_rejections(report, monitor.rejected, tally, params)
    return monitor, report


def add_rejections(report: dict, rejected: dict, tally: InputTally, params: dict) -> None:
    """``report["rejections"]`` (analysis/rejections.py) when any sample was rejected."""
    summary = rejection_summary(dict(rejected), tally, params)
    if summary:
        report["rejections"] = summary


def process_with_load(model: AxisMonitor, chunk, load):
    """``model.process_run(chunk)``; ``load`` (at [ns], typed parameters) not None: the samples stamped at or
    before ``at`` first, then the model loaded (models/wear/model_load.py, as wear_monitor's ~/load_model
    called then), then the rest. Returns the load still to come (None once done)."""
    if load is None:
        model.process_run(chunk)
        return None
    head, tail = split_run(chunk, load[0])
    model.process_run(head)
    if not any(t.size for t in (tail.joint_t_ns, tail.load_t_ns, tail.straightness_t_ns, tail.temperature_t_ns)):
        return load
    load_model(model, load[1])
    model.process_run(tail)
    return None


def analyse_bag(bag, params: dict, namespace: str | None = None, progress=None,
                chunk_messages: int = 200_000, load=None) -> tuple[PrecisionMonitor, dict, dict]:
    """Stream a bag through the precision model chunk by chunk (memory bounded by one chunk, whatever
    the bag's size); identical to analyse(read_machine_bag(bag)) to rounding. ``bag``: a path or a BagSet
    (io/bag/bag_set.py: several bags in time order, one model streaming across them). ``load``: (at [ns],
    typed parameters) a model file loaded over the model at that stamp (after the record: at its end;
    :func:`process_with_load`). Returns the monitor, its report and timings {read_s, model_s}."""
    model = AxisMonitor(wear_axis_params(params))   # one guide: the PrecisionMonitor, plus the bag's events
    events = source_events(bag, namespace)
    for event in events:
        if event.axis == model.axis:
            model.schedule(event)
    monitor = model.guide()
    messages = 0
    t_first = t_last = None
    t_model = 0.0
    t0 = time.perf_counter()
    stats: dict = {}
    tally = InputTally()
    for chunk in iter_source_chunks(bag, joint=params["joint"], namespace=namespace, progress=progress,
                                    chunk_messages=chunk_messages, stats=stats):
        t1 = time.perf_counter()
        load = process_with_load(model, chunk, load)
        t_model += time.perf_counter() - t1
        tally.add(chunk)
        messages += chunk.messages
        stamps = [a for a in (chunk.joint_t_ns, chunk.load_t_ns, chunk.straightness_t_ns) if a.size]
        if stamps:
            lo, hi = min(int(a[0]) for a in stamps), max(int(a[-1]) for a in stamps)
            t_first = lo if t_first is None else min(t_first, lo)
            t_last = hi if t_last is None else max(t_last, hi)
    t1 = time.perf_counter()
    if load is not None:          # stamped after the record: loaded at its end
        load_model(model, load[1])
    report = monitor_report(monitor)
    if events:
        report["maintenance_events"] = maintenance_list(model)
    t_model += time.perf_counter() - t1
    report["messages"] = messages
    report["duration_h"] = (t_last - t_first) * 1e-9 / 3600.0 if t_first is not None else 0.0
    if "bag_count_mismatch" in stats:       # metadata.yaml counts that disagree with the stored rows
        report["bag_count_mismatch"] = stats["bag_count_mismatch"]
    add_rejections(report, model.rejected, tally, params)
    return monitor, report, {"read_s": time.perf_counter() - t0 - t_model, "model_s": t_model}


def maintenance_list(model) -> list[dict]:
    """The maintenance events of an AxisMonitor for the report: applied ones, then pending ones (stamped after
    the last joint sample), each with ``applied``."""
    return ([dict(e.as_dict(), applied=True) for e in model.events]
            + [dict(e.as_dict(), applied=False) for e in model.pending])


def model_curve(monitor: PrecisionMonitor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t [h] from the first joint sample, measured [um], model [um]) at the measurement times."""
    est = monitor.estimator
    t0 = monitor.integrator.first_t_ns or 0
    t_h = (np.asarray(est.measurement_t_ns, dtype=np.int64) - t0) * 1e-9 / 3600.0
    k = monitor.report()["wear_coefficient"]
    model = monitor.straightness_m(k, monitor.measurement_losses_per_k_m()) * 1e6
    return t_h, np.asarray(est.measurement_m) * 1e6, model


def write_outputs(out: Path, monitor: PrecisionMonitor, report: dict, plot: bool) -> dict[str, str]:
    """report.json, straightness.csv (measured, model, residual at the measurements) and, with ``plot``,
    straightness.png in ``out``; returns the files written {json, csv[, png]}."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json"), "csv": str(out / "straightness.csv")}
    write_text(files["json"], json_text(report, indent=2) + "\n")
    t_h, measured, model = model_curve(monitor)
    with open_output(files["csv"]) as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_h", "straightness_measured_um", "straightness_model_um", "residual_um"])
        for row in zip(t_h, measured, model, measured - model):
            writer.writerow([f"{v:.6f}" for v in row])
    if plot:
        files["png"] = str(out / "straightness.png")
        plot_straightness_report(Path(files["png"]), monitor, report, t_h, measured, model)
    return files


def analyse_slewing_bag(bag: Path, params: dict, namespace: str | None = None, progress=None):
    """Every load of a slewing bag through the slewing monitor core. Returns the run, the report (the
    worst roller of the run), the highest roller pressure of each sample [MPa] and timings {read_s, model_s}."""
    from guide_health.analysis.slewing_replay import analyse_slewing_run

    axis = slewing_monitor_params(params)      # the slewing axis's topic and joint, as the node subscribes
    t0 = time.perf_counter()
    run = read_slewing_bag(bag, namespace=namespace, axis_topic=axis.axis_topic, axis_joint=axis.axis_joint)
    t_read = time.perf_counter() - t0
    _, report = analyse_slewing_run(run, params, progress=progress)
    series = report.pop("series")
    return run, report, series, {"read_s": t_read, "model_s": time.perf_counter() - t0 - t_read}


def write_slewing_outputs(out: Path, run, params: dict, report: dict, series: np.ndarray,
                          plot: bool) -> dict[str, str]:
    """contact.csv (loads and highest roller pressure per sample), with ``plot`` contact.png, then
    report.json (holding ``files``) in ``out``; returns the files {json, csv[, png]}."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json"), "csv": str(out / "contact.csv")}
    t_s = (np.asarray(run.t_ns) - (run.t_ns[0] if run.t_ns.size else 0)) * 1e-9
    with open_output(files["csv"]) as handle:
        np.savetxt(handle, np.c_[t_s, run.axial_n, run.radial_n, run.moment_nm, series], delimiter=",",
                   header="time_s,axial_n,radial_n,moment_nm,p_max_MPa", comments="", fmt="%.6g")
    if plot:
        files["png"] = str(out / "contact.png")
        plot_slewing_contact_series(Path(files["png"]), t_s, series, params, report)
    report["files"] = files
    write_text(files["json"], json_text(report, indent=2, default=float) + "\n")
    return files
