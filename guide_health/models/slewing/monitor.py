"""Slewing-bearing monitor core (no ROS): the roller/raceway contact report of the worst roller
(``slewing_contact_report``, direct and uncached, and ``SlewingContactModel``, geometry-only work done once so
that a report costs microseconds; INTERFACES.md ``contact slewing --json`` keys), its level against the
allowable contact stress, and ``SlewingMonitor``: the worst roller per reporting period.

``params`` everywhere: the frozen slewing_monitor parameter object (``SlewingMonitorParams``, validated where it
is built, guide_health.params.typed); fields are read by their parameter names.

The offline analysis of a whole load history with the same object is
:func:`guide_health.analysis.slewing_replay.analyse_slewing_run`.
"""
from __future__ import annotations

import math
from typing import Any

from guide_health.models.contact.elastic import effective_modulus_pa
from guide_health.models.contact.hertz_line import checked_load_n, effective_radius_m, hertz_line_contact
from guide_health.models.levels import ERROR, OK, WARN, Level, exceeds
from guide_health.models.slewing.fatigue import SlewingFatigue
from guide_health.models.slewing.finite_roller import (
    FiniteRollerScalars,
    finite_roller_contact,
    finite_roller_scalars,
    palmgren_line_stiffness,
)
from guide_health.models.slewing.mcewen import McEwenMaxima, cached_mcewen_maxima, mcewen_maxima
from guide_health.models.slewing.raceway_wear import RacewayWear, sliding_weight_table
from guide_health.models.slewing.rating import slewing_ratings
from guide_health.models.slewing.row_loads import AxialRowLoads, axial_row_roller_loads, radial_row_roller_load_max_n
from guide_health.models.wear.calibration import WearCoefficientEstimator
from guide_health.models.wear.stream_gaps import StampGaps

#: seed 003 Sec. 4 example: 131.32.2000.00Z, E = 210 GPa, nu = 0.3, d = 32 mm, l = 31.3 mm, f = 0.1
SEED003_EXAMPLE_ROLLER_LOAD_N: float = 103_400.0

# Parameters: guide_health.params.SLEWING_MONITOR_SCHEMA; every function and class here takes the validated,
# typed SlewingMonitorParams (guide_health.params.typed); models never import params.


# ----------------------------------------------------------------------------------------------------
# Report (INTERFACES.md `contact slewing --json`)
# ----------------------------------------------------------------------------------------------------
def contact_level(p_max_pa: float, allowable_pa: float, warn_fraction: float, margin: float = 0.0) -> Level:
    """OK, WARN above warn_fraction x allowable, ERROR above allowable (judged on p_max); ``margin``: the
    thresholds of the alarm's clearing test (guide_health.models.levels.exceeds)."""
    if not math.isfinite(p_max_pa) or exceeds(p_max_pa, allowable_pa, margin):
        return ERROR
    return WARN if exceeds(p_max_pa, warn_fraction * allowable_pa, margin) else OK


def _level_message(level: Level, p_max_mpa: float, position_mm: float, allowable_mpa: float,
                   warn_fraction: float) -> str:
    """The status sentence; WARN and ERROR name the rule and its threshold."""
    if p_max_mpa <= 0:
        return "no roller loaded"
    share = 100.0 * p_max_mpa / allowable_mpa
    where = "at the roller end" if position_mm > 0 else "at the roller centre"
    rule = {OK: "", WARN: f" > warn_fraction {warn_fraction:g} x allowable_contact_stress_pa = "
                          f"{warn_fraction * allowable_mpa:.0f} MPa",
            ERROR: f" > allowable_contact_stress_pa {allowable_mpa:.0f} MPa"}[level]
    word = {OK: "contact pressure OK", WARN: "contact pressure near the allowable",
            ERROR: "contact pressure above the allowable"}[level]
    return f"{word}: {p_max_mpa:.0f} MPa {where}{rule} ({share:.0f} % of {allowable_mpa:.0f} MPa)"


def _assemble(scalars: FiniteRollerScalars | None, maxima: McEwenMaxima, half_length_m: float,
              allowable_pa: float, warn_fraction: float, load_n: float) -> dict[str, Any]:
    """Report dict from the finite-roller scalars and the geometry-free McEwen maxima (plain floats)."""
    allowable_mpa = allowable_pa * 1e-6
    if scalars is None:  # unloaded
        out = {k: 0.0 for k in ("p_max_MPa", "p_max_position_mm", "p0_hertz_MPa", "p0_center_MPa", "p0_end_MPa",
                                "von_mises_max_MPa", "von_mises_depth_mm", "shear_max_MPa", "shear_depth_mm",
                                "von_mises_x_mm", "shear_x_mm", "von_mises_surface_MPa", "half_width_hertz_mm",
                                "von_mises_subsurface_max_MPa", "von_mises_surface_seed003_end_MPa",
                                "von_mises_surface_seed003_center_MPa", "von_mises_surface_seed003_hertz_MPa",
                                "half_width_center_mm", "half_width_end_mm", "approach_center_mm",
                                "approach_end_mm", "line_load_center_n_per_mm", "line_load_end_n_per_mm")}
        out.update(roller_load_max_n=load_n, end_stress_ratio=float("nan"), allowable_MPa=allowable_mpa,
                   level=OK, message="no roller loaded", stress_model="seed003")
        return out
    p_end, a_end = scalars.p0_end_pa, scalars.end_half_width_m
    vm, tau = maxima.von_mises, maxima.max_shear
    p_max_mpa = p_end * 1e-6
    position_mm = half_length_m * 1e3
    level = contact_level(p_end, allowable_pa, warn_fraction)
    return {
        "roller_load_max_n": load_n,
        "p_max_MPa": p_max_mpa,
        "p_max_position_mm": position_mm,
        "p0_hertz_MPa": scalars.hertz.p0_pa * 1e-6,
        "p0_center_MPa": scalars.p0_centre_pa * 1e-6,
        "p0_end_MPa": p_max_mpa,
        "end_stress_ratio": p_end / scalars.p0_centre_pa,
        "von_mises_max_MPa": vm.value_over_p0 * p_max_mpa,
        "von_mises_depth_mm": vm.z_over_a * a_end * 1e3,
        "von_mises_x_mm": vm.x_over_a * a_end * 1e3,
        "shear_max_MPa": tau.value_over_p0 * p_max_mpa,
        "shear_depth_mm": tau.z_over_a * a_end * 1e3,
        "shear_x_mm": tau.x_over_a * a_end * 1e3,
        "von_mises_max_axis_MPa": maxima.von_mises_on_axis.value_over_p0 * p_max_mpa,
        "von_mises_axis_depth_mm": maxima.von_mises_on_axis.z_over_a * a_end * 1e3,
        "shear_max_axis_MPa": maxima.max_shear_on_axis.value_over_p0 * p_max_mpa,
        "shear_axis_depth_mm": maxima.max_shear_on_axis.z_over_a * a_end * 1e3,
        "von_mises_surface_MPa": maxima.von_mises_surface_centre_over_p0 * p_max_mpa,
        # the subsurface maximum (the design stress; von_mises_max_MPa is kept for the status
        # keys) and the SURFACE values of seed 003 Table 1 (end / centre / ideal Hertz), never to be compared
        # with each other
        "von_mises_subsurface_max_MPa": vm.value_over_p0 * p_max_mpa,
        "von_mises_surface_seed003_end_MPa": maxima.von_mises_surface_seed003_over_p0 * p_max_mpa,
        "von_mises_surface_seed003_center_MPa": maxima.von_mises_surface_seed003_over_p0 * scalars.p0_centre_pa
        * 1e-6,
        "von_mises_surface_seed003_hertz_MPa": maxima.von_mises_surface_seed003_over_p0 * scalars.hertz.p0_pa * 1e-6,
        "half_width_hertz_mm": scalars.hertz.half_width_m * 1e3,
        "half_width_center_mm": scalars.centre_half_width_m * 1e3,
        "half_width_end_mm": a_end * 1e3,
        "approach_center_mm": scalars.centre_approach_m * 1e3,
        "approach_end_mm": scalars.end_approach_m * 1e3,
        "line_load_center_n_per_mm": scalars.centre_line_load_n_m * 1e-3,
        "line_load_end_n_per_mm": scalars.end_line_load_n_m * 1e-3,
        "allowable_MPa": allowable_mpa,
        "level": level,
        "message": _level_message(level, p_max_mpa, position_mm, allowable_mpa, warn_fraction),
        "stress_model": "seed003",
    }


def _numerical_report(params: Any, load_n: float, pressures: dict | None = None) -> dict[str, Any]:
    """stress_model 'numerical': pressures from numerical_roller (solved now, or `pressures` from a
    RollerContactTable lookup), subsurface maxima by McEwen under p_max."""
    if pressures is None:
        try:
            from guide_health.models.slewing.numerical_roller import numerical_contact_report
        except ImportError as exc:
            raise ValueError(f"stress_model 'numerical' is not available in this build ({exc})") from exc
        pressures = numerical_contact_report(params, load_n)
    report = dict(pressures)
    maxima = cached_mcewen_maxima(float(params.friction), float(params.poisson))
    e_star = effective_modulus_pa(params.youngs_modulus_pa, params.poisson)
    radius = effective_radius_m(params.roller_diameter_m)
    p_max_mpa = float(report["p_max_MPa"])
    local_a_mm = 2.0 * radius * p_max_mpa * 1e6 / e_star * 1e3   # Hertz: p0 = E* a / (2 R)
    report.setdefault("p0_hertz_MPa", hertz_line_contact(load_n, params.roller_length_m,
                                                         params.roller_diameter_m, params.youngs_modulus_pa,
                                                         params.poisson).p0_pa * 1e-6)
    allowable = float(params.allowable_contact_stress_pa)
    level = contact_level(p_max_mpa * 1e6, allowable, float(params.warn_fraction))
    report.update(
        roller_load_max_n=load_n,
        von_mises_max_MPa=maxima.von_mises.value_over_p0 * p_max_mpa,
        von_mises_subsurface_max_MPa=maxima.von_mises.value_over_p0 * p_max_mpa,
        von_mises_surface_MPa=maxima.von_mises_surface_centre_over_p0 * p_max_mpa,
        von_mises_depth_mm=maxima.von_mises.z_over_a * local_a_mm,
        shear_max_MPa=maxima.max_shear.value_over_p0 * p_max_mpa,
        shear_depth_mm=maxima.max_shear.z_over_a * local_a_mm,
        subsurface_model="mcewen_on_p_max",
        allowable_MPa=allowable * 1e-6,
        level=level,
        message=_level_message(level, p_max_mpa, float(report.get("p_max_position_mm", 0.0)), allowable * 1e-6,
                               float(params.warn_fraction)),
        stress_model="numerical",
    )
    return report


def slewing_contact_report(params: Any, roller_load_n: float | None = None) -> dict[str, Any]:
    """Direct (uncached) roller/raceway report for one roller load [N] (INTERFACES.md keys).

    ``params``: the slewing_monitor parameters (SlewingMonitorParams); ``roller_load_n`` None = the seed 003
    example load, 103 400 N. The highest pressure (``p_max_MPa``) of the seed model is p0 at the roller
    end (Eq. 5); ``von_mises_max_MPa`` (= ``von_mises_subsurface_max_MPa``)/``shear_max_MPa`` are the
    subsurface maxima of the McEwen field (over x and z, friction included) under that pressure, depths in mm
    below the raceway surface. ``von_mises_surface_MPa`` is the field's surface value at the contact centre;
    ``von_mises_surface_seed003_{end,center,hertz}_MPa`` the reading of seed 003 Table 1 (surface values,
    1328/1095/1127 MPa for the example): compare Table 1 with those, never with the subsurface maximum.
    Level: OK, WARN above warn_fraction x allowable, ERROR above allowable. All field maxima are
    recomputed on every call (grid + scipy.optimize, milliseconds): use ``SlewingContactModel`` live.
    # seed 003 Eqs. 2-24
    """
    load = SEED003_EXAMPLE_ROLLER_LOAD_N if roller_load_n is None else checked_load_n("roller load", roller_load_n)
    if params.stress_model == "numerical":
        return _numerical_report(params, load)
    half_length = 0.5 * params.roller_length_m
    maxima = mcewen_maxima(float(params.friction), float(params.poisson))
    if load == 0:
        return _assemble(None, maxima, half_length, params.allowable_contact_stress_pa, params.warn_fraction, 0.0)
    contact = finite_roller_contact(load, params.roller_length_m, params.roller_diameter_m,
                                    params.youngs_modulus_pa, params.poisson)
    report = _assemble(contact.scalars, maxima, half_length, params.allowable_contact_stress_pa,
                       params.warn_fraction, load)
    report["load_balance_ratio"] = contact.load_balance_ratio
    return report


def _loads_extra(rows: AxialRowLoads, radial_max: float) -> tuple[float, dict[str, Any]]:
    candidates = {"axial_main": rows.main_row_max_n, "axial_opposite": rows.opposite_row_max_n, "radial": radial_max}
    worst = max(candidates, key=candidates.get)
    extra = {
        "axial_main_row_max_n": rows.main_row_max_n,
        "axial_opposite_row_max_n": rows.opposite_row_max_n,
        "radial_row_max_n": radial_max,
        "main_row_unloaded": rows.main_row_unloaded,
        "opposite_row_unloaded": rows.opposite_row_unloaded,
        "main_row_partly_unloaded": rows.main_row_partly_unloaded,
        "worst_row": worst,
    }
    return max(candidates[worst], 0.0), extra


def slewing_contact_report_from_loads(params: Any, axial_load_n: float, radial_load_n: float,
                                      tilting_moment_nm: float) -> dict[str, Any]:
    """Report for the worst roller under F_a [N], F_r [N] and M_T [N m] (direct path).  # seed 003 Eq. 1

    The worst roller is the highest of both axial rows (Eq. 1) and the radial row (4.08 F_r/n_r); the
    radial row is ASSUMED to have the axial rollers' size (the seed does not give it), n_r =
    ``radial_roller_count`` or ``roller_count`` when 0.
    """
    rows = axial_row_roller_loads(axial_load_n, tilting_moment_nm, params.roller_count, params.raceway_diameter_m)
    n_radial = params.radial_roller_count or params.roller_count
    load, extra = _loads_extra(rows, radial_row_roller_load_max_n(radial_load_n, n_radial))
    report = slewing_contact_report(params, load)
    report.update(extra)
    return report


class SlewingContactModel:
    """Cached roller-contact model for a live node (microseconds per report).

    Everything that depends only on the parameters is computed once: E*, R, Palmgren's k1, and the
    McEwen maxima (von Mises, maximum shear: value / p0, x / a, z / a) at the configured friction and
    Poisson ratio. Per load only Eq. 1 and the scalar Eqs. 2/3/5/7/8/10 remain (a few ``math`` calls);
    the Eq. 5 end ratio depends weakly on the load (through ln(l/a)) and is evaluated per call.
    Results equal ``slewing_contact_report``/``slewing_contact_report_from_loads`` (without
    ``load_balance_ratio``, which needs a quadrature).
    """

    def __init__(self, params: Any) -> None:
        self.params = params
        self.numerical = params.stress_model == "numerical"
        self.roller_count = int(params.roller_count)
        self.radial_roller_count = int(params.radial_roller_count or params.roller_count)
        self.raceway_diameter_m = float(params.raceway_diameter_m)
        self.length_m = float(params.roller_length_m)
        self.half_length_m = 0.5 * self.length_m
        self.effective_modulus_pa = effective_modulus_pa(params.youngs_modulus_pa, params.poisson)
        self.radius_m = effective_radius_m(params.roller_diameter_m)
        self.k1 = palmgren_line_stiffness(self.length_m)
        self.allowable_pa = float(params.allowable_contact_stress_pa)
        self.warn_fraction = float(params.warn_fraction)
        self.maxima = cached_mcewen_maxima(float(params.friction), float(params.poisson))
        self.table = None
        if self.numerical:
            from guide_health.models.slewing.numerical_roller import build_roller_contact_table

            self.table = build_roller_contact_table(
                self.params, float(params.numerical_table_min_load_n), float(params.numerical_table_max_load_n),
                n_loads=int(params.numerical_table_loads), check_midpoints=2)

    def report_for_roller_load(self, roller_load_n: float) -> dict[str, Any]:
        """Report for one roller load Q [N] (>= 0, finite)."""
        load = float(roller_load_n)
        if not (load >= 0.0 and math.isfinite(load)):
            raise ValueError(f"roller load must be finite and >= 0, got {roller_load_n!r}")
        if self.numerical and load > 0.0:
            report = _numerical_report(self.params, load, self.table.lookup(load))
            report["table_in_range"] = report.pop("in_range")
            return report
        if load == 0.0:
            return _assemble(None, self.maxima, self.half_length_m, self.allowable_pa, self.warn_fraction, 0.0)
        scalars = finite_roller_scalars(load, self.half_length_m, self.radius_m, self.effective_modulus_pa,
                                        self.length_m, self.k1)
        return _assemble(scalars, self.maxima, self.half_length_m, self.allowable_pa, self.warn_fraction, load)

    def report_for_loads(self, axial_load_n: float, radial_load_n: float, tilting_moment_nm: float) -> dict[str, Any]:
        """Report for the worst roller under F_a, F_r [N] and M_T [N m].  # seed 003 Eq. 1"""
        rows = axial_row_roller_loads(axial_load_n, tilting_moment_nm, self.roller_count, self.raceway_diameter_m)
        load, extra = _loads_extra(rows, radial_row_roller_load_max_n(radial_load_n, self.radial_roller_count))
        report = self.report_for_roller_load(load)
        report.update(extra)
        return report


# ----------------------------------------------------------------------------------------------------
# Monitor core (the slewing_monitor node without ROS)
# ----------------------------------------------------------------------------------------------------
class SlewingMonitor:
    """ROS-free core of the node: worst case per publish period, input validation, levels."""

    def __init__(self, params: Any):
        self.params = params
        self.model = SlewingContactModel(params)
        self.worst: dict | None = None
        self.last_report: dict | None = None
        self.loads_in_period = 0
        self.rejected = 0
        self.last_problem: str | None = None
        self.worst_sample: dict | None = None
        # load samples missing by stamp gaps (models/wear/stream_gaps.py, as wear_monitor's streams): what a
        # reliable KEEP_LAST writer overwrote without any DDS loss event
        self.stamp_gaps = StampGaps()
        # rating life per row over the axis angle, static safety of the worst sample (docs/slewing.md)
        self.fatigue = SlewingFatigue(
            slewing_ratings(params.roller_count, params.radial_roller_count or params.roller_count,
                            params.roller_diameter_m, params.roller_length_m, params.raceway_diameter_m,
                            params.raceway_hardness_hrc),
            reversal_deadband_rad=params.reversal_deadband_rad,
            limiting_curve=((tuple(params.limiting_curve_axial_load_n), tuple(params.limiting_curve_moment_nm))
                            if params.limiting_curve_axial_load_n else None))
        self.rejected_angles = 0
        # raceway wear of the axial rows -> tilting clearance, k from measured clearances (raceway_wear.py)
        self.wear = raceway_wear_model(params)
        self.rejected_clearances = 0

    def reject_axis_angle(self) -> None:
        """Count an axis sample the node could not use (malformed message, joint missing, non-finite)."""
        self.rejected_angles += 1

    def on_axis_angle(self, angle_rad: float, t_ns: int | None = None) -> str | None:
        """One slewing-axis angle [rad] (``t_ns``: its stamp); returns the rejection reason or None."""
        if not math.isfinite(angle_rad):
            self.reject_axis_angle()
            return "non-finite axis angle (NaN/inf) ignored"
        fatigue = self.fatigue
        open_travel, strokes = fatigue.stroke_travel_rad, fatigue.strokes
        fatigue.on_angle(angle_rad, None if t_ns is None else t_ns * 1e-9)
        # the new ground the fatigue counter accepted (a reversal restarts its open stroke's travel)
        self.wear.on_travel(fatigue.stroke_travel_rad - (open_travel if fatigue.strokes == strokes else 0.0))
        return None

    def on_tilting_clearance(self, clearance_m: float, t_ns: int | None = None) -> str | None:
        """A measured tilting clearance [m] (topic or the maintenance service's measure), dated ``t_ns`` (None:
        the latest axis stamp); returns the rejection reason (counted) or None."""
        last = self.fatigue.last_t_s
        stamp = t_ns if t_ns is not None else (round(last * 1e9) if last is not None else 0)
        reason = self.wear.on_measurement(stamp, clearance_m)
        if reason:
            self.rejected_clearances += 1
        return reason

    def elapsed_s(self) -> float:
        """Time between the first and the latest axis stamp [s] (the duty so far)."""
        f = self.fatigue
        return (f.last_t_s - f.first_t_s) if f.first_t_s is not None else 0.0

    def on_loads(self, axial_n: float, radial_n: float, moment_nm: float, t_ns: int | None = None) -> str | None:
        """One load sample (``t_ns``: its header stamp, None when unknown or invalid); returns the rejection
        reason or None."""
        if t_ns is not None:        # a received sample, bad or not, is not a missing one
            self.stamp_gaps.add(t_ns)
        if not all(math.isfinite(v) for v in (axial_n, radial_n, moment_nm)):
            self.rejected += 1
            self.last_problem = "non-finite load"
            return "non-finite load (NaN/inf) ignored"
        report = self.model.report_for_loads(axial_n, radial_n, moment_nm)
        self.fatigue.on_loads(axial_n, radial_n, moment_nm)
        self.wear.on_loads(axial_n, moment_nm)
        self.worst_sample = report              # the report of this sample (offline analysis reads it)
        self.loads_in_period += 1
        if self.worst is None or report["p_max_MPa"] > self.worst["p_max_MPa"]:
            self.worst = report
        return None

    def period_report(self) -> tuple[Level, str, dict]:
        """Level, message and values for the period just ended (the worst roller since the last call)."""
        report = self.worst or self.last_report
        values = dict(report or {})
        values["loads_in_period"] = self.loads_in_period
        values["rejected_loads"] = self.rejected
        gaps = self.stamp_gaps
        values.update(samples_missing_estimate=gaps.missing, load_period_estimate_us=gaps.period_ns * 1e-3,
                      load_stamp_pauses=gaps.pauses)
        if report is None:
            level, message = WARN, "no valid load received yet"
            if self.last_problem:
                message = f"no valid load received yet ({self.last_problem})"
        else:
            level, message = Level(report["level"]), report["message"]
            if report.get("main_row_unloaded") and report.get("opposite_row_unloaded"):
                level, message = max(level, WARN), "no axial roller is loaded: " + message
            elif report.get("main_row_partly_unloaded"):
                # normal for a three-row roller bearing under a crane's moment: the retaining row takes
                # it; reported, but not a warning by itself
                message = ("tilting moment lifts the main row's rollers off on the far side "
                           "(4 M_T / D0 > F_a, the retaining row takes the moment); " + message)
            if self.loads_in_period == 0 and self.rejected:
                level = max(level, WARN)
                message = f"only invalid loads this period ({self.last_problem}); last valid: {message}"
        fatigue_level, fatigue_message, fatigue_values = self.fatigue.report()
        values.update(fatigue_values, rejected_axis_angles=self.rejected_angles)
        values.update(self.wear.report(self.elapsed_s()), rejected_tilting_clearances=self.rejected_clearances)
        if report is not None and fatigue_level > OK:
            level, message = max(level, fatigue_level), f"{message}; {fatigue_message}"
        if gaps.missing:
            message = f"{message}; {gaps.missing} load samples missing (stamp gaps)"
        if report is not None and self.worst is not None:
            self.last_report = self.worst
        self.worst = None
        self.loads_in_period = 0
        return level, message, values


def raceway_wear_model(params: Any) -> RacewayWear:
    """The raceway wear model of the configured bearing: chi(Q) of its rollers, k's prior and the clearances."""
    chi = sliding_weight_table(params.roller_length_m, params.roller_diameter_m, params.youngs_modulus_pa,
                               params.poisson)
    estimator = WearCoefficientEstimator(params.raceway_wear_coefficient_m2_n,
                                         params.raceway_wear_coefficient_rel_sd,
                                         params.tilting_clearance_noise_m, params.tilting_clearance_initial_m)
    return RacewayWear(params.roller_count, params.raceway_diameter_m, chi, estimator,
                       params.tilting_clearance_limit_m)
