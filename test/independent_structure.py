"""An independent writer of structure the effect library does not hold, for the unexplained-structure flag's
power table (bench/flag_power.py) and the acceptance slice (test_flag_power.py). Imports nothing from
guide_health.analysis.discrepancy or guide_health.models.wear: the clean straightness is
test/reference_wear.py's sample-by-sample integration of the run's own motion and load (Eq. 7/10, no hidden
effect), the noise is drawn here, and each structure is added to it in closed form:

- ``ramp``: a gauge zero creeping linearly in clock time, a t / T (T the record's length);
- ``periodic``: a cycle in clock time, a sin(2 pi t / 8 h) (e.g. the shop's temperature or humidity);
- ``position``: wear that depends on the position along the rail, the work done weighted by
  sin(2 pi x / 0.15 m), its cumulative sum scaled to the amplitude a (a foundation of varying stiffness);
- ``step``: a jump of a at 40 % of the record (a gauge knocked, a re-clamped rail).

``amplitude`` a [m] is each structure's largest deviation from the clean straightness.
"""
from __future__ import annotations

import math

import numpy as np
import reference_wear as ref

SHAPES = ("ramp", "periodic", "position", "step")
PERIOD_S = 8.0 * 3600.0
POSITION_WAVELENGTH_M = 0.15
STEP_AT = 0.4


def clean_straightness_m(run, params: dict, stroke_sum_m: float) -> np.ndarray:
    """Noise-free straightness [m] at the run's measurement stamps, plain Archard wear (reference_wear.py)."""
    return ref.reference_straightness_m(
        run, ref.Hidden(), wear_coefficient=params["wear_coefficient"], hardness_pa=params["hardness_pa"],
        contact_width_m=params["contact_width_m"], slider_length_m=params["slider_length_m"],
        straightness_initial_m=params["straightness_initial_m"], stroke_sum_m=stroke_sum_m)


def structure_m(shape: str, amplitude_m: float, run) -> np.ndarray:
    """The structure [m] at the run's measurement stamps (module text)."""
    t_ns = np.asarray(run.joint_t_ns, dtype=np.int64)
    at = (np.asarray(run.straightness_t_ns, dtype=np.int64) - t_ns[0]) * 1e-9
    span = max((t_ns[-1] - t_ns[0]) * 1e-9, 1.0)
    if shape == "ramp":
        return amplitude_m * at / span
    if shape == "periodic":
        return amplitude_m * np.sin(2.0 * math.pi * at / PERIOD_S)
    if shape == "step":
        return np.where(at >= STEP_AT * span, amplitude_m, 0.0)
    if shape == "position":
        x = np.asarray(run.joint_position_m, dtype=float)
        held = np.searchsorted(run.load_t_ns, t_ns[1:], side="right") - 1
        load = np.where(held >= 0, np.asarray(run.load_n, dtype=float)[np.clip(held, 0, None)], 0.0)
        work = load * np.abs(np.diff(x)) * np.sin(2.0 * math.pi * 0.5 * (x[1:] + x[:-1]) / POSITION_WAVELENGTH_M)
        g = np.concatenate(([0.0], np.cumsum(work)))
        g_at = np.interp(at, (t_ns - t_ns[0]) * 1e-9, g)
        peak = float(np.max(np.abs(g_at)))
        return amplitude_m * g_at / peak if peak > 0 else np.zeros_like(at)
    raise ValueError(f"unknown shape {shape!r} (shapes: {', '.join(SHAPES)})")


def measured_m(run, params: dict, stroke_sum_m: float, shape: str, amplitude_m: float, noise_m: float,
               seed: int) -> np.ndarray:
    """Clean straightness + structure + Gaussian noise of sd ``noise_m`` (its own generator, ``seed``)."""
    y = clean_straightness_m(run, params, stroke_sum_m)
    if shape:
        y = y + structure_m(shape, amplitude_m, run)
    return y + np.random.default_rng(10_000 + seed).normal(0.0, noise_m, y.size)
