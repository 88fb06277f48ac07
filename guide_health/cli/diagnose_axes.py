"""`guide-health diagnose` on a machine of several axes (wear_monitor ``axes``): the discrepancy workflow per
axis, on the axis's own topics, with its wear resets (regrind, new rail) splitting its record; ``--axis``
chooses one. The report holds ``axes: {axis: <the single-axis result>}``."""
from __future__ import annotations

import time

from guide_health.analysis.discrepancy.duty import read_duty_cells
from guide_health.analysis.discrepancy.model import MIN_MEASUREMENTS
from guide_health.analysis.machine_replay import axis_topics
from guide_health.cli.text import bag_set_lines
from guide_health.errors import InputError
from guide_health.io.bag.bag_set import BagSet, source_events
from guide_health.io.outputs.progress import ProgressBar
from guide_health.models.wear.maintenance import relubrication_times_s, wear_resets
from guide_health.params import validate_wear_params
from guide_health.params.machine import axes_params


def chosen_axes(axes: dict, axis: str | None) -> list[str]:
    """Every axis, or ``--axis``; InputError (one line naming the axes present) for an unknown one."""
    if axis is None:
        return list(axes)
    if axis not in axes:
        raise InputError(f"--axis {axis}: no such axis (axes present: {', '.join(axes)})")
    return [axis]


def check_counts(cells: dict) -> None:
    """InputError naming the axis and every axis's count when one has too few straightness measurements."""
    counts = {axis: int(c.measurement_m.size) for axis, c in cells.items()}
    short = [axis for axis, n in counts.items() if n < MIN_MEASUREMENTS]
    if short:
        per_axis = ", ".join(f"{a}: {n}" for a, n in counts.items())
        raise InputError(f"axis {short[0]} has {counts[short[0]]} straightness measurements, the discrepancy workflow "
                         f"needs at least {MIN_MEASUREMENTS} per axis ({per_axis}; choose an axis with --axis)")


def read_axes(args, axes: dict, chosen: list[str], bag, events: list) -> tuple[dict, dict]:
    """Duty cells and messages read per chosen axis (one pass each over the bag), one progress bar."""
    bar = ProgressBar("reading", force=args.progress)
    cells, messages = {}, {}
    for k, axis in enumerate(chosen):
        def progress(done, total, k=k):
            bar(k * total + done, len(chosen) * total)
        cells[axis], messages[axis] = read_duty_cells(bag, axes[axis], args.namespace, progress,
                                                      resets=wear_resets(events, axis), topics=axis_topics(axes[axis]))
    bar.close()
    return cells, messages


def run_axes(args, params: dict, bag, threshold) -> dict:
    from guide_health.analysis.discrepancy.model_file import write_axes_model_file
    from guide_health.analysis.discrepancy.report import write_axes_report
    from guide_health.analysis.discrepancy.selection import BIC_THRESHOLD
    from guide_health.analysis.discrepancy.workflow import diagnose_cells
    from guide_health.cli.diagnose import _fit_workers, report_dir

    axes = axes_params(params, validate_wear_params)
    chosen = chosen_axes(axes, args.axis)
    t0 = time.perf_counter()
    events = source_events(bag, args.namespace)
    cells, messages = read_axes(args, axes, chosen, bag, events)
    check_counts(cells)
    t_read = time.perf_counter() - t0
    results = {}
    for axis in chosen:
        try:
            results[axis] = diagnose_cells(
                cells[axis], axes[axis], heldout_fraction=args.heldout_fraction,
                bic_threshold=BIC_THRESHOLD if threshold is None else threshold,
                relubrication_t_s=relubrication_times_s(events, axis, cells[axis].t0_ns), workers=_fit_workers())
        except ValueError as exc:
            raise InputError(f"{bag}: axis {axis}: {exc}") from None
        results[axis].update(axis=axis, messages=messages[axis])
        if cells[axis].reset_t_s.size:
            results[axis]["data"]["wear_resets"] = [
                {"t_h": float(t / 3600.0), "straightness_after_um": float(a * 1e6)}
                for t, a in zip(cells[axis].reset_t_s, cells[axis].reset_straightness_m)]
    t_fit = time.perf_counter() - t0 - t_read
    out = report_dir(args)
    report = {"machine_id": params["machine_id"], "axes": results, "read_s": t_read, "fit_s": t_fit,
              **(bag.report() if isinstance(bag, BagSet) else {})}
    report["files"] = write_axes_report(report, out, bag=str(bag), with_plot=not args.no_plot)
    report["files"]["model"] = str(out / "model.yaml")
    write_axes_model_file(out / "model.yaml", axes, {a: r["model_file"] for a, r in results.items()},
                          {a: r["named_effects"] for a, r in results.items()}, source=str(bag),
                          unexplained={a: r["unexplained_structure"].get("message", "") for a, r in results.items()
                                       if r["unexplained_structure"].get("present")})
    for r in results.values():
        r.pop("series")
    report["total_s"] = time.perf_counter() - t0
    return report


def format_axes_text(report: dict) -> str:
    from guide_health.cli.diagnose import axis_text_lines

    lines = [f"machine {report['machine_id']}: discrepancy workflow per axis"]
    for axis, result in report["axes"].items():
        lines.append(f"axis {axis}:")
        lines.extend("  " + line for line in axis_text_lines(result, model_file=True))
    lines.extend(bag_set_lines(report, "  "))
    lines.append(f"  time:  read {report['read_s']:.1f} s, fit {report['fit_s']:.1f} s")
    lines.append(f"  files: {', '.join(report['files'].values())}")
    return "\n".join(lines)
