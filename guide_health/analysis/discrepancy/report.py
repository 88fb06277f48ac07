"""Files of ``guide-health diagnose``: report.json, report.md, residuals.csv and diagnose.png."""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from guide_health.analysis.discrepancy.model_file import live_parameter_text, not_live_effects
from guide_health.analysis.discrepancy.naming_text import naming_lead_lines, resolution_markdown
from guide_health.analysis.rejections import diagnose_lead_lines, diagnose_tail_lines
from guide_health.analysis.report_plots import plot_forecast
from guide_health.io.outputs.files import open_output, save_figure, write_text
from guide_health.io.outputs.json_text import json_text


def _fmt(v: float, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    return f"{v:.4g}{(' ' + unit) if unit and unit != '-' else ''}"


def model_file_lines(result: dict[str, Any]) -> list[str]:
    """What model.yaml (beside the report) gives the live monitor, and how to load it."""
    model = result.get("model_file") or {}
    live = [e for e in str(model["effects"]).split(",") if e] if model else []
    out = [f"`model.yaml` holds K = {model['wear_coefficient'] if model else math.nan:.4g} and "
           + (f"the effects the live monitor integrates: {', '.join(live)}." if live else "no effect (plain Archard).")]
    if model:
        out.append(f"Refitted on every measurement (the values above left the held-out span out): "
                   f"{live_parameter_text(model)}.")
    skipped = not_live_effects(result["named_effects"])
    if skipped:
        out.append(f"Named but not applied live: {', '.join(skipped)}.")
    out += left_out_lines(result)
    if result.get("unexplained_structure", {}).get("present") and live:
        out.append("The residuals still have structure: these effects are fitted, not an explanation.")
    out.append("Load it after the base parameters: `guide-health replay BAG --params BASE --params model.yaml`, or "
               "`wear_monitor --ros-args --params-file BASE --params-file model.yaml` (docs/model_file.md).")
    return out


def left_out_lines(result: dict[str, Any]) -> list[str]:
    """The named effects model.yaml leaves out (readings, ties an alternative leads: consistency.model_effects)
    and what stands in their place."""
    left = {e: c.get("in_model_file_in_its_place", "") for e, c in result.get("effects", {}).items()
            if not c.get("in_model_file", True)}
    if not left:
        return []
    parts = [f"{e}, a {result['effects'][e]['status']}" + (f" ({alt} in its place)" if alt else "")
             for e, alt in left.items()]
    return ["Left out of model.yaml (the record prefers another form; the live remaining life is not forecast "
            f"from it): {'; '.join(parts)}."]


def _nothing_named(result: dict[str, Any]) -> str:
    """Why nothing is named: too little data, rejected input, or the baseline explains the data."""
    if result.get("data_resolution", {}).get("too_little_data"):
        return "No effect named: too little data (above, and the table below)."
    if result.get("rejected_wear", {}).get("explains_misfit"):
        return "No effect named: the rejected input could explain the misfit (above)."
    return "No candidate earned its parameters: the baseline (K calibrated) explains the measurements to their noise."


def markdown(result: dict[str, Any], bag: str = "") -> str:
    b, f, d = result["baseline"], result["final"], result["data"]
    where = result["where_baseline_disagrees"]
    lines = [f"# Discrepancy report{(': ' + bag) if bag else ''}", ""] + diagnose_lead_lines(result, markdown=True)
    structure = result.get("unexplained_structure", {})
    if structure.get("present"):
        lines += [f"> **{structure['message']}**", ""]
    lines.append(f"{d['measurements']} straightness measurements over {d['duration_h']:.1f} h "
                 f"({d['fit_measurements']} fitted, the last {d['heldout_measurements']} from "
                 f"{d['heldout_from_h']:.1f} h held out for forecasts); {d['sliding_distance_m']:.0f} m of sliding.")
    lines.append("")
    lines += naming_lead_lines(result, markdown=True)
    named = result["named_effects"]
    if structure.get("present"):
        lines.append("## Effects named: NOT an explanation (structure remains)" if named
                     else "## No library effect explains the structure")
    else:
        lines.append("## Effects named" if named else "## No missing effect found")
    lines.append("")
    withheld = (result.get("data_resolution", {}).get("too_little_data")
                or result.get("rejected_wear", {}).get("explains_misfit"))
    if not named and (withheld or not structure.get("present")):
        lines.append(_nothing_named(result))
    for e in named:
        info = result["effects"][e]
        params = ", ".join(f"{k} = {_fmt(p['value'], p['unit'])} ± {_fmt(p['std_error'], p['unit'])}"
                           for k, p in info["parameters"].items())
        status = f" ({info['status']})" if "status" in info else ""
        lines.append(f"- **{e}**{status}: {info['meaning']} ({params})")
    for tie in result.get("near_ties", []):
        lines.append(f"- near-tie: {tie['message']}")
    for d in result.get("dropped_by_backward_pass", []):
        lines.append(f"- dropped by the backward pass: {d['effect']} (BIC rises by only {d['delta_bic']:.1f} "
                     "without it)")
    tail = diagnose_tail_lines(result, markdown=True)
    lines += ["", *tail[:-1]] if tail else []
    if "bags" in result:
        lines += ["", f"Read from {len(result['bags'])} bags in time order; gaps between them:"]
        lines += [f"- {g['start_utc']} .. {g['end_utc']} ({g['duration_s']:.3f} s)" for g in result["gaps"]]
    lines += ["", "## The live model (model.yaml)", ""] + model_file_lines(result)
    lines += ["", "## The gap", "", "| model | RMSE fit [um] | max rel. error fit | RMSE held out [um] | "
              "max rel. error held out | K |", "|---|---|---|---|---|---|"]
    for label, g in (("baseline (K calibrated)", b), ("with " + (" + ".join(named) or "nothing"), f)):
        lines.append(f"| {label} | {g['rmse_um']:.3f} | {g['max_rel_error']:.3%} | {g['heldout_rmse_um']:.3f} | "
                     f"{g['heldout_max_rel_error']:.3%} | {g['wear_coefficient']:.4g} |")
    if "steady_stage" in result:
        s = result["steady_stage"]
        lines += ["", f"Steady stage (from {s['from_h']:.1f} h, after 3 running-in distances): max relative "
                      f"error {s['baseline_max_rel_error']:.1%} (baseline) -> {s['final_max_rel_error']:.1%}."]
    lines += ["", *resolution_markdown(result), "## Where the baseline disagrees", ""]
    rt, ac = where["runs_test"], where["lag1_autocorrelation"]
    lines.append(f"- residual RMS {where['residual_rms_um']:.3f} um against a noise of "
                 f"{where['noise_sd_um']:.3f} um (successive differences)")
    lines.append(f"- runs test: {rt['runs']} runs of residual sign, {_fmt(rt['expected_runs'])} expected, "
                 f"z = {rt['z']:.2f}, p = {rt['p_value']:.2g}; lag-1 autocorrelation {ac['r']:.2f} "
                 f"(z = {ac['z']:.2f}, p = {ac['p_value']:.2g}): "
                 f"{'systematic' if where['systematic_in_time'] else 'no structure'} in time")
    for w in where["windows"]:
        lines.append(f"- window {w['start_h']:.1f}..{w['end_h']:.1f} h: {w['measurements']} residuals of one sign, "
                     f"mean {w['mean_residual_um']:+.2f} um (t = {w['t_statistic']:.1f})")
    for c in where["conditions"]:
        lines.append(f"- {c['condition']} (range {c['range'][0]:.4g}..{c['range'][1]:.4g}) vs "
                     f"{c['against'].replace('_', ' ')}: Spearman rho = {c['rho']:+.2f}, p = {c['p_value']:.2g}"
                     f"{' **systematic**' if c['systematic'] else ''}")
    lines += ["", "## Candidates tried", "", "| round | effect | dBIC | held-out RMSE [um] | earns its place | "
              "parameters |", "|---|---|---|---|---|---|"]
    for c in result["candidates"]:
        params = "; ".join(f"{k} = {_fmt(p['value'], p['unit'])}" for k, p in c["parameters"].items()
                           if k != "wear_coefficient")
        lines.append(f"| {c['round']} | {c['effect']} | {c['delta_bic']:+.1f} | {c['heldout_rmse_um']:.3f} | "
                     f"{'yes' if c['earns_place'] else 'no'}{' (added)' if c['selected'] else ''} | {params} |")
    lines += ["", f"An effect is added when BIC drops by more than {result['selection']['bic_threshold']:g} and the "
                  "held-out forecast error does not grow beyond its sampling error; of those, the one with the "
                  "best BIC + held-out log-likelihood is added and the search repeats.", ""]
    return "\n".join(lines)


def preload_plotting() -> None:
    """Import what :func:`plot` needs (matplotlib with the Agg backend), e.g. while a child reads the bag."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401



def plot(result: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = result["series"]
    t, y, b, f, held = (np.asarray(s[k]) for k in ("t_h", "measured_um", "baseline_um", "final_um", "heldout"))
    named = " + ".join(result["named_effects"]) or "no effect"
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    if held.any():
        for ax in (ax1, ax2):
            ax.axvspan(t[held][0], t[-1], color="0.92", label="held out" if ax is ax1 else None)
    ax1.plot(t, y, "o", ms=3.5, color="k", label="measured")
    ax1.plot(t, b, "-", color="tab:red", label=f"baseline (K calibrated), held-out RMSE "
                                                f"{result['baseline']['heldout_rmse_um']:.2f} um")
    ax1.plot(t, f, "-", color="tab:blue",
             label=f"with {named}, held-out RMSE {result['final']['heldout_rmse_um']:.2f} um")
    ax1.set_ylabel("straightness [um]")
    if result.get("forecast"):
        fc = {k: np.asarray(v) if isinstance(v, list) else v for k, v in result["forecast"].items()}
        plot_forecast(ax1, fc, " + ".join(result["named_effects"]))
        ax1.axhline(fc["limit_um"], color="r", ls=":", lw=0.8)
    structure = result.get("unexplained_structure", {})
    if structure.get("present"):
        import textwrap

        fig.suptitle("\n".join(textwrap.wrap(structure["message"], 130)), color="tab:red", fontsize=8.5,
                     fontweight="bold")
        ax1.set_title(f"UNEXPLAINED STRUCTURE - fitted with {named} (not an explanation)", color="tab:red")
        for w in structure["where"]:
            ax2.axvspan(w["start_h"], w["end_h"], color="tab:red", alpha=0.12)
    else:
        ax1.set_title(f"{'axis ' + result['axis'] + ': ' if 'axis' in result else ''}discrepancy workflow: {named}")
    ax1.legend(loc="upper left", fontsize=8)
    ax1.grid(alpha=0.3)
    ax2.axhline(0.0, color="0.5", lw=0.8)
    ax2.plot(t, y - b, "o-", ms=3, lw=0.8, color="tab:red", label="measured - baseline")
    ax2.plot(t, y - f, "o-", ms=3, lw=0.8, color="tab:blue", label=f"measured - with {named}")
    ax2.set_xlabel("time [h]")
    ax2.set_ylabel("residual [um]")
    ax2.legend(loc="lower left", fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    try:
        save_figure(fig, path)
    finally:
        plt.close(fig)


def write_report(result: dict[str, Any], out: Path, bag: str = "", with_plot: bool = True,
                 plot_with=None) -> dict[str, str]:
    """Write the report files; returns their paths. ``result['series']`` is written to CSV, not JSON.
    ``plot_with(result, path)``: draws the PNG instead of :func:`plot` (e.g. in another process)."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json"), "markdown": str(out / "report.md"), "csv": str(out / "residuals.csv")}
    write_residuals(Path(files["csv"]), result["series"])
    if with_plot:
        files["png"] = str(out / "diagnose.png")
        (plot_with or plot)(result, Path(files["png"]))
    write_text(files["markdown"], markdown(result, bag))
    body = {k: v for k, v in result.items() if k != "series"}
    body["files"] = files
    write_text(files["json"], json_text(body, indent=2, default=float) + "\n")
    return files


def write_residuals(path: Path, s: dict[str, Any]) -> None:
    """residuals.csv: measured, baseline and final model at every measurement, and whether it was held out."""
    with open_output(path) as handle:
        w = csv.writer(handle)
        w.writerow(["time_h", "measured_um", "baseline_um", "final_um", "heldout"])
        for row in zip(s["t_h"], s["measured_um"], s["baseline_um"], s["final_um"], s["heldout"]):
            w.writerow([f"{row[0]:.6f}", f"{row[1]:.6f}", f"{row[2]:.6f}", f"{row[3]:.6f}", int(row[4])])


def write_axes_report(report: dict[str, Any], out: Path, bag: str = "", with_plot: bool = True) -> dict[str, str]:
    """The report files of a machine of several axes (``report["axes"]``: each axis's workflow result, with
    its series): report.md with a section per axis, residuals_<axis>.csv, diagnose_<axis>.png and report.json
    (without the series). Returns the files."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json"), "markdown": str(out / "report.md")}
    sections = []
    for axis, result in report["axes"].items():
        files[f"csv_{axis}"] = str(out / f"residuals_{axis}.csv")
        write_residuals(Path(files[f"csv_{axis}"]), result["series"])
        if with_plot:
            files[f"png_{axis}"] = str(out / f"diagnose_{axis}.png")
            plot(result, Path(files[f"png_{axis}"]))
        sections.append(markdown(result, f"{bag}, axis {axis}" if bag else f"axis {axis}"))
    write_text(files["markdown"], "\n".join(sections))
    body = {k: v for k, v in report.items() if k != "axes"}
    body["axes"] = {axis: {k: v for k, v in r.items() if k != "series"} for axis, r in report["axes"].items()}
    body["files"] = files
    write_text(files["json"], json_text(body, indent=2, default=float) + "\n")
    return files
