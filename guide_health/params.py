"""Parameter sets shared by the live nodes and the offline CLI.

One ROS 2 parameters YAML (``<node>: ros__parameters: {...}``, ``/**`` wildcard allowed) drives both the
node and ``guide-health ... --params FILE``, so live and offline results come from the same numbers.
The defaults below are the single source: nodes declare exactly these parameters.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from guide_health.errors import InputError

WEAR_MONITOR_DEFAULTS: dict[str, Any] = {
    "machine_id": "machine",
    "joint": "x",
    "guide_type": "sliding",            # sliding | rolling
    # sliding guide, seed 000
    "contact_width_m": 0.040,           # b
    "hardness_pa": 199.0e6,             # H of the softer (worn) surface, HT200
    "wear_coefficient": 4.42e-6,        # K (dimensionless Archard coefficient)
    "stroke_min_m": 0.0,                # l_min, 0 = estimate from observed strokes
    "stroke_max_m": 0.0,                # l_max, 0 = estimate from observed strokes
    "stroke_detect_min_m": 0.005,       # reversals closer than this are jitter, not strokes
    "straightness_initial_m": 15.0e-6,  # A0
    "straightness_limit_m": 100.0e-6,   # A_max (absolute straightness)
    "straightness_model": "eq7",        # eq7 | profile
    "slider_length_m": 0.100,           # profile model: length of the slider contact
    "rail_start_m": -0.100,             # profile model: rail coordinate of the first bin
    "rail_length_m": 0.500,             # profile model: rail length covered by bins
    "profile_bin_m": 0.001,             # profile model: bin width
    "duty_window_s": 3600.0,            # window for the current duty W v (remaining life)
    "straightness_noise_m": 0.5e-6,     # 1-sigma noise of a straightness measurement (prior)
    "wear_coefficient_prior_rel_sd": 0.5,  # prior sd of K relative to the configured K
    "life_warn_h": 500.0,               # WARN when the remaining life drops below this
    "life_error_h": 100.0,              # ERROR below this
    "straightness_warn_fraction": 0.8,  # WARN when straightness > fraction * limit, ERROR above limit
    "diagnostics_period_s": 1.0,
    "input_timeout_s": 5.0,             # STALE when joint_states/load silent longer (data arrival)
    "checkpoint_period_s": 2.0,         # SQLite commit period
    "input_align_window_s": 0.5,        # joint samples wait <= this for the load stamped before them
    "executor": "events",               # events (rclpy EventsExecutor, raw CDR) | single_threaded
    "state_file": "",                   # '' = no persistence
    # rolling guide, seeds 001/004
    "ball_radius_m": 3.9685e-3,
    "groove_conformity": 0.52,
    "contact_angle_deg": 50.0,
    "balls_per_row": 10,
    "rows": 4,
    "preload_n": 385.0,
    "dynamic_load_rating_n": 0.0,
    "rolling_element": "ball",
    "oil_viscosity_pa_s": 0.060,
    "pressure_viscosity_pa_inv": 2.0e-8,
    "roughness_rms_m": 0.2e-6,
    "life_factors": [1.0, 1.0, 1.0, 1.0],   # fh, ft, fc, fw
    "rating_distance_km": 50.0,
    "youngs_modulus_pa": 206.0e9,
    "poisson": 0.3,
    "carriages": 1,                     # carriages sharing the guide load (fatigue per carriage)
    "boundary_window_m": 100.0,         # travel over which the boundary-lubrication share is judged
    "boundary_share_warn": 0.5,
    "life_used_warn": 0.8,
    "life_used_error": 1.0,
}

SIMULATION_DEFAULTS: dict[str, Any] = {
    "duration_h": 20.0,
    "joint_state_rate_hz": 50.0,
    "load_rate_hz": 10.0,
    "feed_speed_m_s": 0.05,
    "retract_speed_m_s": 0.05,
    "feed_load_n": 6000.0,
    "retract_load_n": 6000.0,
    "stroke_mean_m": 0.200,
    "stroke_std_m": 0.047,
    "stroke_low_m": 0.100,
    "stroke_high_m": 0.300,
    "stroke_skew": 0.0,                 # 0 = truncated normal (seed 000); >0 skewed towards short strokes
    "home_position_m": 0.0,
    "dwell_s": 0.0,
    "measurement_interval_h": 0.5,
    "straightness_noise_m": 0.5e-6,
    "wear_coefficient_factor": 1.0,     # truth K = factor * wear_coefficient
    "load_noise_n": 0.0,
    # jobs (0 = one job with the values above); per job the value is drawn up to its *_max
    "job_hours": 0.0,
    "feed_speed_max_m_s": 0.0,          # log-uniform feed_speed_m_s .. max
    "feed_load_max_n": 0.0,             # uniform feed_load_n .. max
    "retract_load_max_n": 0.0,          # uniform retract_load_n .. min(max, the job's feed load)
    "stroke_mean_max_m": 0.0,           # uniform stroke_mean_m .. max
    "stroke_skew_max": 0.0,             # stroke_skew + uniform(-max, max)
    # effects of `simulate --effect` (models/wear/effects.py)
    "running_in_distance_m": 100.0,     # s0 of running_in
    "load_reference_n": 1000.0,         # W_ref of load_exponent
    # guide temperature (topic guide/temperature when temperature_rate_hz > 0)
    "temperature_rate_hz": 0.0,
    "ambient_temperature_c": 20.0,
    "ambient_swing_k": 1.0,             # daily amplitude
    "friction_coefficient": 0.1,        # heating power mu W v
    "thermal_resistance_k_per_w": 0.15,
    "thermal_time_constant_s": 1800.0,
    "temperature_noise_k": 0.05,
}


def _load_yaml(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"parameters file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise InputError(f"parameters file {path} is not valid YAML: {exc}".splitlines()[0]) from exc
    if not isinstance(data, dict):
        raise InputError(f"parameters file {path} holds no '<node>: ros__parameters:' mapping")
    return data


def _coerce(name: str, value: Any, default: Any) -> Any:
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise InputError(f"parameter {name} must be true/false, got {value!r}")
        return value
    if isinstance(default, float):
        if isinstance(value, str):
            # YAML 1.1 (PyYAML) reads 199.0e6 as a string; ROS's rcl parser reads it as a double
            try:
                value = float(value)
            except ValueError:
                raise InputError(f"parameter {name} must be a number, got {value!r}") from None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"parameter {name} must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise InputError(f"parameter {name} must be finite, got {value!r}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"parameter {name} must be an integer, got {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise InputError(f"parameter {name} must be a string, got {value!r}")
        return value
    if isinstance(default, list):
        if not isinstance(value, list) or len(value) != len(default):
            raise InputError(f"parameter {name} must be a list of {len(default)} numbers, got {value!r}")
        return [_coerce(f"{name}[{i}]", v, d) for i, (v, d) in enumerate(zip(value, default))]
    return value


def load_node_params(path: str | Path | None, node_name: str, defaults: dict[str, Any],
                     strict: bool = False) -> dict[str, Any]:
    """Parameters of ``node_name`` from a ROS 2 parameters YAML, merged over ``defaults``.

    ``/**`` entries apply first, then ``node_name`` (with or without a leading slash/namespace).
    Unknown names are kept (a file may carry other tools' parameters) unless ``strict``.
    """
    params = dict(defaults)
    if path is None:
        return params
    data = _load_yaml(path)
    sections = []
    for key, section in data.items():
        base = str(key).rstrip("/").split("/")[-1]
        if key == "/**" or base == node_name:
            if not isinstance(section, dict) or not isinstance(section.get("ros__parameters", {}), dict):
                raise InputError(f"{path}: section '{key}' has no 'ros__parameters' mapping")
            sections.append((0 if key == "/**" else 1, section.get("ros__parameters", {})))
    if not sections and strict:
        raise InputError(f"{path}: no section for node '{node_name}'")
    for _, section in sorted(sections, key=lambda s: s[0]):
        for name, value in section.items():
            if name in defaults:
                params[name] = _coerce(name, value, defaults[name])
            elif strict:
                raise InputError(f"{path}: unknown parameter '{name}' for {node_name}")
            else:
                params[name] = value
    return params


def wear_monitor_params(path: str | Path | None) -> dict[str, Any]:
    """wear_monitor parameters, validated (positive sizes, known model names)."""
    p = load_node_params(path, "wear_monitor", WEAR_MONITOR_DEFAULTS)
    validate_wear_params(p)
    return p


def validate_wear_params(p: dict[str, Any]) -> None:
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
    if p.get("executor", "events") not in ("events", "single_threaded"):
        raise InputError(f"executor must be 'events' or 'single_threaded', got {p['executor']!r}")
    if p["straightness_model"] not in ("eq7", "profile"):
        raise InputError(f"straightness_model must be 'eq7' or 'profile', got {p['straightness_model']!r}")


def simulation_params(path: str | Path | None) -> dict[str, Any]:
    """Scenario of ``guide-health simulate`` (section ``guide_health_simulation``)."""
    p = load_node_params(path, "guide_health_simulation", SIMULATION_DEFAULTS)
    for name in ("duration_h", "joint_state_rate_hz", "load_rate_hz", "feed_speed_m_s",
                 "retract_speed_m_s", "measurement_interval_h"):
        if not p[name] > 0:
            raise InputError(f"simulation parameter {name} must be > 0, got {p[name]!r}")
    if not 0 < p["stroke_low_m"] <= p["stroke_mean_m"] <= p["stroke_high_m"]:
        raise InputError("simulation strokes need 0 < stroke_low_m <= stroke_mean_m <= stroke_high_m")
    return p


def declare_parameters(node, defaults: dict[str, Any]) -> dict[str, Any]:
    """Declare ``defaults`` on an rclpy node (dynamic typing, so ``6000`` may set a float parameter) and
    return the values coerced like the offline loader does (same numbers live and offline)."""
    from rcl_interfaces.msg import ParameterDescriptor

    values = {}
    for name, default in defaults.items():
        node.declare_parameter(name, default, ParameterDescriptor(dynamic_typing=True))
        value = node.get_parameter(name).value
        if isinstance(default, list) and isinstance(value, (tuple, list)) or (
                isinstance(default, list) and hasattr(value, "tolist")):
            value = list(value)
        values[name] = _coerce(name, value, default)
    return values
