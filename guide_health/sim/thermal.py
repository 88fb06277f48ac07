"""Guide temperature of a simulated machine run: ambient with a daily swing plus frictional heating."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from guide_health.sim.motion import MachineKnots

#: temperature record rate [Hz] when a thermal drift is simulated but the scenario records none
THERMAL_DRIFT_RECORD_RATE_HZ = 0.1


def guide_temperature_c(knots: MachineKnots, sim: dict[str, Any], grid_s: np.ndarray,
                        rng: np.random.Generator) -> np.ndarray:
    """Guide temperature [degC] on the time grid: ambient (daily swing) plus frictional heating,
    a first-order lag of the friction power mu W v through a thermal resistance (exact per grid step
    for the step's mean power)."""
    ds = np.abs(np.diff(knots.x_m))
    friction_work = np.concatenate(([0.0], np.cumsum(sim["friction_coefficient"] * knots.load_n[1:] * ds)))
    f = np.interp(grid_s, knots.t_s, friction_work)
    dt = np.diff(grid_s)
    power_w = np.diff(f) / dt
    decay = np.exp(-dt / sim["thermal_time_constant_s"])
    rise = np.empty(grid_s.size)
    rise[0] = 0.0
    for i in range(dt.size):          # ~7000 steps for 20 h
        rise[i + 1] = rise[i] * decay[i] + sim["thermal_resistance_k_per_w"] * power_w[i] * (1.0 - decay[i])
    phase = rng.uniform(0.0, 2.0 * math.pi)
    ambient = sim["ambient_temperature_c"] + sim["ambient_swing_k"] * np.sin(2.0 * math.pi * grid_s / 86400.0 + phase)
    return ambient + rise


def temperature_records(knots: MachineKnots, sim: dict[str, Any], needs_record: bool, measurement_t_s: np.ndarray,
                        rng: np.random.Generator) -> tuple[np.ndarray | None, np.ndarray, np.ndarray | None]:
    """Recorded guide temperature (when ``temperature_rate_hz`` > 0 or ``needs_record``: a hidden effect needs a
    temperature record, as the gauge's thermal drift does): record times [s] (None: no record), recorded
    temperature [degC] with sensor noise, and the noise-free temperature at the straightness measurement times
    ``measurement_t_s`` (None without a record)."""
    duration = knots.t_s[-1]
    rate = sim["temperature_rate_hz"]
    if needs_record and not rate > 0:
        rate = THERMAL_DRIFT_RECORD_RATE_HZ
    if not rate > 0:
        return None, np.zeros(0), None
    record_t_s = np.arange(0.25 / rate, duration, 1.0 / rate)
    grid = np.union1d(np.arange(0.0, duration, 10.0), np.concatenate((measurement_t_s, [duration])))
    grid_c = guide_temperature_c(knots, sim, grid, rng)
    recorded_c = np.interp(record_t_s, grid, grid_c) + rng.normal(0.0, sim["temperature_noise_k"], record_t_s.size)
    return record_t_s, recorded_c, np.interp(measurement_t_s, grid, grid_c)
