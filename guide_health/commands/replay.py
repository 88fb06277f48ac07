"""`guide-health replay BAG --params FILE`: offline analysis of a bag with the live node's model objects."""
from __future__ import annotations

import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from guide_health.models.levels import LEVEL_NAMES
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import wear_monitor_params


def add_arguments(parser) -> None:
    parser.add_argument("bag", help="rosbag2 directory (sqlite3 or mcap)")
    parser.add_argument("--params", required=True, help="ROS 2 parameters YAML (wear_monitor section)")
    parser.add_argument("--out", help="report directory (default: <bag>.report beside the bag)")
    parser.add_argument("--namespace", default=None, help="topic namespace in the bag (default: detect)")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    parser.add_argument("--progress", action="store_true", help="force the progress bar even without a TTY")


def analyse(run, params: dict, progress=None) -> tuple[PrecisionMonitor, dict]:
    """Run the precision model over a MachineRun; returns the monitor and its report."""
    monitor = PrecisionMonitor(params)
    monitor.process_run(run, progress=progress)
    report = monitor.report()
    if monitor.rolling is not None:
        report["fatigue"] = monitor.fatigue_report()
    report["messages"] = run.messages
    report["duration_h"] = run.duration_s / 3600.0
    return monitor, report


def analyse_bag(bag, params: dict, namespace: str | None = None, progress=None,
                chunk_messages: int = 200_000) -> tuple[PrecisionMonitor, dict, dict]:
    """Stream a bag through the precision model chunk by chunk (memory bounded by one chunk, whatever
    the bag's size); identical to analyse(read_machine_bag(bag)) to rounding. Returns the monitor, its
    report and timings {read_s, model_s}."""
    from guide_health.io.bag_reader import iter_machine_bag

    monitor = PrecisionMonitor(params)
    messages = 0
    t_first = t_last = None
    t_model = 0.0
    t0 = time.perf_counter()
    for chunk in iter_machine_bag(bag, joint=params["joint"], namespace=namespace, progress=progress,
                                  chunk_messages=chunk_messages):
        t1 = time.perf_counter()
        monitor.process_run(chunk)
        t_model += time.perf_counter() - t1
        messages += chunk.messages
        stamps = [a for a in (chunk.joint_t_ns, chunk.load_t_ns, chunk.straightness_t_ns) if a.size]
        if stamps:
            lo, hi = min(int(a[0]) for a in stamps), max(int(a[-1]) for a in stamps)
            t_first = lo if t_first is None else min(t_first, lo)
            t_last = hi if t_last is None else max(t_last, hi)
    t1 = time.perf_counter()
    report = monitor.report()
    if monitor.rolling is not None:
        report["fatigue"] = monitor.fatigue_report()
    t_model += time.perf_counter() - t1
    report["messages"] = messages
    report["duration_h"] = (t_last - t_first) * 1e-9 / 3600.0 if t_first is not None else 0.0
    return monitor, report, {"read_s": time.perf_counter() - t0 - t_model, "model_s": t_model}


def model_curve(monitor: PrecisionMonitor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t [h] from the first joint sample, measured [um], model [um]) at the measurement times."""
    est = monitor.estimator
    t0 = monitor.integrator.first_t_ns or 0
    t_h = (np.asarray(est.measurement_t_ns, dtype=np.int64) - t0) * 1e-9 / 3600.0
    k = monitor.report()["wear_coefficient"]
    model = (monitor.params["straightness_initial_m"] + k * monitor.measurement_losses_per_k_m()) * 1e6
    return t_h, np.asarray(est.measurement_m) * 1e6, model


def write_outputs(out: Path, monitor: PrecisionMonitor, report: dict, plot: bool) -> dict[str, str]:
    out.mkdir(parents=True, exist_ok=True)
    files = {"json": str(out / "report.json"), "csv": str(out / "straightness.csv")}
    Path(files["json"]).write_text(json.dumps(report, indent=2, allow_nan=True) + "\n")
    t_h, measured, model = model_curve(monitor)
    with open(files["csv"], "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_h", "straightness_measured_um", "straightness_model_um", "residual_um"])
        for row in zip(t_h, measured, model, measured - model):
            writer.writerow([f"{v:.6f}" for v in row])
    if plot:
        files["png"] = str(out / "straightness.png")
        plot_report(Path(files["png"]), monitor, report, t_h, measured, model)
    return files


def plot_report(path: Path, monitor: PrecisionMonitor, report: dict, t_h, measured, model) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(t_h, measured, "o", ms=4, label="measured")
    ax1.plot(t_h, model, "-", label=f"model (K = {report['wear_coefficient']:.3g})")
    ax1.axhline(report["straightness_limit_um"], color="r", ls="--", label="limit")
    ax1.set_xlabel("time [h]")
    ax1.set_ylabel("straightness [um]")
    life = report["remaining_life_h"]
    ax1.set_title(f"remaining precision life {life:.0f} h "
                  f"[{report['remaining_life_h_low']:.0f}, {report['remaining_life_h_high']:.0f}]"
                  if math.isfinite(life) else "straightness")
    ax1.legend()
    ax1.grid(alpha=0.3)
    u = monitor.geometry.bin_centres_m()
    depth_um = report["wear_coefficient"] * monitor.integrator.profile_depth_per_k_m() * 1e6
    ax2.plot(u * 1e3, -depth_um)
    ax2.set_xlabel("rail position [mm]")
    ax2.set_ylabel("wear profile [um]")
    ax2.set_title("wear along the rail (profile model)")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def is_slewing_bag(bag: Path) -> bool:
    from guide_health.io.bag_info import bag_topic_types

    topics = bag_topic_types(bag)
    return (any(t.endswith("slewing/load") for t in topics)
            and not any(t.endswith("joint_states") for t in topics))


def run_slewing(args, bag: Path) -> dict:
    """A slewing bag: every load through the slewing_monitor core; the worst roller of the run."""
    from guide_health.io.bag_reader import read_slewing_bag
    from guide_health.io.progress import ProgressBar
    from guide_health.analysis.slewing_replay import analyse_slewing_run
    from guide_health.params import SLEWING_MONITOR_DEFAULTS, load_node_params

    params = load_node_params(args.params, "slewing_monitor", SLEWING_MONITOR_DEFAULTS)
    t0 = time.perf_counter()
    run = read_slewing_bag(bag, namespace=args.namespace)
    t_read = time.perf_counter() - t0
    bar = ProgressBar("contact", force=args.progress)
    _, report = analyse_slewing_run(run, params, progress=bar)
    bar.close()
    series = report.pop("series")
    out = Path(args.out) if args.out else bag.with_name(bag.name + ".report")
    out.mkdir(parents=True, exist_ok=True)
    report.update(kind="slewing", read_s=t_read, model_s=time.perf_counter() - t0 - t_read,
                  level_name=LEVEL_NAMES[int(report.get("level", 1))])
    files = {"json": str(out / "report.json"), "csv": str(out / "contact.csv")}
    t_s = (np.asarray(run.t_ns) - (run.t_ns[0] if run.t_ns.size else 0)) * 1e-9
    np.savetxt(files["csv"], np.c_[t_s, run.axial_n, run.radial_n, run.moment_nm, series], delimiter=",",
               header="time_s,axial_n,radial_n,moment_nm,p_max_MPa", comments="", fmt="%.6g")
    if not args.no_plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        files["png"] = str(out / "contact.png")
        fig, ax = plt.subplots(figsize=(10, 4))
        ax.plot(t_s / 60.0, series, lw=0.6, label="highest roller pressure")
        allowable = params["allowable_contact_stress_pa"] * 1e-6
        ax.axhline(allowable, color="r", ls="--", label=f"allowable {allowable:.0f} MPa")
        ax.axhline(params["warn_fraction"] * allowable, color="orange", ls=":", label="warn")
        ax.set_xlabel("time [min]")
        ax.set_ylabel("p_max [MPa]")
        ax.set_title(f"{params['bearing']}: worst {report.get('p_max_MPa', float('nan')):.0f} MPa "
                     f"({params['stress_model']} model)")
        ax.legend(loc="lower right")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(files["png"], dpi=110)
        plt.close(fig)
    report["files"] = files
    Path(files["json"]).write_text(json.dumps(report, indent=2, allow_nan=True, default=float) + "\n")
    return report


def run(args) -> dict:
    from guide_health.io.progress import ProgressBar

    bag = Path(args.bag)
    if bag.exists() and is_slewing_bag(bag):
        return run_slewing(args, bag)
    params = wear_monitor_params(args.params)
    bar = ProgressBar("replay", force=args.progress)
    monitor, report, timing = analyse_bag(bag, params, namespace=args.namespace, progress=bar)
    bar.close()
    t_read, t_model = timing["read_s"], timing["model_s"]
    out = Path(args.out) if args.out else bag.with_name(bag.name + ".report")
    report["level_name"] = LEVEL_NAMES[report["level"]]
    report["read_s"] = t_read
    report["model_s"] = t_model
    report["files"] = write_outputs(out, monitor, report, plot=not args.no_plot)
    print(f"{report['messages']} messages in {t_read + t_model:.2f} s "
          f"({report['messages'] / max(t_read + t_model, 1e-9):,.0f} msg/s); report in {out}", file=sys.stderr)
    return report


def format_text(report: dict) -> str:
    if report.get("kind") == "slewing":
        return "\n".join([
            f"slewing bearing report ({report['duration_h']:.2f} h, {report['messages']} loads)",
            f"  worst roller:   {report.get('p_max_MPa', float('nan')):.0f} MPa at "
            f"{report.get('roller_load_max_n', float('nan')) / 1e3:.1f} kN ({report['level_name']}: "
            f"{report.get('message', '')})",
            f"  samples:        {report['samples_ok']} OK, {report['samples_warn']} WARN, "
            f"{report['samples_error']} ERROR, {report['rejected_loads']} rejected",
            f"  files:          {', '.join(report['files'].values())}",
        ])
    return "\n".join([
        f"guide precision report ({report['duration_h']:.2f} h, {report['messages']} messages)",
        f"  status:                {report['level_name']}: {report['message']}",
        f"  straightness (model):  {report['straightness_um']:.2f} um   (last measured "
        f"{report['straightness_measured_um']:.2f} um, limit {report['straightness_limit_um']:.0f} um)",
        f"  remaining life:        {report['remaining_life_h']:.1f} h   (90 %: "
        f"{report['remaining_life_h_low']:.1f} .. {report['remaining_life_h_high']:.1f} h)",
        f"  wear coefficient K:    {report['wear_coefficient']:.4g}   (configured "
        f"{report['wear_coefficient_configured']:.4g}, {report['measurements']} measurements)",
        f"  wear volume:           {report['wear_volume_mm3']:.3f} mm^3 over {report['sliding_distance_m']:.1f} m",
        f"  strokes:               {report['strokes']} between {report['stroke_min_m'] * 1e3:.1f} and "
        f"{report['stroke_max_m'] * 1e3:.1f} mm",
        f"  files:                 {', '.join(report['files'].values())}",
    ])
