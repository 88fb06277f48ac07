"""`guide-health contact slewing|rolling`: contact stresses of a slewing bearing's rollers and of a rolling
guide's balls, from a ROS 2 parameters YAML.

    guide-health contact slewing --params FILE [--load-n Q | --axial-n FA --radial-n FR --moment-nm MT]
                                 [--json] [--plot PNG]

Roller/raceway stresses of a three-row roller slewing bearing (seed 003). The roller load is ``--load-n``
when given; otherwise the worst roller under ``--axial-n``/``--radial-n``/``--moment-nm`` (seed 003 Eq. 1;
missing ones are 0); with none of them, the seed example roller load 103 400 N. Parameters: the
``slewing_monitor`` section.

    guide-health contact rolling --params FILE [--load-n F] [--speed M_S] [--json] [--plot PNG]

Ball/groove contact and lubrication of a 4-row linear rolling guide (seed 001). ``--load-n`` is the
contact load of one ball [N] (default: the parameter ``preload_n``, the no-load case of seed 001 Table 1);
``--speed`` the carriage speed [m/s] (default 0.1 m/s; the entrainment speed of the ball contacts is half
of it). Parameters: the ``wear_monitor`` section. ``--plot`` writes film thickness, lambda and
contact-area ratio against speed (log axis, 1e-3..2 m/s).
"""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import Any

from guide_health.analysis.report_plots import plot_rolling_contact_vs_speed, plot_slewing_roller_stresses
from guide_health.cli.command import Command, value_errors_as_input_errors
from guide_health.errors import InputError
from guide_health.models.rolling import ball_contact as bc
from guide_health.params import SLEWING_MONITOR_DEFAULTS, load_node_params, wear_monitor_params
from guide_health.params.typed import guide_params, slewing_monitor_params

DEFAULT_SPEED_M_S = 0.1


def _add_params_and_load(parser: argparse.ArgumentParser, section: str, load_metavar: str, load_help: str) -> None:
    """--params (the node's section of a ROS 2 parameters YAML) and --load-n [N]."""
    parser.add_argument("--params", required=True, metavar="FILE",
                        help=f"ROS 2 parameters YAML with a '{section}: ros__parameters:' section")
    parser.add_argument("--load-n", type=float, default=None, metavar=load_metavar, help=load_help)


def _named_report(report: dict[str, Any], params: Any, names: dict[str, str], plot_path: str | None,
                  plot: Callable[[Any, dict, str], None]) -> dict[str, Any]:
    """The report with the parameters that name the machine (``names``), and the plot when asked for."""
    report.update(names)
    if plot_path:
        plot(params, report, plot_path)
        report["plot"] = plot_path
    return report


# --- contact slewing ------------------------------------------------------------------------------

def add_slewing_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``contact slewing`` (the CLI adds ``--json``)."""
    _add_params_and_load(parser, "slewing_monitor", "Q", "roller load [N] (overrides --axial-n/--radial-n/--moment-nm)")
    parser.add_argument("--axial-n", type=float, default=None, metavar="FA",
                        help="axial load F_a [N], > 0 presses the main axial row")
    parser.add_argument("--radial-n", type=float, default=None, metavar="FR", help="radial load F_r [N]")
    parser.add_argument("--moment-nm", type=float, default=None, metavar="MT", help="tilting moment M_T [N m]")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="write pressure along the roller and stresses vs depth (seed Figs. 5-8) to PNG")


def _finite(name: str, value: float | None, allow_negative: bool) -> float | None:
    if value is None:
        return None
    if not math.isfinite(value):
        raise InputError(f"{name} must be a finite number, got {value!r}")
    if value < 0 and not allow_negative:
        raise InputError(f"{name} must be >= 0, got {value!r}")
    return value


def run_slewing(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the report (INTERFACES.md `contact slewing --json` keys)."""
    from guide_health.models.slewing import monitor as rc

    params = slewing_monitor_params(load_node_params(args.params, "slewing_monitor", SLEWING_MONITOR_DEFAULTS))
    load = _finite("--load-n", args.load_n, allow_negative=False)
    axial = _finite("--axial-n", args.axial_n, allow_negative=True)
    radial = _finite("--radial-n", args.radial_n, allow_negative=False)
    moment = _finite("--moment-nm", args.moment_nm, allow_negative=True)
    with value_errors_as_input_errors():
        if load is not None:
            report = rc.slewing_contact_report(params, load)
            report["load_source"] = "--load-n"
        elif any(v is not None for v in (axial, radial, moment)):
            report = rc.slewing_contact_report_from_loads(params, axial or 0.0, radial or 0.0, moment or 0.0)
            report["load_source"] = "eq1"
        else:
            report = rc.slewing_contact_report(params, rc.SEED003_EXAMPLE_ROLLER_LOAD_N)
            report["load_source"] = "seed003_example"
    return _named_report(report, params, {"bearing": params.bearing, "machine_id": params.machine_id}, args.plot,
                         plot_slewing_roller_stresses)


def format_slewing(result: dict[str, Any]) -> str:
    """Short human summary."""
    lines = [f"{result.get('bearing', '')}: {result['message']}",
             f"  roller load            {result['roller_load_max_n']:.0f} N",
             f"  p0 Hertz/centre/end    {result['p0_hertz_MPa']:.0f} / {result['p0_center_MPa']:.0f} / "
             f"{result['p0_end_MPa']:.0f} MPa (end ratio {result['end_stress_ratio']:.3f})",
             f"  von Mises max          {result['von_mises_max_MPa']:.0f} MPa at {result['von_mises_depth_mm']:.3f} mm",
             f"  max shear              {result['shear_max_MPa']:.0f} MPa at {result['shear_depth_mm']:.3f} mm",
             f"  allowable              {result['allowable_MPa']:.0f} MPa"]
    return "\n".join(lines)


# --- contact rolling ------------------------------------------------------------------------------

def add_rolling_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``contact rolling`` (the CLI adds ``--json``)."""
    _add_params_and_load(parser, "wear_monitor", "F",
                         "contact load of one ball [N] (default: the most loaded ball under --carriage-load-n)")
    parser.add_argument("--carriage-load-n", type=float, default=0.0, metavar="F",
                        help="external load on one carriage [N], > 0 downward, < 0 reverse/lift-off (default 0: "
                             "preload only); sets the four-row ball loads and equivalent_fatigue_load_n")
    parser.add_argument("--speed", type=float, default=DEFAULT_SPEED_M_S, metavar="M_S",
                        help=f"carriage speed [m/s] (default {DEFAULT_SPEED_M_S}; entrainment speed = speed/2)")
    parser.add_argument("--temperature-c", type=float, default=None, metavar="C",
                        help="oil temperature [degC] for a catalogue (Walther) oil, oil_viscosity_40c_mm2_s > 0 "
                             "(default: oil_temperature_c)")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="write film / lambda / contact-area ratio vs speed (1e-3..2 m/s) to PNG")


def run_rolling(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the report (INTERFACES.md `contact rolling --json` keys)."""
    loaded = wear_monitor_params(args.params)
    params = guide_params(loaded)
    if args.load_n is not None and not (math.isfinite(args.load_n) and args.load_n > 0):
        raise InputError(f"--load-n must be a finite number > 0, got {args.load_n!r}")
    if not math.isfinite(args.speed) or args.speed < 0:
        raise InputError(f"--speed must be a finite number >= 0, got {args.speed!r}")
    if params.guide_type != "rolling":
        print(f"guide-health: note: guide_type is {params.guide_type!r}; using its rolling-guide parameters",
              file=sys.stderr)
    if not math.isfinite(args.carriage_load_n):
        raise InputError(f"--carriage-load-n must be a finite number, got {args.carriage_load_n!r}")
    with value_errors_as_input_errors():
        report = bc.rolling_contact_report(params, args.load_n, args.speed, args.carriage_load_n,
                                           args.temperature_c)
    report["load_source"] = "--load-n" if args.load_n is not None else "max ball load (preload + carriage load)"
    return _named_report(report, params, {"machine_id": loaded["machine_id"], "joint": loaded["joint"]}, args.plot,
                         plot_rolling_contact_vs_speed)


def format_rolling(result: dict[str, Any]) -> str:
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
        f"  oil                    {result['oil_viscosity_pa_s']:.4g} Pa s"
        + (f" at {result['oil_temperature_c']:.1f} degC (Walther)" if math.isfinite(result['oil_temperature_c'])
           else ""),
        f"  lambda                 {result['lambda']:.3g} -> {result['regime']}",
        f"  asperity load share    {result['asperity_load_share']:.3f} (contact-area ratio estimate)",
        f"  carriage load          {result['carriage_load_n']:.0f} N: ball loads upper "
        f"{result['upper_ball_load_n']:.0f} / lower {result['lower_ball_load_n']:.0f} N, equivalent fatigue load "
        f"{result['equivalent_fatigue_load_n']:.0f} N (preload included)",
    ])


SLEWING = Command(add_slewing_arguments, run_slewing, format_slewing)
ROLLING = Command(add_rolling_arguments, run_rolling, format_rolling)
