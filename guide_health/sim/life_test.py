"""Accelerated life test bench of a ball guide (seed 004 Sec. 3-4): constant load F = fraction x C, constant stroke
and speed, travel to failure drawn from the rating life's Weibull distribution; what is recorded: the sound level
[dB] and accelerometer blocks at 25.6 kHz.

Travel is compressed: a block (block_samples at sample_rate_hz) is simulated every block_every_m metres (the
bench runs continuously; the bag holds snapshots), stamped at the bench time t = travel / speed from the start of
the test (travel 0 at the first block).

Signal model of one block at travel s (spall onset s_f, carriage loosening s_l = s_f (1 + loosen_after_fraction)):
* the machine band: narrow-band noise in [machine_band_low_hz, machine_band_high_hz] (seed 004 Fig. 6: 5.5-6 kHz);
* broadband noise, rms sigma0 (1 + wear_gain (1 - exp(-s / L_nominal))) (wear, saturating);
* from s_f: a defect tone at the raceway defect frequency f_race (vibration.defect_frequencies) with harmonics
  k = 1..4 (amplitude a / k) and sidebands at +- f_rec (0.3 a / k), a = a0 (1 + defect_growth (s - s_f) / s_f);
* the sound level: L0 + noise_wear_db (1 - exp(-s / L_nominal)) + noise_spall_db sqrt((s - s_f) / (s_l - s_f)) from s_f,
  minus loosening_drop_db after s_l (seed 004 Sec. 4.1: the noise rises, then drops when the carriage loosens),
  plus normal scatter noise_sd_db.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal

from guide_health.models.rolling import rating_life as lm
from guide_health.models.rolling.vibration import GuideKinematics, defect_frequencies
from guide_health.params.typed import typed_params
from guide_health.params.vibration_monitor import LIFE_TEST_SIMULATION_SCHEMA, VIBRATION_MONITOR_SCHEMA

WEIBULL_SHAPE_BALL = 10.0 / 9.0     # Lundberg-Palmgren dispersion exponent e of ball bearings


@dataclass
class LifeTestRecord:
    """A simulated life test: block travels [m] and stamps [ns], blocks (rows) [m/s^2], sound levels [dB]."""

    travel_m: np.ndarray
    t_ns: np.ndarray
    blocks: np.ndarray
    level_t_ns: np.ndarray
    level_db: np.ndarray
    sample_rate_hz: float
    metadata: dict


def failure_travel_km(sim: Any, bench: Any, rng: np.random.Generator) -> float:
    """Travel to spall onset [km]: failure_km when > 0, else a draw from the Weibull distribution whose
    L10 is the rating life at load_fraction of the true C (c_ratio_true x catalogue C, seed 004 Eq. 4-5)."""
    if sim.failure_km > 0:
        return float(sim.failure_km)
    l10 = lm.rating_life_km(sim.c_ratio_true, bench.load_fraction, lm.BALL, bench.rating_distance_km)
    beta = sim.weibull_shape
    eta = l10 / (-math.log(lm.RATING_RELIABILITY)) ** (1.0 / beta)
    return float(eta * rng.weibull(beta))


def _bandpass(fs: float, low: float, high: float):
    return signal.butter(4, [low, high], btype="bandpass", fs=fs, output="sos")


def _defect_block(t: np.ndarray, f_race: float, f_rec: float, amp: float, phase: np.ndarray) -> np.ndarray:
    x = np.zeros_like(t)
    for k in range(1, 5):
        w = 2.0 * np.pi * k * f_race
        x += amp / k * np.sin(w * t + phase[k])
        x += 0.3 * amp / k * (np.sin((w + 2 * np.pi * f_rec) * t) + np.sin((w - 2 * np.pi * f_rec) * t))
    return x


def simulate_life_test(p: dict, seed: int = 0, spall: bool = True) -> LifeTestRecord:
    """One life test from the parameters ``p``: the guide_health_life_test_simulation section merged with the
    bench's vibration_monitor section (params/vibration_monitor.py), taken here as the two typed objects.

    ``spall=False`` simulates a clean run (no spall) over max_travel_km."""
    sim = typed_params(LIFE_TEST_SIMULATION_SCHEMA.section, p, validate=False)
    bench = typed_params(VIBRATION_MONITOR_SCHEMA.section, p, validate=False)
    rng = np.random.default_rng(seed)
    fs, n = float(bench.sample_rate_hz), int(sim.block_samples)
    kin = GuideKinematics(bench.ball_diameter_m, bench.ball_pitch_m, bench.loop_length_m,
                          math.radians(bench.contact_angle_deg))
    freqs = defect_frequencies(kin, bench.carriage_speed_m_s)
    fail_km = failure_travel_km(sim, bench, rng) if spall else math.inf
    loose_km = fail_km * (1.0 + sim.loosen_after_fraction)
    end_km = min(loose_km * (1.0 + sim.run_on_fraction), sim.max_travel_km) if spall else sim.max_travel_km
    travel = np.arange(0.0, end_km * 1e3 + 1e-9, sim.block_every_m)
    nominal_m = sim.nominal_life_km * 1e3
    sos = _bandpass(fs, sim.machine_band_low_hz, sim.machine_band_high_hz)
    t = np.arange(n) / fs
    blocks = np.empty((travel.size, n), dtype=np.float32)
    s_f, s_l = fail_km * 1e3, loose_km * 1e3
    for i, s in enumerate(travel):
        machine = signal.sosfilt(sos, rng.standard_normal(n + 512))[512:]
        machine *= sim.machine_band_rms / max(float(np.std(machine)), 1e-12)
        broad = sim.broadband_rms * (1.0 - sim.wear_gain * math.expm1(-s / nominal_m)) * rng.standard_normal(n)
        blocks[i] = machine + broad
        if s >= s_f:
            amp = sim.defect_amplitude * (1.0 + sim.defect_growth * (s - s_f) / s_f)
            blocks[i] += _defect_block(t + s / bench.carriage_speed_m_s, freqs["raceway_hz"],
                                       freqs["recirculation_hz"], amp, rng.uniform(0, 2 * np.pi, 5))
    level_travel = np.arange(travel.size * int(sim.levels_per_block)) * (sim.block_every_m / sim.levels_per_block)
    level = sound_level_db(sim, level_travel, s_f, s_l) + sim.noise_sd_db * rng.standard_normal(level_travel.size)
    t_ns = (sim.start_time_s + travel / bench.carriage_speed_m_s) * 1e9
    level_t_ns = (sim.start_time_s + level_travel / bench.carriage_speed_m_s) * 1e9
    meta = {"kind": "life_test", "seed": seed, "spall": bool(spall),
            "truth": {"spall_onset_km": fail_km if spall else None,
                      "loosening_km": loose_km if spall else None},
            "defect_frequencies_hz": freqs, "params": dict(p)}
    return LifeTestRecord(travel, t_ns.astype(np.int64), blocks, level_t_ns.astype(np.int64), level, fs, meta)


def sound_level_db(sim: Any, travel_m: np.ndarray, spall_m: float, loosen_m: float) -> np.ndarray:
    """Noise-free sound level [dB] against travel: wear rise, spall rise, drop at loosening (module docstring)."""
    s = np.asarray(travel_m, dtype=float)
    lvl = sim.noise_level_db + sim.noise_wear_db * -np.expm1(-s / (sim.nominal_life_km * 1e3))
    if math.isfinite(spall_m):
        frac = np.clip((s - spall_m) / max(loosen_m - spall_m, 1e-9), 0.0, 1.0)
        lvl = lvl + sim.noise_spall_db * np.sqrt(frac) - sim.loosening_drop_db * (s >= loosen_m)
    return lvl
