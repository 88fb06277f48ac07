"""Scenarios of ``guide-health simulate``: a machine axis (section ``guide_health_simulation``, seed 000
bench by default) and a slewing-bearing crane duty (section ``guide_health_slewing_simulation``).

These sections are read by the CLI only (no node); ``dynamic`` is False throughout.
"""
from __future__ import annotations

from typing import Any

from guide_health.errors import InputError
from guide_health.models.wear.effects.registry import EFFECTS
from guide_health.params.schema import NodeSchema, Param

MACHINE_SIMULATION_PARAMS = (
    Param("duration_h", 20.0, "h", "(0, inf)", "simulated machine time"),
    Param("joint_state_rate_hz", 50.0, "Hz", "(0, inf)", "rate of joint_states"),
    Param("load_rate_hz", 10.0, "Hz", "(0, inf)", "rate of guide/load"),
    Param("feed_speed_m_s", 0.05, "m/s", "(0, inf)", "feed (working) stroke speed"),
    Param("retract_speed_m_s", 0.05, "m/s", "(0, inf)", "return stroke speed"),
    Param("feed_load_n", 6000.0, "N", "[0, inf)", "guide load on the feed stroke"),
    Param("retract_load_n", 6000.0, "N", "[0, inf)", "guide load on the return stroke"),
    Param("stroke_mean_m", 0.200, "m", "(0, inf)", "mean stroke (stroke_low_m <= mean <= stroke_high_m)"),
    Param("stroke_std_m", 0.047, "m", "[0, inf)", "stroke standard deviation"),
    Param("stroke_low_m", 0.100, "m", "(0, inf)", "shortest stroke (truncation)"),
    Param("stroke_high_m", 0.300, "m", "(0, inf)", "longest stroke (truncation)"),
    Param("stroke_skew", 0.0, "-", "", "0 = truncated normal (seed 000); > 0 skewed towards short strokes"),
    Param("home_position_m", 0.0, "m", "", "axis position the strokes start from"),
    Param("dwell_s", 0.0, "s", "[0, inf)", "pause after each return stroke"),
    Param("measurement_interval_h", 0.5, "h", "(0, inf)", "interval of the straightness measurements"),
    Param("straightness_noise_m", 0.5e-6, "m", "[0, 0.01]", "1-sigma noise of a straightness measurement"),
    Param("wear_coefficient_factor", 1.0, "-", "(0, 1e6]", "truth K = factor x wear_coefficient"),
    Param("load_noise_n", 0.0, "N", "[0, inf)", "1-sigma noise of the load sensor"),
    Param("job_hours", 0.0, "h", "[0, inf)", "mean job length; 0 = one job with the values above"),
    Param("feed_speed_max_m_s", 0.0, "m/s", "[0, inf)", "per job log-uniform feed_speed_m_s .. this"),
    Param("feed_load_max_n", 0.0, "N", "[0, inf)", "per job uniform feed_load_n .. this"),
    Param("retract_load_max_n", 0.0, "N", "[0, inf)", "per job uniform retract_load_n .. min(this, feed load)"),
    Param("stroke_mean_max_m", 0.0, "m", "[0, inf)", "per job uniform stroke_mean_m .. this"),
    Param("stroke_skew_max", 0.0, "-", "[0, inf)", "per job stroke_skew + uniform(-this, this)"),
    # the effects' simulation parameters (the effect registry's: models/wear/effects/)
    *(Param(p.name, p.default, p.unit, p.range_text, p.meaning) for e in EFFECTS for p in e.simulation),
    Param("temperature_rate_hz", 0.0, "Hz", "[0, inf)", "rate of guide/temperature; 0 = no temperature topic"),
    Param("ambient_temperature_c", 20.0, "degC", "[-100, 200]", "mean ambient temperature"),
    Param("ambient_swing_k", 1.0, "K", "[0, 100]", "daily amplitude of the ambient temperature"),
    Param("friction_coefficient", 0.1, "-", "[0, 2]", "mu of the heating power mu W v"),
    Param("thermal_resistance_k_per_w", 0.15, "K/W", "(0, inf)", "guide temperature rise per heating power"),
    Param("thermal_time_constant_s", 1800.0, "s", "(0, inf)", "thermal time constant of the guide"),
    Param("temperature_noise_k", 0.05, "K", "[0, inf)", "1-sigma noise of the temperature sensor"),
    Param("motion_profile", "constant_speed", "", "", "constant_speed: each move at its speed from knot to knot; "
          "jerk_limited: double-S moves under max_acceleration_m_s2 and max_jerk_m_s3, stopping at every knot",
          choices=("constant_speed", "jerk_limited")),
    Param("max_acceleration_m_s2", 2.0, "m/s^2", "(0, 1000]", "acceleration limit of a jerk-limited move"),
    Param("max_jerk_m_s3", 40.0, "m/s^3", "(0, 1e6]", "jerk limit of a jerk-limited move"),
    Param("encoder_noise_m", 0.0, "m", "[0, 0.001]", "1-sigma noise of the joint_states position (encoder)"),
    Param("load_clock_offset_s", 0.0, "s", "[0, 1]", "guide/load stamps: offset of the sensor's clock after "
          "the half-period phase"),
    Param("load_clock_drift_ppm", 0.0, "ppm", "[-1000, 1000]", "guide/load stamps: the sensor's period is "
          "1 / load_rate_hz x (1 + this x 1e-6)"),
    Param("load_stamp_jitter_s", 0.0, "s", "[0, 0.01]", "guide/load stamps: 1-sigma jitter of each sample "
          "instant (stamps stay increasing)"),
)

#: ``simulate --motion realistic``: a machine-tool axis as a controller records it (jerk-limited moves,
#: joint_states at 250 Hz with 1 um encoder noise, a 100 Hz load sensor on its own drifting, jittery clock)
REALISTIC_MOTION = {"motion_profile": "jerk_limited", "joint_state_rate_hz": 250.0, "load_rate_hz": 100.0,
                    "encoder_noise_m": 1.0e-6, "load_clock_offset_s": 1.3e-3, "load_clock_drift_ppm": 50.0,
                    "load_stamp_jitter_s": 1.0e-4}


def _machine_simulation_cross_checks(p: dict[str, Any]) -> None:
    for name in ("duration_h", "joint_state_rate_hz", "load_rate_hz", "feed_speed_m_s",
                 "retract_speed_m_s", "measurement_interval_h"):
        if not p[name] > 0:
            raise InputError(f"simulation parameter {name} must be > 0, got {p[name]!r}")
    if not 0 < p["stroke_low_m"] <= p["stroke_mean_m"] <= p["stroke_high_m"]:
        raise InputError("simulation strokes need 0 < stroke_low_m <= stroke_mean_m <= stroke_high_m")


SIMULATION_SCHEMA = NodeSchema("guide_health_simulation", MACHINE_SIMULATION_PARAMS,
                               _machine_simulation_cross_checks)

SLEWING_DUTIES = ("crane", "yaw", "pitch")

#: duty of a mid-size crane on a 2 m slewing ring (131.32.2000 class); the moment range keeps the
#: busiest roller near the seed's 103 kN example at the heaviest lifts
SLEWING_SIMULATION_PARAMS = (
    Param("duration_h", 0.25, "h", "(0, inf)", "simulated time"),
    Param("load_rate_hz", 200.0, "Hz", "(0, inf)", "rate of slewing/load"),
    Param("dead_weight_n", 6.0e5, "N", "[0, inf)", "superstructure weight on the bearing"),
    Param("dead_moment_nm", 1.5e6, "N m", "[0, inf)", "counterweight imbalance when empty"),
    Param("payload_max_n", 3.0e5, "N", "[0, inf)", "payloads drawn uniformly in [0.2, 1] x this"),
    Param("boom_radius_min_m", 10.0, "m", "(0, inf)", "shortest boom radius of a lift"),
    Param("boom_radius_max_m", 30.0, "m", "(0, inf)", "longest boom radius of a lift (>= min)"),
    Param("cycle_s", 120.0, "s", "(0, inf)", "work cycle: hoist 20 % / slew 30 % / lower 20 % / return 30 %"),
    Param("sway_fraction", 0.08, "-", "[0, inf)", "dynamic moment amplitude / static moment while slewing"),
    Param("slew_radial_n", 3.0e4, "N", "[0, inf)", "inertial radial load peak during slew acceleration"),
    # oscillating duties (sim/slewing_duty.py): yaw (long dwell, occasional large rotations), pitch (constant
    # small oscillations); loads per motion: F_a = dead_weight_n (+-5 %), M_T lognormal about dead_moment_nm
    Param("duty", "crane", "", "", "crane (work cycles), yaw or pitch", choices=SLEWING_DUTIES),
    Param("moment_cv", 0.3, "-", "[0, 5]", "yaw/pitch: coefficient of variation of M_T between motions"),
    Param("yaw_dwell_min_s", 60.0, "s", "(0, inf)", "yaw: shortest dwell between two rotations"),
    Param("yaw_dwell_mean_s", 3600.0, "s", "(0, inf)", "yaw: mean dwell (min + exponential)"),
    Param("yaw_rotation_min_rad", 0.2, "rad", "(0, inf)", "yaw: smallest rotation of an event"),
    Param("yaw_rotation_max_rad", 3.14, "rad", "(0, inf)", "yaw: largest rotation (uniform, either sense)"),
    Param("slew_speed_rad_s", 0.01, "rad/s", "(0, inf)", "yaw: rotation speed"),
    Param("pitch_period_s", 8.0, "s", "(0, inf)", "pitch: period of one oscillation"),
    Param("pitch_amplitude_min_rad", 0.005, "rad", "(0, inf)", "pitch: smallest amplitude (half the swing)"),
    Param("pitch_amplitude_max_rad", 0.05, "rad", "(0, inf)", "pitch: largest amplitude (uniform)"),
    Param("axis_sample_step_rad", 0.05, "rad", "(0, inf)", "yaw/pitch: angle between two axis samples"),
    Param("clearance_measurements", 6, "-", "[0, 1000]", "yaw/pitch: tilting-clearance measurements, evenly"),
    Param("true_raceway_wear_coefficient_m2_n", 2.0e-13, "m^2/N", "(0, 1e-6]", "the simulated bearing's k"),
    Param("tilting_clearance_initial_m", 0.3e-3, "m", "(0, 0.01]", "c_0 of the simulated bearing"),
    Param("tilting_clearance_limit_m", 1.0e-3, "m", "(0, 0.01]", "replacement clearance (the truth's end)"),
    Param("tilting_clearance_noise_m", 20.0e-6, "m", "[0, 0.001]", "sd of a simulated tilting-clearance reading"),
)


def _slewing_simulation_cross_checks(p: dict[str, Any]) -> None:
    for name in ("duration_h", "load_rate_hz", "cycle_s", "boom_radius_min_m", "boom_radius_max_m"):
        if not float(p[name]) > 0:
            raise InputError(f"slewing simulation: {name} must be > 0, got {p[name]!r}")
    if p["duty"] not in SLEWING_DUTIES:
        raise InputError(f"slewing simulation: duty must be one of {SLEWING_DUTIES}, got {p['duty']!r}")
    for low, high in (("yaw_rotation_min_rad", "yaw_rotation_max_rad"),
                      ("pitch_amplitude_min_rad", "pitch_amplitude_max_rad"),
                      ("tilting_clearance_initial_m", "tilting_clearance_limit_m")):
        if not float(p[low]) < float(p[high]):
            raise InputError(f"slewing simulation: {low} must be < {high}")
    if p["boom_radius_max_m"] < p["boom_radius_min_m"]:
        raise InputError("slewing simulation: boom_radius_max_m < boom_radius_min_m")
    for name in ("dead_weight_n", "dead_moment_nm", "payload_max_n", "sway_fraction", "slew_radial_n"):
        if float(p[name]) < 0:
            raise InputError(f"slewing simulation: {name} must be >= 0, got {p[name]!r}")


SLEWING_SIMULATION_SCHEMA = NodeSchema("guide_health_slewing_simulation", SLEWING_SIMULATION_PARAMS,
                                       _slewing_simulation_cross_checks)


def slewing_simulation_params(overrides: dict | None = None) -> dict[str, Any]:
    """Slewing scenario: the defaults updated by ``overrides``, validated."""
    p = SLEWING_SIMULATION_SCHEMA.defaults()
    p.update(overrides or {})
    SLEWING_SIMULATION_SCHEMA.validate(p)
    return p
