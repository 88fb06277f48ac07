"""`guide-health contact rolling`: ball/groove contact and lubrication of a 4-row linear rolling guide (seed 001).

    guide-health contact rolling --params FILE [--load-n F] [--speed M_S] [--json] [--plot PNG]

``--load-n`` is the contact load of one ball [N] (default: the parameter ``preload_n``, the no-load case of
seed 001 Table 1); ``--speed`` the carriage speed [m/s] (default 0.1 m/s; the entrainment speed of the
ball contacts is half of it). Parameters: the ``wear_monitor`` section of a ROS 2 parameters YAML.
``--plot`` writes film thickness, lambda and contact-area ratio against speed (log axis, 1e-3..2 m/s).
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from guide_health.errors import InputError
from guide_health.models.rolling import ball_contact as bc
from guide_health.params import wear_monitor_params

DEFAULT_SPEED_M_S = 0.1
PLOT_SPEED_RANGE_M_S = (1e-3, 2.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``contact rolling`` (the CLI adds ``--json``)."""
    parser.add_argument("--params", required=True, metavar="FILE",
                        help="ROS 2 parameters YAML with a 'wear_monitor: ros__parameters:' section")
    parser.add_argument("--load-n", type=float, default=None, metavar="F",
                        help="contact load of one ball [N] (default: preload_n)")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED_M_S, metavar="M_S",
                        help=f"carriage speed [m/s] (default {DEFAULT_SPEED_M_S}; entrainment speed = speed/2)")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="write film / lambda / contact-area ratio vs speed (1e-3..2 m/s) to PNG")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the report (INTERFACES.md `contact rolling --json` keys)."""
    params = wear_monitor_params(args.params)
    if args.load_n is not None and not (math.isfinite(args.load_n) and args.load_n > 0):
        raise InputError(f"--load-n must be a finite number > 0, got {args.load_n!r}")
    if not math.isfinite(args.speed) or args.speed < 0:
        raise InputError(f"--speed must be a finite number >= 0, got {args.speed!r}")
    if params["guide_type"] != "rolling":
        print(f"guide-health: note: guide_type is {params['guide_type']!r}; using its rolling-guide parameters",
              file=sys.stderr)
    try:
        report = bc.rolling_contact_report(params, args.load_n, args.speed)
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(str(exc).splitlines()[0]) from exc
    report["load_source"] = "--load-n" if args.load_n is not None else "preload_n"
    report["machine_id"] = params["machine_id"]
    report["joint"] = params["joint"]
    if args.plot:
        _plot(params, report, args.plot)
        report["plot"] = args.plot
    return report


def format_text(result: dict[str, Any]) -> str:
    """Short human summary."""
    return "\n".join([
        f"{result.get('machine_id', '')}/{result.get('joint', '')}: {result['message']}",
        f"  contact load           {result['contact_load_n']:.1f} N per ball ({result['load_source']})",
        f"  Hertz p_max            {result['p_max_MPa']:.0f} MPa, a x b = {result['semi_axis_a_mm']:.4f} x "
        f"{result['semi_axis_b_mm']:.4f} mm, approach {result['approach_um']:.2f} um",
        f"  speed                  carriage {result['carriage_speed_m_s']:.4g} m/s, "
        f"entrainment {result['entrainment_speed_m_s']:.4g} m/s",
        f"  film central / min     {result['film_central_nm']:.1f} / {result['film_min_nm']:.1f} nm "
        f"(sigma {result['composite_roughness_nm']:.0f} nm)",
        f"  lambda                 {result['lambda']:.3g} -> {result['regime']}",
        f"  asperity load share    {result['asperity_load_share']:.3f} (contact-area ratio estimate)",
    ])


def _plot(params: dict[str, Any], report: dict[str, Any], path: str) -> None:
    """Film (central, min), lambda and contact-area ratio vs carriage speed at the report's ball load."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    speeds = np.logspace(math.log10(PLOT_SPEED_RANGE_M_S[0]), math.log10(PLOT_SPEED_RANGE_M_S[1]), 61)
    try:
        sweep = bc.speed_sweep(params, report["contact_load_n"], speeds)
    except ValueError as exc:
        raise InputError(str(exc).splitlines()[0]) from exc
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    ax = axes[0]
    ax.semilogx(speeds, sweep["film_central_m"] * 1e9, label="central (Hamrock-Dowson)")
    ax.semilogx(speeds, sweep["film_min_m"] * 1e9, label="minimum (Hamrock-Dowson)")
    ax.axhline(report["composite_roughness_nm"], ls=":", color="k", label="composite RMS roughness")
    ax.set_ylabel("film thickness [nm]")
    ax = axes[1]
    ax.loglog(speeds, sweep["lambda"], label="lambda = h_c / sigma")
    ax.axhline(report["lambda_full_film"], ls="--", color="g", label="mixed / full film")
    ax.axhline(report["lambda_boundary"], ls="--", color="r", label="boundary / mixed")
    ax.axhline(1.0, ls=":", color="k", lw=0.8)
    ax.set_ylabel("lambda [-]")
    ax = axes[2]
    ax.semilogx(speeds, sweep["asperity_load_share"], label="asperity load share (JGP), contact-area ratio est.")
    ax.semilogx(speeds, sweep["asperity_real_area_ratio"], label="GT real contact area / Hertz area")
    ax.axhline(0.8, ls="--", color="r", label="seed 001 boundary (80 %)")
    ax.set_ylim(0.0, 1.0)
    ax.set_ylabel("ratio [-]")
    for ax in axes:
        ax.set_xlabel("carriage speed [m/s]")
        ax.set_xlim(*PLOT_SPEED_RANGE_M_S)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"ball contact {report['contact_load_n']:.0f} N, p_max {report['p_max_MPa']:.0f} MPa, "
                 f"eta0 {params['oil_viscosity_pa_s']} Pa s, sigma {report['composite_roughness_nm']:.0f} nm")
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)
