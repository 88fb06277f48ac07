"""`guide-health contact slewing`: roller/raceway stresses of a three-row roller slewing bearing (seed 003).

    guide-health contact slewing --params FILE [--load-n Q | --axial-n FA --radial-n FR --moment-nm MT]
                                 [--json] [--plot PNG]

The roller load is ``--load-n`` when given; otherwise the worst roller under ``--axial-n``/``--radial-n``/
``--moment-nm`` (seed 003 Eq. 1; missing ones are 0); with none of them, the seed example roller load
103 400 N. Parameters: the ``slewing_monitor`` section of a ROS 2 parameters YAML.
"""
from __future__ import annotations

import argparse
import math
from typing import Any

from guide_health.errors import InputError
from guide_health.models.slewing import finite_roller, mcewen
from guide_health.models.slewing import monitor as rc
from guide_health.params import SLEWING_MONITOR_DEFAULTS, load_node_params, validate_slewing_params


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``contact slewing`` (the CLI adds ``--json``)."""
    parser.add_argument("--params", required=True, metavar="FILE",
                        help="ROS 2 parameters YAML with a 'slewing_monitor: ros__parameters:' section")
    parser.add_argument("--load-n", type=float, default=None, metavar="Q",
                        help="roller load [N] (overrides --axial-n/--radial-n/--moment-nm)")
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


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the report (INTERFACES.md `contact slewing --json` keys)."""
    params = load_node_params(args.params, "slewing_monitor", SLEWING_MONITOR_DEFAULTS)
    validate_slewing_params(params)
    load = _finite("--load-n", args.load_n, allow_negative=False)
    axial = _finite("--axial-n", args.axial_n, allow_negative=True)
    radial = _finite("--radial-n", args.radial_n, allow_negative=False)
    moment = _finite("--moment-nm", args.moment_nm, allow_negative=True)
    try:
        if load is not None:
            report = rc.slewing_contact_report(params, load)
            report["load_source"] = "--load-n"
        elif any(v is not None for v in (axial, radial, moment)):
            report = rc.slewing_contact_report_from_loads(params, axial or 0.0, radial or 0.0, moment or 0.0)
            report["load_source"] = "eq1"
        else:
            report = rc.slewing_contact_report(params, rc.SEED003_EXAMPLE_ROLLER_LOAD_N)
            report["load_source"] = "seed003_example"
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(str(exc).splitlines()[0]) from exc
    report["bearing"] = params["bearing"]
    report["machine_id"] = params["machine_id"]
    if args.plot:
        _plot(params, report, args.plot)
        report["plot"] = args.plot
    return report


def format_text(result: dict[str, Any]) -> str:
    """Short human summary."""
    lines = [f"{result.get('bearing', '')}: {result['message']}",
             f"  roller load            {result['roller_load_max_n']:.0f} N",
             f"  p0 Hertz/centre/end    {result['p0_hertz_MPa']:.0f} / {result['p0_center_MPa']:.0f} / "
             f"{result['p0_end_MPa']:.0f} MPa (end ratio {result['end_stress_ratio']:.3f})",
             f"  von Mises max          {result['von_mises_max_MPa']:.0f} MPa at {result['von_mises_depth_mm']:.3f} mm",
             f"  max shear              {result['shear_max_MPa']:.0f} MPa at {result['shear_depth_mm']:.3f} mm",
             f"  allowable              {result['allowable_MPa']:.0f} MPa"]
    return "\n".join(lines)


def _plot(params: dict[str, Any], report: dict[str, Any], path: str) -> None:
    """Pressure along the roller (Fig. 5) and von Mises / max shear vs depth at centre and end (Figs. 7-8)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    load = float(report["roller_load_max_n"])
    if load <= 0:
        raise InputError("nothing to plot: no roller is loaded")
    contact = finite_roller.finite_roller_contact(load, params["roller_length_m"], params["roller_diameter_m"],
                                                  params["youngs_modulus_pa"], params["poisson"])
    s = contact.scalars
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    ax = axes[0]
    ax.plot(contact.y_m * 1e3, contact.p0_pa * 1e-6, label="seed 003 finite roller (Eqs. 2-10)")
    ax.axhline(s.hertz.p0_pa * 1e-6, ls="--", color="k", label="ideal Hertz")
    ax.axhline(report["allowable_MPa"], ls=":", color="r", label="allowable")
    ax.set_xlabel("y along the roller [mm]")
    ax.set_ylabel("peak contact pressure p0 [MPa]")
    ax.set_title(f"Q = {load:.0f} N")
    ax.legend(fontsize=8)
    for ax, key, label in ((axes[1], "von_mises", "von Mises"), (axes[2], "max_shear", "max shear (sigma1-sigma2)/2")):
        for name, a, p0 in (("end", s.end_half_width_m, s.p0_end_pa), ("centre", s.centre_half_width_m, s.p0_centre_pa),
                            ("ideal Hertz", s.hertz.half_width_m, s.hertz.p0_pa)):
            z = np.linspace(0.0, 3.0 * a, 301)
            field = mcewen.mcewen_stress_field(np.zeros_like(z), z, a, p0, params["friction"], params["poisson"])
            ax.plot(z * 1e3, getattr(field, key) * 1e-6, label=f"{name} (x = 0)")
        ax.set_xlabel("depth z [mm]")
        ax.set_ylabel(f"{label} [MPa]")
        ax.set_title(f"{label}, f = {params['friction']}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)
