"""slewing_monitor parameters: roller/raceway contact of a three-row roller slewing bearing (seed 003).

Defaults: the seed 003 bearing 131.32.2000.00Z (Feng, Qi, Tong, China Mechanical Engineering 28(4) 2017,
Sec. 4: E = 210 GPa, nu = 0.3, d = 32 mm, l = 31.3 mm, f = 0.1). JB/T 2300 designation 13 1 .32 .2000:
three-row roller, roller diameter 32 mm, raceway centre diameter D0 = 2000 mm. The seed gives no roller
count; 170 per axial row is an ESTIMATE (pi D0 / 170 = 37 mm pitch = roller + ~5 mm spacer).
"""
from __future__ import annotations

import math
from typing import Any

from guide_health.errors import InputError
from guide_health.params.machine import MAINTENANCE_PARAMS
from guide_health.params.schema import NodeSchema, NumberList, Param, alarm_and_sensor_qos_params, executor_param

#: ISO 76:2006 static load rating reference: 4000 MPa contact stress at the most heavily loaded
#: roller/raceway contact of roller bearings (through-hardened bearing steel, >= 58 HRC).
ISO76_ROLLER_CONTACT_STRESS_PA: float = 4.0e9

STRESS_MODELS = ("seed003", "numerical")
ROLLER_PROFILES = ("straight", "crowned", "logarithmic")

SLEWING_MONITOR_PARAMS = (
    Param("machine_id", "machine", "", "", "machine name: hardware_id of the diagnostics"),
    Param("bearing", "131.32.2000.00Z", "", "", "bearing designation (status name)"),
    Param("roller_count", 170, "-", "[1, 100000]", "n, rollers per axial row (seed 003 bearing: estimate)"),
    Param("radial_roller_count", 0, "-", "[0, 100000]", "n_r of the radial row; 0 = same as roller_count (assumed)"),
    Param("raceway_diameter_m", 2.0, "m", "(0, 50]", "D0, raceway centre diameter"),
    Param("roller_diameter_m", 0.032, "m", "(0, 1]", "d, roller diameter"),
    Param("roller_length_m", 0.0313, "m", "(0, 1]", "l_e, effective contact length of a roller"),
    Param("youngs_modulus_pa", 210.0e9, "Pa", "[1e8, 1e12]", "E of rollers and rings"),
    Param("poisson", 0.3, "-", "[0, 0.5)", "nu of rollers and rings"),
    Param("friction", 0.1, "-", "[0, 1)", "f_s, friction coefficient of the surface traction (seed 003 Sec. 4)"),
    Param("allowable_contact_stress_pa", ISO76_ROLLER_CONTACT_STRESS_PA, "Pa", "[1e6, 1e11]",
          "ERROR above this peak contact pressure (ISO 76 reference: 4000 MPa)", dynamic=True),
    Param("warn_fraction", 0.8, "-", "(0, 1)", "WARN above this fraction of allowable_contact_stress_pa",
          dynamic=True),
    Param("stress_model", "seed003", "", "", "seed003 (finite roller, Eqs. 2-10) or numerical",
          choices=STRESS_MODELS),
    Param("roller_profile", "straight", "", "", "numerical model: roller profile", choices=ROLLER_PROFILES),
    Param("roller_end_radius_m", 1.0e-3, "m", "[0, 0.5]",
          "numerical model: edge blend radius r (assumed ~1 mm for d = 32 mm)"),
    Param("crown_drop_m", 15.0e-6, "m", "[0, 1e-3]", "numerical model, crowned profile: drop at the roller ends"),
    Param("log_profile_coeff_m", 0.00035 * 0.032, "m", "[0, 1e-3]",
          "numerical model, logarithmic profile: ISO/TS 16281 0.00035 D; 0 = Lundberg 2P'/(pi E*)"),
    Param("numerical_table_min_load_n", 2.0e3, "N", "(0, 1e9]",
          "numerical model live: lowest roller load of the log-spaced table"),
    Param("numerical_table_max_load_n", 4.0e5, "N", "(0, 1e9]",
          "numerical model live: highest roller load of the table (> min)"),
    Param("numerical_table_loads", 16, "-", "[4, 10000]", "numerical model live: loads in the table"),
    Param("raceway_hardness_hrc", 55.0, "HRC", "[20, 70]",
          "raceway surface hardness: C and C0 x (HRC/58)^3.6 below 58 (induction hardened: assumed 55)"),
    Param("axis_topic", "slewing/joint_states", "", "", "sensor_msgs/JointState of the slewing axis (angle)"),
    Param("axis_joint", "slew", "", "", "joint name of the slewing axis in axis_topic"),
    Param("reversal_deadband_rad", 1.0e-3, "rad", "(0, 1]",
          "a reversal of the axis counts once it came back this far (encoder noise is no oscillation)"),
    # the manufacturer's static limiting load curve M_lim(F_a) (docs/slewing.md): a table, both lists empty = none
    Param("limiting_curve_axial_load_n", NumberList(), "N", "",
          "static limiting load curve: F_a values, strictly ascending (empty: no curve)"),
    Param("limiting_curve_moment_nm", NumberList(), "N m", "",
          "static limiting load curve: the allowed M_T at each F_a (>= 0, not rising with F_a)"),
    # raceway wear of the axial rows -> tilting clearance (models/slewing/raceway_wear.py, docs/slewing.md)
    Param("tilting_clearance_topic", "slewing/tilting_clearance", "", "",
          "std_msgs/Float64: a measured tilting clearance [m] (the tilting test), dated at the latest axis stamp"),
    Param("tilting_clearance_initial_m", 0.3e-3, "m", "(0, 0.01]",
          "c_0, the tilting clearance of the new bearing (the acceptance record or the first tilting test)"),
    Param("tilting_clearance_limit_m", 1.0e-3, "m", "(0, 0.01]",
          "replacement clearance: the manufacturer's permissible tilting clearance for this size (> c_0)"),
    Param("tilting_clearance_noise_m", 20.0e-6, "m", "(0, 0.001]",
          "sd of one tilting-clearance reading (dial gauge and the test's repeatability)"),
    Param("raceway_wear_coefficient_m2_n", 1.0e-13, "m^2/N", "(0, 1e-6]",
          "prior of k = K/H, Archard's dimensional wear coefficient of the raceways (learned from the clearances)"),
    Param("raceway_wear_coefficient_rel_sd", 2.0, "-", "(0, 10]",
          "relative sd of the prior of k (wear coefficients scatter by orders of magnitude: a weak prior)"),
    *MAINTENANCE_PARAMS[:4],
    Param("diagnostics_period_s", 1.0, "s", "[0.01, 3600]", "period of the /diagnostics status", dynamic=True),
    Param("input_timeout_s", 2.0, "s", "(0, 86400]", "STALE when slewing/load is silent longer", dynamic=True),
    Param("state_file", "auto", "", "",
          "SQLite state file of the fatigue damage; auto = $ROS_HOME/guide_health/<machine_id>/<node>.db "
          "(ROS_HOME: ~/.ros); '' or none = no persistence"),
    Param("state_reset", False, "", "",
          "start from zero when state_file holds a state of another bearing geometry (replaced at the next "
          "checkpoint); false: such a state stops the node at start, nothing overwritten"),
    Param("input_align_window_s", 0.5, "s", "[0, 60]",
          "loads and axis angles are taken in stamp order; a sample waits up to this (wall time) for the other "
          "topic; 0 = on arrival"),
    Param("checkpoint_period_s", 10.0, "s", "[0.1, 86400]", "period of the SQLite state commit", dynamic=True),
    executor_param("rclpy EventsExecutor: the messages in arrival order across topics, so a tilting clearance "
                   "is dated after every axis sample received before it"),
    *alarm_and_sensor_qos_params("slewing/load"),
)


def _check_types(params: dict[str, Any]) -> None:
    for name in ("machine_id", "bearing", "stress_model", "roller_profile", "axis_topic", "axis_joint",
                 "state_file", "tilting_clearance_topic"):
        if not isinstance(params.get(name), str):
            raise InputError(f"parameter {name} must be a string, got {params.get(name)!r}")
    for name in ("roller_count", "radial_roller_count"):
        value = params.get(name)
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"parameter {name} must be an integer, got {value!r}")
    if params["roller_count"] < 1:
        raise InputError(f"parameter roller_count must be >= 1, got {params['roller_count']!r}")
    if params["radial_roller_count"] < 0:
        raise InputError(f"parameter radial_roller_count must be >= 0, got {params['radial_roller_count']!r}")
    numbers = ("raceway_diameter_m", "roller_diameter_m", "roller_length_m", "youngs_modulus_pa", "poisson",
               "friction", "allowable_contact_stress_pa", "warn_fraction", "roller_end_radius_m",
               "crown_drop_m", "log_profile_coeff_m", "diagnostics_period_s", "input_timeout_s",
               "raceway_hardness_hrc", "reversal_deadband_rad", "checkpoint_period_s",
               "input_align_window_s", "tilting_clearance_initial_m", "tilting_clearance_limit_m",
               "tilting_clearance_noise_m", "raceway_wear_coefficient_m2_n", "raceway_wear_coefficient_rel_sd")
    for name in numbers:
        value = params.get(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"parameter {name} must be a finite number, got {value!r}")


def _check_numerical_table(params: dict[str, Any]) -> None:
    defaults = SLEWING_MONITOR_SCHEMA
    lo = params.get("numerical_table_min_load_n", defaults["numerical_table_min_load_n"].default)
    hi = params.get("numerical_table_max_load_n", defaults["numerical_table_max_load_n"].default)
    n_table = params.get("numerical_table_loads", defaults["numerical_table_loads"].default)
    if not (isinstance(lo, (int, float)) and isinstance(hi, (int, float)) and 0 < lo < hi):
        raise InputError("numerical_table_min_load_n/numerical_table_max_load_n: need 0 < min < max")
    if isinstance(n_table, bool) or not isinstance(n_table, int) or n_table < 4:
        raise InputError(f"parameter numerical_table_loads must be an integer >= 4, got {n_table!r}")


def _slewing_cross_checks(params: dict[str, Any]) -> None:
    _check_types(params)
    for name in ("raceway_diameter_m", "roller_diameter_m", "roller_length_m", "youngs_modulus_pa",
                 "allowable_contact_stress_pa", "diagnostics_period_s", "input_timeout_s"):
        if not params[name] > 0:
            raise InputError(f"parameter {name} must be > 0, got {params[name]!r}")
    if not 0.0 <= params["poisson"] < 0.5:
        raise InputError(f"parameter poisson must be in [0, 0.5), got {params['poisson']!r}")
    if not 0.0 <= params["friction"] < 1.0:
        raise InputError(f"parameter friction must be in [0, 1), got {params['friction']!r}")
    if not 0.0 < params["warn_fraction"] < 1.0:
        raise InputError(f"parameter warn_fraction must be in (0, 1), got {params['warn_fraction']!r}")
    if params["stress_model"] not in STRESS_MODELS:
        raise InputError(f"parameter stress_model must be one of {STRESS_MODELS}, got {params['stress_model']!r}")
    if params["roller_profile"] not in ROLLER_PROFILES:
        raise InputError(f"parameter roller_profile must be one of {ROLLER_PROFILES}, "
                         f"got {params['roller_profile']!r}")
    _check_numerical_table(params)
    for name in ("roller_end_radius_m", "crown_drop_m", "log_profile_coeff_m"):
        if params[name] < 0:
            raise InputError(f"parameter {name} must be >= 0, got {params[name]!r}")
    if params["roller_end_radius_m"] > 0.5 * params["roller_length_m"]:
        raise InputError("parameter roller_end_radius_m must not exceed half the roller length")
    _check_limiting_curve(params["limiting_curve_axial_load_n"], params["limiting_curve_moment_nm"])
    if not params["tilting_clearance_limit_m"] > params["tilting_clearance_initial_m"]:
        raise InputError(f"tilting_clearance_limit_m {params['tilting_clearance_limit_m']!r} must exceed "
                         f"tilting_clearance_initial_m {params['tilting_clearance_initial_m']!r}")
    if params["roller_diameter_m"] >= params["raceway_diameter_m"]:
        raise InputError("roller_diameter_m must be smaller than raceway_diameter_m")
    if params["roller_count"] * params["roller_diameter_m"] > math.pi * params["raceway_diameter_m"]:
        raise InputError(f"{params['roller_count']} rollers of {params['roller_diameter_m']} m do not fit on a "
                         f"raceway of diameter {params['raceway_diameter_m']} m")


def _check_limiting_curve(axial_n: list, moment_nm: list) -> None:
    """The manufacturer's curve: one M_T per F_a, none or >= 2 points, F_a strictly ascending, M_T >= 0 and
    not rising with F_a (a static limiting load curve falls as the axial load grows)."""
    if len(axial_n) != len(moment_nm):
        raise InputError(f"limiting_curve_axial_load_n has {len(axial_n)} values, limiting_curve_moment_nm "
                         f"{len(moment_nm)}: one allowed moment per axial load")
    if not axial_n:
        return
    if len(axial_n) < 2:
        raise InputError("limiting load curve: need >= 2 points (F_a, M_T)")
    if any(b <= a for a, b in zip(axial_n, axial_n[1:])):
        raise InputError(f"limiting_curve_axial_load_n must be strictly ascending, got {axial_n}"[:200])
    if min(moment_nm) < 0 or any(b > a for a, b in zip(moment_nm, moment_nm[1:])):
        raise InputError(f"limiting_curve_moment_nm must be >= 0 and not rising with F_a, got {moment_nm}"[:200])


SLEWING_MONITOR_SCHEMA = NodeSchema("slewing_monitor", SLEWING_MONITOR_PARAMS, _slewing_cross_checks)


def validate_slewing_params(params: dict[str, Any]) -> None:
    """Check slewing_monitor parameters; raise :class:`InputError` with a one-line reason."""
    SLEWING_MONITOR_SCHEMA.validate(params)
