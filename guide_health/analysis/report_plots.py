"""PNG plots of the reports: replay (straightness, slewing contact series) and contact (rolling guide
film vs speed, slewing roller pressure and subsurface stresses). matplotlib (Agg) is imported on use."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from guide_health.errors import InputError
from guide_health.io.outputs.files import save_figure

#: most points of a forecast curve: 60 on the span shown when the band's far end is 300x farther
FORECAST_POINTS_MAX = 18_000
#: carriage speeds of the rolling-contact plot [m/s] (log axis)
PLOT_SPEED_RANGE_M_S = (1e-3, 2.0)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save_figure(plt, fig, path) -> None:
    """Write ``fig`` (110 dpi) and close it (``plt`` None: a figure of the object API, not pyplot's, is kept
    by its owner); a path that cannot be written is bad input."""
    try:
        save_figure(fig, path)
    except OSError as exc:
        raise InputError(f"cannot write plot {path}: {exc.strerror or exc}") from exc
    finally:
        if plt is not None:
            plt.close(fig)


def plot_straightness_report(path: Path, monitor, report: dict, t_h, measured, model, name: str = "") -> None:
    """Three panels: the history at its own time scale (measured vs model straightness), the forecast from
    now to the limit with its 90 % band (forecast_span_h), and the wear profile along the rail (replay).
    ``name`` (e.g. "axis x (guide front)") leads the title."""
    plt = _pyplot()
    fig, (ax1, axf, ax2) = plt.subplots(1, 3, figsize=(15, 4.4))
    ax1.plot(t_h, measured, "o", ms=4, label="measured")
    ax1.plot(t_h, model, "-", label=f"model (K = {report['wear_coefficient']:.3g})")
    fc = monitor.forecast()
    if fc and forecast_span_h(fc) < fc["horizon_h"][-1]:          # the same forecast, as fine on the span shown
        fc = monitor.forecast(points=min(FORECAST_POINTS_MAX, math.ceil(
            len(fc["horizon_h"]) * fc["horizon_h"][-1] / forecast_span_h(fc))))
    ax1.set_xlim(0.0, 1.03 * max(float(np.max(t_h, initial=0.0)), fc.get("now_h", 0.0)) or 1.0)
    ax1.set_xlabel("time [h] (calendar, since the first sample)")
    ax1.set_ylabel("straightness [um]")
    ax1.set_title("history")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    axf.axhline(report["straightness_limit_um"], color="r", ls="--", label="limit")
    if fc:
        plot_forecast(axf, fc, report.get("effects", ""), report)
        axf.set_xlim(fc["now_h"], fc["now_h"] + forecast_span_h(fc))
        axf.legend(loc="upper left", fontsize=8)
    else:
        axf.text(0.5, 0.5, "no finite remaining life: no forecast", transform=axf.transAxes, ha="center")
    axf.set_xlabel("time [h]: now + running hours at the current duty")
    axf.set_title("forecast to the limit at the current duty")
    axf.grid(alpha=0.3)
    u = monitor.geometry.bin_centres_m()
    depth_um = report["wear_coefficient"] * monitor.integrator.profile_depth_per_k_m() * 1e6
    ax2.plot(u * 1e3, -depth_um)
    ax2.set_xlabel("rail position [mm]")
    ax2.set_ylabel("wear profile [um]")
    ax2.set_title("wear along the rail (profile model)")
    ax2.grid(alpha=0.3)
    life = report["remaining_life_h"]
    band = (report["remaining_life_h_low"], report["remaining_life_h_high"])
    what = f"remaining precision life {life_text(life, *band)}" if math.isfinite(life) else "straightness"
    fig.suptitle(f"{name}: {what}" if name else what)
    fig.tight_layout()
    _save_figure(plt, fig, path)


def hours_text(hours: float) -> str:
    """Hours to 3 significant digits without an exponent (1980, 11000, 23.4)."""
    if not math.isfinite(hours):
        return "never"
    rounded = float(f"{hours:.3g}")
    return f"{rounded:.0f}" if abs(rounded) >= 100 else f"{rounded:g}"


def life_text(life_h: float, low_h: float, high_h: float) -> str:
    """A remaining life with its 90 % interval: '1980 h (90 %: 1090-11000 h)'."""
    band = (f"{hours_text(low_h)}-{hours_text(high_h)} h" if math.isfinite(high_h)
            else f"over {hours_text(low_h)} h")
    return f"{hours_text(life_h)} h (90 %: {band})"


def forecast_span_h(fc: dict) -> float:
    """The forecast axis from now [h]: to the band's far end, at most 3x the remaining life, so a slow edge
    far beyond the point forecast (an uncertain K) does not squeeze it; the band's dates are in the text."""
    return float(min(fc["horizon_h"][-1], 3.0 * fc["life_h"]))


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


def _date_text(iso_utc: str) -> str:
    """'2027-01-05T13:20:00Z' as '2027-01-05 13:20 UTC' ('' as 'never at this duty')."""
    return f"{iso_utc[:10]} {iso_utc[11:16]} UTC" if iso_utc else "never at this duty"


def plot_forecast(ax, fc: dict, effects: str = "", report: dict | None = None) -> None:
    """The forecast from now to the limit (PrecisionMonitor.forecast) with its 90 % band, in running hours
    from now, and when the limit is reached: the calendar dates at the utilisation when ``report`` has them
    (limit_date_utc, models/wear/running_time.py), else the running hours counted as if 24/7."""
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
    if report and report.get("limit_date_utc") and fc["now_ns"] >= 1e18:
        low, high = (_date_text(report[k]) for k in ("limit_date_utc_low", "limit_date_utc_high"))
        text = (f"limit reached {_date_text(report['limit_date_utc'])}\n(calendar at utilisation "
                f"{report['utilisation']:.0%})\n90 %: {low} .. {high}")
    else:
        text = (f"limit reached {when_text(fc['now_ns'], fc['life_h'])} (running 24/7)\n90 %: "
                f"{when_text(fc['now_ns'], fc['life_low_h'])} .. {when_text(fc['now_ns'], fc['life_high_h'])}")
    ax.text(0.98, 0.03, text, transform=ax.transAxes, ha="right", va="bottom", fontsize=7.5,   # inside the frame
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})


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
