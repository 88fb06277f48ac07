"""wear_monitor parameters: sliding guide (seed 000) and rolling guide (seed 001) precision monitoring.

Defaults: the seed 000 bench (45 steel slider on an HT200 rail) and the seed 001 NSK LH45 carriage. Ranges are
wide physical bounds, not design limits.
"""
from __future__ import annotations

from typing import Any

from guide_health.errors import InputError
from guide_health.models.rolling.lubrication import LAMBDA_BOUNDARY, LAMBDA_FULL_FILM  # the one source
from guide_health.models.wear.effect_life import covariance_problem
from guide_health.models.wear.effects.registry import (
    BY_ID,
    COVARIANCE_NAMES,
    COVARIANCE_SIZES,
    GAUGE_TEMPERATURE,
    LIVE_EFFECT_IDS,
    LIVE_PARAMETERS,
)
from guide_health.models.wear.form_average import LEGACY_RUNNING_IN_FORMS, LIFE_FORMS
from guide_health.params.machine import AXES_PARAM, MAINTENANCE_PARAMS, PLAN_PARAMS
from guide_health.params.schema import NodeSchema, Param, alarm_and_sensor_qos_params, executor_param

_N = len(COVARIANCE_NAMES)

#: the wear profile's bins (rail_length_m / profile_bin_m) at most: 1e6 bins = 8 MB per profile array
MAX_PROFILE_BINS = 1_000_000
#: duty_window_s at least this many diagnostics periods (the duty is averaged over DUTY_BUCKETS buckets)
DUTY_WINDOW_MIN_PERIODS = 3

SLIDING_GUIDE_PARAMS = (
    Param("machine_id", "machine", "", "", "machine name: hardware_id of the diagnostics, key in the state file"),
    Param("machine_type", "", "", "",
          "machine type (model/series): machines of one type share a fleet prior (guide-health fleet prior)"),
    Param("joint", "x", "", "", "the axis to monitor: its name in sensor_msgs/JointState (without 'axes')"),
    AXES_PARAM,
    Param("guide_type", "sliding", "", "", "sliding (seed 000 Archard wear) or rolling (seed 001 ball guide)",
          choices=("sliding", "rolling")),
    Param("contact_width_m", 0.040, "m", "(0, 10]", "b, width of the sliding contact"),
    Param("hardness_pa", 199.0e6, "Pa", "[1e6, 1e11]",
          "H of the softer (worn) surface. NOTE: seed 000's '199 N/mm^2' for HT200 is a Brinell NUMBER (HB 199, a "
          "real hardness of about 1.95e9 Pa); only K/H enters the model, so K = 4.42e-6 belongs with H = 199e6. "
          "With a real hardness in Pa, scale K by the same factor (about 4.3e-5) or the wear is ~10x too low"),
    Param("wear_coefficient", 4.42e-6, "-", "[1e-12, 1e-1]",
          "K, dimensionless Archard wear coefficient, ALWAYS a pair with hardness_pa: only K/H enters the wear "
          "(V = K W s / H, seed 000 Eq. 10). Seed 000: K = 4.42e-6 with H = 199e6 (K/H = 2.22e-14 1/Pa, its "
          "pin-on-disc fit). A start-up warning names a real hardness in Pa (> 1e9) used with the seed's K"),
    Param("stroke_min_m", 0.0, "m", "[0, 100]", "l_min, shortest stroke; 0 = estimate from the observed strokes"),
    Param("stroke_max_m", 0.0, "m", "[0, 100]", "l_max, longest stroke; 0 = estimate from the observed strokes"),
    Param("stroke_detect_min_m", 0.005, "m", "[0, 1]", "reversal hysteresis: reversals closer than this are jitter"),
    Param("sliding_deadband_m", 10.0e-6, "m", "[0, 0.01]",
          "sliding deadband: a reversal of motion shorter than this is encoder noise, not sliding "
          "(about 10 x the position noise sd; 0 = every change of position slides)"),
    Param("straightness_initial_m", 15.0e-6, "m", "[0, 0.01]", "A0, straightness of the new guide"),
    Param("straightness_limit_m", 100.0e-6, "m", "(0, 0.01]", "A_max, absolute straightness limit"),
    Param("straightness_model", "eq7", "", "", "eq7 (seed 000 Eq. 7) or profile (wear depth along the rail)",
          choices=("eq7", "profile")),
    Param("slider_length_m", 0.100, "m", "(0, 10]", "profile model: length of the slider contact"),
    Param("rail_start_m", -0.100, "m", "[-100, 100]",
          "rail coordinate of the rail's first end: the first profile bin, and the start of the axis travel "
          "the input rules accept"),
    Param("rail_length_m", 0.500, "m", "(0, 100]",
          "rail length: covered by the profile bins, and the axis travel the input rules accept"),
    Param("profile_bin_m", 0.001, "m", "[1e-6, 1]", "profile model: bin width"),
    Param("duty_window_s", 3600.0, "s", "[1, 1e8]",
          "window over which the current duty W v is averaged (>= 3 diagnostics periods)"),
    Param("idle_after_s", 300.0, "s", "[1, 86400]",
          "a pause of the axis longer than this is idle, not running: the duty and remaining life keep their "
          "values at the last motion and the pause does not count as running time (shorter pauses, a tool "
          "change or a probe cycle, are part of running)"),
    Param("utilisation_window_days", 7.0, "d", "[0.01, 366]",
          "calendar window over which the axis's utilisation (running share) is judged; limit_date_utc is "
          "the remaining running life at that utilisation"),
    # the load source (models/wear/load_model.py): a load cell on load_topic, or the masses and the motion
    Param("load_source", "topic", "", "", "topic: the normal load from load_topic (a load cell); model: from "
          "the masses below, the axis incline and the acceleration of the joint (no load topic needed)",
          choices=("topic", "model")),
    Param("moving_mass_kg", 0.0, "kg", "[0, 1e6]", "load_source model: mass the axis moves (carriage, table, "
          "saddle, head, with what rides on it except the workpiece)"),
    Param("workpiece_mass_kg", 0.0, "kg", "[0, 1e6]", "load_source model: workpiece (and fixture) mass the axis "
          "carries (0 for an axis that does not carry it)"),
    Param("axis_incline_deg", 0.0, "deg", "[-90, 90]", "load_source model: angle of the axis above the "
          "horizontal (0: horizontal, the ways carry the weight; 90: vertical, the drive carries it)"),
    Param("load_lever_ratio", 0.0, "-", "[0, 100]", "load_source model: e / h, the centre of mass's offset "
          "from the drive line over the spacing of the carriages (way ends) that react its couple"),
    Param("acceleration_window_s", 0.05, "s", "(0, 10]", "load_source model: the acceleration is the mean "
          "over about twice this (secants of the joint position over this lag)"),
    Param("straightness_noise_m", 0.5e-6, "m", "[0, 0.01]",
          "1-sigma noise of a straightness measurement (prior of the K update)", dynamic=True),
    Param("wear_coefficient_prior_rel_sd", 0.5, "-", "(0, 100]", "prior sd of K relative to the configured K"),
    # wear effects learnt by `guide-health diagnose` (its DIR/model.yaml; models/wear/effects/); the defaults
    # are the plain Archard model
    Param("effects", "", "", "", "effects the live model integrates, comma-separated ids of models/wear/effects/ "
          "(written by diagnose --out DIR as DIR/model.yaml; '' = plain Archard wear)"),
    # the effects' own parameters (name, default, unit, range, meaning: the effect registry's)
    *(Param(e.name, e.default, e.unit, e.range_text, e.meaning, choices=e.choices) for e in LIVE_PARAMETERS),
    Param("effect_covariance", [0.0] * len(COVARIANCE_NAMES) ** 2, "SI", "",
          f"covariance (row-major {_N} x {_N}) of the fitted {', '.join(COVARIANCE_NAMES[:-1])} and "
          f"{COVARIANCE_NAMES[-1]} (SI; {GAUGE_TEMPERATURE.row_names[1]}: the gauge's offset at "
          f"{GAUGE_TEMPERATURE.fields[1][0]}, 0 at the "
          "fitted values; straightness_initial_m: A0 when fitted); widens the remaining-life interval (the "
          f"{' or '.join(f'{n} x {n}' for n in COVARIANCE_SIZES[:-1])} of an older model file loads as the "
          "leading block)"),
    # the running-in form's uncertainty (models/wear/form_average.py; LIFE_FORMS order, the carried model first)
    Param("life_form_weights", [1.0] + [0.0] * (len(LIFE_FORMS) - 1), "-", "[0, 1]",
          f"BIC weights of the model the file carries and of the running-in in each decay law "
          f"({', '.join(LIFE_FORMS)}; sum 1; written by diagnose): the remaining-life interval averages their "
          "forecasts"),
    Param("life_form_ln_life_offsets", [0.0] * len(LIFE_FORMS), "-", "[-50, 50]",
          "ln(life of the form / life of the carried model) at the diagnosed record's end, per form"),
    Param("life_form_ln_life_sd_ratios", [1.0] * len(LIFE_FORMS), "-", "(0, 1e3]",
          "delta-method sd of ln(life) of each form over the carried model's, at the diagnosed record's end"),
    Param("life_form_interval", "mixture", "", "", "how the forms' forecasts make the 90 % interval: mixture "
          "(their BIC-weighted mixture's quantiles) or envelope (from the lowest form's low end to the highest's high "
          "end: diagnose's choice when the record holds unexplained structure)", choices=("mixture", "envelope")),
    Param("running_in_form_weights", [1.0] + [0.0] * (len(LEGACY_RUNNING_IN_FORMS) - 1), "-", "[0, 1]",
          f"model files of earlier versions: BIC weights of {', '.join(LEGACY_RUNNING_IN_FORMS)} (the exponential "
          "carried), read as life_form_weights when those are not given"),
    Param("running_in_form_ln_life_offsets", [0.0] * len(LEGACY_RUNNING_IN_FORMS), "-", "[-50, 50]",
          "model files of earlier versions: the offsets of running_in_form_weights' forms"),
    Param("life_warn_h", 500.0, "h", "(0, 1e7]", "WARN when the remaining precision life drops below this",
          dynamic=True),
    Param("life_error_h", 100.0, "h", "[0, 1e7]",
          "ERROR when the remaining precision life drops below this (< life_warn_h)",
          dynamic=True),
    Param("straightness_warn_fraction", 0.8, "-", "(0, 1)",
          "WARN above this fraction of straightness_limit_m, ERROR above the limit", dynamic=True),
    Param("diagnostics_period_s", 1.0, "s", "[0.01, 3600]", "period of the /diagnostics status", dynamic=True),
    Param("input_timeout_s", 5.0, "s", "(0, 86400]", "STALE when joint_states/load are silent longer (arrival time)",
          dynamic=True),
    Param("checkpoint_period_s", 2.0, "s", "[0.1, 86400]", "period of the SQLite state commit", dynamic=True),
    Param("input_align_window_s", 0.5, "s", "[0, 60]",
          "joint samples wait up to this (wall time) for the load stamped before them; 0 = integrate on arrival",
          dynamic=True),
    # input rules (guide_health/models/wear/input_rules.py): plausibility limits, time base, judgement
    Param("travel_margin_m", 0.100, "m", "[0, 100]",
          "joint positions further than this outside the rail (rail_start_m .. + rail_length_m) are rejected",
          dynamic=True),
    Param("load_max_n", 1.0e6, "N", "(0, 1e9]", "guide loads above this are rejected as implausible",
          dynamic=True),
    Param("load_max_rating_multiple", 3.0, "-", "[0, 1000]",
          "rolling guides with dynamic_load_rating_n > 0: loads above this multiple of carriages x C are "
          "rejected too; 0 = load_max_n only", dynamic=True),
    Param("straightness_max_multiple", 10.0, "-", "[1, 1e4]",
          "straightness measurements above this multiple of straightness_limit_m are rejected as implausible",
          dynamic=True),
    Param("stamp_horizon_s", 3600.0, "s", "(0, inf)",
          "a joint/load stamp further than this after the last accepted one is a candidate for a new time base"),
    Param("stamp_rebase_samples", 3, "-", "[1, 1000]",
          "consecutive agreeing candidates that make a new time base (fewer: rejected as a stamp jump)"),
    Param("rejected_window_samples", 1000, "-", "[1, 1000000]",
          "recent samples per input stream over which the rejected share is judged", dynamic=True),
    Param("rejected_share_warn", 0.5, "-", "[0, 1]",
          "WARN when more than this share of a stream's recent samples was rejected (names the reason)",
          dynamic=True),
    executor_param("rclpy EventsExecutor, raw CDR"),
    *alarm_and_sensor_qos_params("the data topics"),
    Param("state_file", "auto", "", "",
          "SQLite state file; auto = $ROS_HOME/guide_health/<machine_id>/<node>.db (ROS_HOME: ~/.ros); "
          "'' or none = no persistence"),
    Param("model_from_stamp_s", 0.0, "s", "[0, 1e10]",
          "the model (K, A0) describes the machine from this stamp on [s since the epoch, machine time base]: "
          "a load over the running model (~/load_model, replay --model-at) re-anchors the guide at its measurement "
          "there (diagnose --since writes it); 0 = a model of the whole record"),
    Param("model_file", "", "", "",
          "parameters file the ~/load_model service loads over the running model (a diagnose model.yaml); "
          "'' = none", dynamic=True),
)

ROLLING_GUIDE_PARAMS = (
    Param("ball_radius_m", 3.9685e-3, "m", "(0, 0.1]", "R1, ball radius"),
    Param("groove_conformity", 0.52, "-", "(0.5, 1]", "Gf: groove radius = Gf x ball diameter (straight groove)"),
    Param("contact_angle_deg", 50.0, "deg", "(0, 90)", "alpha, contact angle from the horizontal"),
    Param("balls_per_row", 10, "-", "[1, 10000]", "loaded balls per row"),
    Param("rows", 4, "-", "[1, 16]", "ball rows of the carriage (only 4-row carriages are modelled)"),
    Param("preload_n", 385.0, "N", "[0, 1e6]", "preload per ball contact"),
    Param("dynamic_load_rating_n", 0.0, "N", "[0, 1e8]", "C of one carriage at rating_distance_km; 0 = unknown"),
    Param("reverse_load_rating_factor", 1.0, "-", "(0, 10]",
          "C_reverse / C: rating of a reverse (lift-off, force.z < 0) load on the lower rows relative to the "
          "downward C. 1.0 for the seed 001 LH-type carriage (four rows at 50 deg, lower rows identical to the "
          "upper ones: equal ratings up and down); enter the catalogue's reverse-load factor for other designs"),
    Param("rolling_element", "ball", "", "", "ball or roller (life exponent 3 or 10/3)", choices=("ball", "roller")),
    Param("oil_viscosity_pa_s", 0.060, "Pa s", "[1e-5, 100]",
          "eta_0, dynamic oil viscosity at the operating temperature (VG68 at 40 degC inlet: 0.060); used when "
          "oil_viscosity_40c_mm2_s is 0, otherwise the Walther oil below sets eta_0"),
    Param("oil_viscosity_40c_mm2_s", 0.0, "mm^2/s", "[0, 1e5]",
          "catalogue kinematic viscosity at 40 degC; > 0 makes eta_0 follow the guide temperature by Walther/"
          "ASTM D341 through this and oil_viscosity_100c_mm2_s (seed 000's 68# oil: 65.4); 0 = constant "
          "oil_viscosity_pa_s"),
    Param("oil_viscosity_100c_mm2_s", 0.0, "mm^2/s", "[0, 1e4]",
          "catalogue kinematic viscosity at 100 degC (< the 40 degC value; seed 000's 68# oil: 8.83)"),
    Param("oil_density_15c_kg_m3", 880.0, "kg/m^3", "[500, 1500]",
          "oil density at 15 degC (falls 6.4e-4 per K); 880 gives seed 000's oil 0.163 Pa s at 21 degC"),
    Param("oil_temperature_c", 40.0, "degC", "[-50, 250]",
          "oil temperature for the Walther viscosity until guide/temperature reports (then its readings, "
          "applied by stamp live and offline alike)"),
    Param("pressure_viscosity_pa_inv", 2.0e-8, "1/Pa", "(0, 1e-6]", "alpha, pressure-viscosity coefficient"),
    Param("roughness_rms_m", 0.2e-6, "m", "(0, 1e-4]", "composite RMS roughness sqrt(Rq_ball^2 + Rq_groove^2)"),
    Param("asperity_radius_m", 2.0e-6, "m", "(0, 1e-3]", "beta, Greenwood-Tripp asperity summit radius"),
    Param("asperity_density_per_m2", 1.597e11, "1/m^2", "(0, 1e16]",
          "eta_s, Greenwood-Tripp summit density (1.597e11: seed 001's contact-area ratio 73.76 % at 0.001 m/s)"),
    Param("lambda_boundary", LAMBDA_BOUNDARY, "-", "(0, 100]",
          "boundary below this film/roughness ratio lambda (default: seed 001 Fig. 8, boundary below 0.0005 m/s "
          "with its 68# oil at 21 degC; models/rolling/lubrication.py)"),
    Param("lambda_full_film", LAMBDA_FULL_FILM, "-", "(0, 100]", "full film from this lambda on (> lambda_boundary)"),
    Param("life_factors", [1.0, 1.0, 1.0, 1.0], "-", "(0, 10]", "fh (hardness), ft (temperature), fc (contact), "
          "fw (load/shock) of the rating life"),
    Param("rating_distance_km", 50.0, "km", "(0, 1e6]", "rating distance of C (50 or 100 km)"),
    Param("youngs_modulus_pa", 206.0e9, "Pa", "[1e8, 1e12]", "E of ball and raceway"),
    Param("poisson", 0.3, "-", "[0, 0.5)", "nu of ball and raceway"),
    Param("carriages", 1, "-", "[1, 1000]", "carriages sharing the guide load equally (fatigue per carriage)"),
    Param("boundary_window_m", 100.0, "m", "(0, 1e7]", "travel over which the boundary-lubrication share is judged"),
    Param("boundary_share_warn", 0.5, "-", "[0, 1]", "WARN when the recent boundary share exceeds this",
          dynamic=True),
    Param("life_used_warn", 0.8, "-", "(0, 100]", "WARN when the used fatigue life fraction reaches this",
          dynamic=True),
    Param("life_used_error", 1.0, "-", "(0, 100]",
          "ERROR when the used fatigue life fraction reaches this (> life_used_warn)",
          dynamic=True),
)


def effect_ids(p: dict[str, Any]) -> list[str]:
    """The ``effects`` parameter as a list of ids ('' = none)."""
    return [e.strip() for e in str(p.get("effects", "")).split(",") if e.strip()]


def _effect_checks(p: dict[str, Any]) -> None:
    for e in effect_ids(p):
        if e not in LIVE_EFFECT_IDS:
            raise InputError(f"parameter effects: unknown or not live effect {e!r} "
                             f"(live: {', '.join(LIVE_EFFECT_IDS)})")
    if effect_ids(p) and p["straightness_model"] != "eq7":
        raise InputError("parameter effects: the live wear effects need straightness_model eq7")
    for e in effect_ids(p):
        need = BY_ID[e].requires
        if need is not None and not need.holds(p[need.parameter]):
            raise InputError(f"parameter effects: {e} needs {need.parameter} {need.condition}{need.note}")
    problem = covariance_problem(p["effect_covariance"])
    if problem:
        raise InputError(f"parameter effect_covariance {problem}")
    for key, forms in (("life_form_weights", LIFE_FORMS), ("running_in_form_weights", LEGACY_RUNNING_IN_FORMS)):
        if abs(sum(p[key]) - 1.0) > 1e-6:
            raise InputError(f"parameter {key} must sum to 1 (weights of {', '.join(forms)}), got {p[key]!r}")


def _wear_cross_checks(p: dict[str, Any]) -> None:
    for name in ("contact_width_m", "hardness_pa", "wear_coefficient", "slider_length_m",
                 "profile_bin_m", "rail_length_m", "duty_window_s", "diagnostics_period_s",
                 "straightness_limit_m"):
        if not p[name] > 0:
            raise InputError(f"parameter {name} must be > 0, got {p[name]!r}")
    for name in ("stroke_min_m", "stroke_max_m", "straightness_initial_m", "straightness_noise_m",
                 "input_align_window_s"):
        if p[name] < 0:
            raise InputError(f"parameter {name} must be >= 0, got {p[name]!r}")
    if (p["stroke_min_m"] > 0) != (p["stroke_max_m"] > 0) or p["stroke_max_m"] < p["stroke_min_m"]:
        raise InputError("stroke_min_m/stroke_max_m: both 0 (estimate) or 0 < min <= max")
    if p["guide_type"] not in ("sliding", "rolling"):
        raise InputError(f"guide_type must be 'sliding' or 'rolling', got {p['guide_type']!r}")
    if p.get("executor", "auto") not in ("auto", "events", "single_threaded"):
        raise InputError(f"executor must be 'auto', 'events' or 'single_threaded', got {p['executor']!r}")
    if p["straightness_model"] not in ("eq7", "profile"):
        raise InputError(f"straightness_model must be 'eq7' or 'profile', got {p['straightness_model']!r}")


def _wear_threshold_checks(p: dict[str, Any]) -> None:
    """Orders a range cannot express: thresholds, A0 below the limit, memory of the profile, the duty window."""
    if not p["life_error_h"] < p["life_warn_h"]:
        raise InputError(f"life_error_h ({p['life_error_h']!r} h) must be below life_warn_h ({p['life_warn_h']!r} h)")
    if not p["life_used_warn"] < p["life_used_error"]:
        raise InputError(f"life_used_warn ({p['life_used_warn']!r}) must be below life_used_error "
                         f"({p['life_used_error']!r})")
    if not p["straightness_initial_m"] < p["straightness_limit_m"]:
        raise InputError(f"straightness_initial_m ({p['straightness_initial_m']!r} m, A0) must be below "
                         f"straightness_limit_m ({p['straightness_limit_m']!r} m)")
    if not p["lambda_boundary"] < p["lambda_full_film"]:
        raise InputError("lambda_boundary must be below lambda_full_film")
    if p["oil_viscosity_40c_mm2_s"] > 0 and not 0 < p["oil_viscosity_100c_mm2_s"] < p["oil_viscosity_40c_mm2_s"]:
        raise InputError(f"oil_viscosity_100c_mm2_s ({p['oil_viscosity_100c_mm2_s']!r}) must be > 0 and below "
                         f"oil_viscosity_40c_mm2_s ({p['oil_viscosity_40c_mm2_s']!r})")
    if p["load_source"] == "model" and not p["moving_mass_kg"] + p["workpiece_mass_kg"] > 0:
        raise InputError("load_source model needs moving_mass_kg + workpiece_mass_kg > 0 (the masses the "
                         "normal load comes from)")
    bins = p["rail_length_m"] / p["profile_bin_m"]
    if not bins <= MAX_PROFILE_BINS:
        raise InputError(f"rail_length_m / profile_bin_m = {bins:.3g} bins: at most {MAX_PROFILE_BINS:.0e} "
                         f"(a coarser profile_bin_m)")
    if not p["duty_window_s"] >= DUTY_WINDOW_MIN_PERIODS * p["diagnostics_period_s"]:
        raise InputError(f"duty_window_s ({p['duty_window_s']!r} s) must be at least {DUTY_WINDOW_MIN_PERIODS} "
                         f"diagnostics periods ({p['diagnostics_period_s']!r} s)")


def _wear_all_checks(p: dict[str, Any]) -> None:
    _wear_cross_checks(p)
    _effect_checks(p)
    WEAR_MONITOR_SCHEMA.check_ranges(p)     # ranges first: the orders below compare in-range numbers
    _wear_threshold_checks(p)


SEED000_WEAR_COEFFICIENT = 4.42e-6      # seed 000 pin-on-disc K, fitted with H = 199e6 (HB 199 read as N/mm^2)
REAL_HARDNESS_PA = 1.0e9                 # above this, hardness_pa looks like a real hardness, not the HB number


def hardness_units_warning(p: dict[str, Any]) -> str | None:
    """A one-line start-up warning when hardness_pa looks like a real hardness (> 1e9 Pa) while K is the seed's
    4.42e-6, which was fitted with H = 199e6 (the Brinell number): the pair gives about 10x too little wear."""
    h, k = float(p["hardness_pa"]), float(p["wear_coefficient"])
    if h > REAL_HARDNESS_PA and abs(k - SEED000_WEAR_COEFFICIENT) <= 0.01 * SEED000_WEAR_COEFFICIENT:
        return (f"hardness_pa = {h:.3g} Pa looks like a real hardness, but wear_coefficient = {k:.3g} is seed 000's "
                f"K fitted with H = 199e6 (HB 199 read as N/mm^2): wear is {h / 199e6:.1f}x too low; use "
                f"wear_coefficient = {k * h / 199e6:.3g} with this H, or H = 199e6")
    return None


WEAR_MONITOR_SCHEMA = NodeSchema("wear_monitor", SLIDING_GUIDE_PARAMS + ROLLING_GUIDE_PARAMS + MAINTENANCE_PARAMS
                                 + PLAN_PARAMS,
                                 _wear_all_checks)


def validate_wear_params(p: dict[str, Any]) -> None:
    """wear_monitor parameters: positive sizes, known model names, stroke limits, then the declared ranges."""
    WEAR_MONITOR_SCHEMA.validate(p)
