"""PNG plots of the reports: replay (straightness, slewing contact series) and contact (rolling guide
film vs speed, slewing roller pressure and subsurface stresses). matplotlib (Agg) is imported on use."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from guide_health.errors import InputError
from guide_health.io.outputs.files import save_figure

#: carriage speeds of the rolling-contact plot [m/s] (log axis)
PLOT_SPEED_RANGE_M_S = (1e-3, 2.0)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save_figure(plt, fig, path) -> None:
    """Write ``fig`` (110 dpi) and close it; a path that cannot be written is bad input."""
    try:
        save_figure(fig, path)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)


def plot_straightness_report(path: Path, monitor, report: dict, t_h, measured, model) -> None:
    """Measured vs model straightness over time, and the wear profile along the rail (replay)."""
    plt = _pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(t_h, measured, "o", ms=4, label="measured")
    ax1.plot(t_h, model, "-", label=f"model (K = {report['wear_coefficient']:.3g})")
    ax1.axhline(report["straightness_limit_um"], color="r", ls="--", label="limit")
    ax1.set_xlabel("time [h]")
    ax1.set_ylabel("straightness [um]")
    life = report["remaining_life_h"]
    ax1.set_title(f"remaining precision life {life:.3g} h "
                  f"[{report['remaining_life_h_low']:.3g}, {report['remaining_life_h_high']:.3g}]"
                  if math.isfinite(life) else "straightness")
    plot_forecast(ax1, monitor.forecast(), report.get("effects", ""))
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
    _save_figure(plt, fig, path)


def when_text(now_ns: int, hours: float) -> str:
    """The date and time (UTC) ``hours`` after the stamp ``now_ns``; stamps before 2001 (simulated time
    from 0) as 't = ... h'."""
    import datetime

    if not math.isfinite(hours):
        return "never at this duty"
    t_s = now_ns * 1e-9 + hours * 3600.0
    if now_ns < 1e18:
        return f"t = {t_s / 3600.0:.1f} h"
    return datetime.datetime.fromtimestamp(t_s, datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")


def plot_forecast(ax, fc: dict, effects: str = "") -> None:
    """The forecast from now to the limit (PrecisionMonitor.forecast) with its 90 % band and the date/time
    the limit is reached, on a straightness-vs-time axis [h]."""
    if not fc:
        return
    t = fc["now_h"] + fc["horizon_h"]
    label = "forecast" + (f" with {effects}" if effects else "")
    ax.fill_betweenx(fc["mid_um"], fc["now_h"] + np.interp(fc["mid_um"], fc["fast_um"], fc["horizon_h"]),
                     fc["now_h"] + np.interp(fc["mid_um"], fc["slow_um"], fc["horizon_h"]), color="tab:purple",
                     alpha=0.2, label="90 % band")
    ax.plot(t, fc["mid_um"], "--", color="tab:purple", label=label)
    reach = fc["now_h"] + fc["life_h"]
    ax.axvline(reach, color="tab:purple", lw=0.8)
    ax.annotate(f"limit reached {when_text(fc['now_ns'], fc['life_h'])}\n90 %: "
                f"{when_text(fc['now_ns'], fc['life_low_h'])} .. {when_text(fc['now_ns'], fc['life_high_h'])}",
                (reach, fc["limit_um"]), textcoords="offset points", xytext=(-10, -30), ha="right", fontsize=7.5)


def plot_slewing_contact_series(path: Path, t_s: np.ndarray, series: np.ndarray, params: dict,
                                report: dict) -> None:
    """Highest roller pressure [MPa] of each load sample over time, with the allowable and warn lines."""
    plt = _pyplot()
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
    _save_figure(plt, fig, path)


def plot_rolling_contact_vs_speed(params: Any, report: dict[str, Any], path: str) -> None:
    """Film (central, min), lambda and contact-area ratio vs carriage speed at the report's ball load
    (``params``: the guide's GuideParams)."""
    from guide_health.models.rolling import ball_contact as bc

    plt = _pyplot()
    speeds = np.logspace(math.log10(PLOT_SPEED_RANGE_M_S[0]), math.log10(PLOT_SPEED_RANGE_M_S[1]), 61)
    try:
        temperature = report["oil_temperature_c"]            # NaN: a constant-viscosity oil
        sweep = bc.speed_sweep(params, report["contact_load_n"], speeds,
                               temperature if math.isfinite(temperature) else None)
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
    oil = (f" at {report['oil_temperature_c']:.1f} degC (Walther)" if math.isfinite(report["oil_temperature_c"])
           else "")
    fig.suptitle(f"ball contact {report['contact_load_n']:.0f} N, p_max {report['p_max_MPa']:.0f} MPa, "
                 f"eta0 {report['oil_viscosity_pa_s']:.3g} Pa s{oil}, sigma {report['composite_roughness_nm']:.0f} nm")
    fig.tight_layout()
    _save_figure(plt, fig, path)


def plot_slewing_roller_stresses(params: Any, report: dict[str, Any], path: str) -> None:
    """Pressure along the roller (Fig. 5) and von Mises / max shear vs depth at centre and end (Figs. 7-8)
    (``params``: SlewingMonitorParams)."""
    from guide_health.models.slewing import finite_roller, mcewen

    load = float(report["roller_load_max_n"])
    if load <= 0:
        raise InputError("nothing to plot: no roller is loaded")
    plt = _pyplot()
    contact = finite_roller.finite_roller_contact(load, params.roller_length_m, params.roller_diameter_m,
                                                  params.youngs_modulus_pa, params.poisson)
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
            field = mcewen.mcewen_stress_field(np.zeros_like(z), z, a, p0, params.friction, params.poisson)
            ax.plot(z * 1e3, getattr(field, key) * 1e-6, label=f"{name} (x = 0)")
        ax.set_xlabel("depth z [mm]")
        ax.set_ylabel(f"{label} [MPa]")
        ax.set_title(f"{label}, f = {params.friction}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    _save_figure(plt, fig, path)
