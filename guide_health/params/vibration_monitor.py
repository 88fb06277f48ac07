"""Parameters of the vibration monitor (node ``vibration_monitor`` and ``guide-health life test BAG``) and of the
simulated accelerated life test (section ``guide_health_life_test_simulation``, read by ``guide-health simulate
--kind life-test`` together with the ``vibration_monitor`` section, which holds the bench's geometry and speed).
"""
from __future__ import annotations

from typing import Any

from guide_health.errors import InputError
from guide_health.params.schema import NodeSchema, Param

VIBRATION_MONITOR_PARAMS = (
    Param("machine_id", "machine", "", "", "machine name: hardware_id of the diagnostics"),
    Param("joint_name", "x", "", "", "the guide's joint: status '<joint> vibration'"),
    Param("sample_rate_hz", 25600.0, "Hz", "[1000, 1e6]", "accelerometer sample rate (IEPE, 10-50 kHz)"),
    Param("carriage_speed_m_s", 1.0, "m/s", "(0, 20]", "carriage speed of the constant-speed test"),
    Param("ball_diameter_m", 6.35e-3, "m", "(0, 0.1]", "ball diameter D"),
    Param("ball_pitch_m", 6.6e-3, "m", "(0, 0.2]", "centre distance of neighbouring balls p (>= D)"),
    Param("loop_length_m", 0.25, "m", "(0, 10]", "one ball's recirculation circuit"),
    Param("contact_angle_deg", 45.0, "deg", "[0, 80]", "ball-raceway contact angle (rolling radius D/2 cos)"),
    Param("n_bands", 32, "-", "[4, 1024]", "equal-width bands 0 .. fs/2 of the abnormal-band test"),
    Param("welch_segment", 1024, "samples", "[64, 65536]", "Welch segment length (Hann, 50 % overlap)"),
    Param("baseline_blocks", 20, "-", "[3, 100000]", "running-in blocks that learn the machine's bands"),
    Param("false_alarm_per_block", 1e-3, "-", "(0, 0.5)", "per-block false-alarm probability (all bands)",
          dynamic=True),
    Param("persist_k", 3, "-", "[1, 100]", "abnormal blocks needed among the last persist_n", dynamic=True),
    Param("persist_n", 5, "-", "[1, 100]", "persistence window [blocks]", dynamic=True),
    Param("noise_baseline_samples", 20, "-", "[3, 100000]", "running-in sound levels of the noise baseline"),
    Param("noise_rise_allowance_db", 4.0, "dB", "[0, 60]", "CUSUM allowance k above the running-in level",
          dynamic=True),
    Param("noise_rise_cusum_db", 6.0, "dB", "(0, 1000]", "CUSUM decision interval h of the noise rise",
          dynamic=True),
    Param("noise_drop_db", 3.0, "dB", "(0, 60]", "smallest level drop that counts as loosening (half the sound "
          "power)", dynamic=True),
    Param("noise_change_allowance_sd", 1.0, "sd", "[0, 100]", "two-sided CUSUM allowance k of the level shift "
          "[noise sd]", dynamic=True),
    Param("noise_change_decision_sd", 10.0, "sd", "(0, 1e4]", "two-sided CUSUM decision interval h of the level "
          "shift [noise sd]", dynamic=True),
    Param("envelope_max_s", 2.0, "s", "[0.01, 60]", "longest contiguous signal measured for the defect rate "
          "(resolution 1 / T)"),
    Param("pause_gap_s", 10800.0, "s", "(0, 1e9]", "no block and no level for longer: a bench stop (no travel); "
          "without a position topic"),
    Param("travel_offset_km", 0.0, "km", "[0, 1e6]", "travel of the specimen before the recording"),
    Param("test_start_time_s", 0.0, "s", "[0, 4e9]", "stamp of travel 0 (UNIX s); 0 = the first stamp"),
    Param("load_fraction", 0.3, "-", "(0, 10]", "test load F / C (seed 004: 0.3 for its ball guide)"),
    Param("rating_distance_km", 50.0, "km", "(0, inf)", "reference travel of C (seed 004: 50 km)"),
    Param("status_period_s", 1.0, "s", "(0, 3600]", "status publishing period", dynamic=True),
    Param("input_timeout_s", 10.0, "s", "(0, 86400]",
          "STALE when guide/acceleration and guide/sound_pressure are silent longer (arrival time)"),
)


def _vibration_cross_checks(values: dict[str, Any]) -> None:
    if values.get("ball_pitch_m", 1.0) < values.get("ball_diameter_m", 0.0):
        raise InputError("vibration_monitor: ball_pitch_m must be >= ball_diameter_m")
    if values.get("persist_k", 1) > values.get("persist_n", 1):
        raise InputError("vibration_monitor: persist_k must be <= persist_n")


VIBRATION_MONITOR_SCHEMA = NodeSchema("vibration_monitor", VIBRATION_MONITOR_PARAMS, _vibration_cross_checks)

LIFE_TEST_SIMULATION_PARAMS = (
    Param("block_samples", 4096, "samples", "[256, 1048576]", "samples per accelerometer block"),
    Param("block_every_m", 2000.0, "m", "(0, inf)", "travel between simulated blocks (compression)"),
    Param("failure_km", 0.0, "km", "[0, inf)", "travel to spall onset; 0 = drawn from the Weibull life"),
    Param("c_ratio_true", 0.624, "-", "(0, 10]", "true C_test / C of the specimens (seed 004: 0.624)"),
    Param("weibull_shape", 10.0 / 9.0, "-", "(0, 20]", "Weibull shape of the lives (ball bearings: 10/9)"),
    Param("max_travel_km", 600.0, "km", "(0, inf)", "end of a clean run; cap of a failing one"),
    Param("nominal_life_km", 450.0, "km", "(0, inf)", "travel scale of the wear trends"),
    Param("loosen_after_fraction", 0.02, "-", "[0, 1]", "loosening at spall onset x (1 + this)"),
    Param("run_on_fraction", 0.03, "-", "[0, 1]", "recording goes on to loosening x (1 + this)"),
    Param("levels_per_block", 4, "-", "[1, 1000]", "sound levels recorded per block spacing"),
    Param("machine_band_low_hz", 5500.0, "Hz", "(0, inf)", "machine band low edge (seed 004: 5.5 kHz)"),
    Param("machine_band_high_hz", 6000.0, "Hz", "(0, inf)", "machine band high edge (seed 004: 6 kHz)"),
    Param("machine_band_rms", 2.0, "m/s^2", "[0, inf)", "rms of the machine band"),
    Param("broadband_rms", 0.5, "m/s^2", "[0, inf)", "rms of the broadband noise when new"),
    Param("wear_gain", 1.0, "-", "[0, inf)", "broadband rms growth per nominal life"),
    Param("defect_amplitude", 0.3, "m/s^2", "[0, inf)", "defect tone amplitude at spall onset"),
    Param("defect_growth", 20.0, "-", "[0, inf)", "defect amplitude growth per spall-onset travel"),
    Param("noise_level_db", 70.0, "dB", "[0, 200]", "sound level when new"),
    Param("noise_wear_db", 3.0, "dB", "[0, 60]", "sound level rise with wear per nominal life"),
    Param("noise_spall_db", 8.0, "dB", "[0, 60]", "sound level rise from spall onset to loosening"),
    Param("loosening_drop_db", 6.0, "dB", "[0, 60]", "sound level drop when the carriage loosens"),
    Param("noise_sd_db", 0.3, "dB", "[0, 10]", "scatter of the sound level"),
    Param("start_time_s", 1.7e9, "s", "[0, 4e9]", "bench clock at the test start (travel 0)"),
)


def _sim_cross_checks(values: dict[str, Any]) -> None:
    if values.get("machine_band_low_hz", 0.0) >= values.get("machine_band_high_hz", 1.0):
        raise InputError("guide_health_life_test_simulation: machine_band_low_hz must be < machine_band_high_hz")


LIFE_TEST_SIMULATION_SCHEMA = NodeSchema("guide_health_life_test_simulation", LIFE_TEST_SIMULATION_PARAMS,
                                         _sim_cross_checks)
