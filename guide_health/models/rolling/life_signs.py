"""Failure signs of a rolling guide in a life test (seed 004 Sec. 2 and 4.1): the noise level [dB] against travel
(rises gradually, then drops near the end, at about 450 km in the seed's ball-guide test, when spalled balls
and raceway let the carriage loosen) and vibration in an abnormal band (fatigue pitting, the seed's criterion to
stop the test).

Pure numpy, no ROS, no I/O. Travel in m (km where the name says so), levels in dB.

* :class:`NoiseTrend`: baseline mean/sd of the level over the running-in span; a one-sided CUSUM for the rise,
  S_i = max(0, S_{i-1} + (L_i - mu0 - k)), rise when S_i > h (k = rise_allowance_db, h = rise_cusum_db);
  the drop after a rise when the EWMA level falls drop_db below its peak after the rise was detected.
* :class:`LifeTestSigns`: one object for live and offline use: the abnormal-band test
  (:class:`~guide_health.models.rolling.vibration.AbnormalBand`), the noise trend, the named defect tone and
  the status level: WARN on a sustained abnormal band or a noise rise, ERROR on the seed's end-of-test pattern
  (a sustained abnormal band and the noise drop after its rise). The failure travel is the travel of the first
  abnormal block of the run that met the persistence rule; its interval (previous block, that block] is the
  interval-censored life for the Weibull fit (seed 004 Sec. 3.2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from guide_health.models.levels import ERROR, OK, WARN, Level
from guide_health.models.rolling.vibration import (
    AbnormalBand,
    GuideKinematics,
    defect_frequencies,
    name_tone,
    welch_psd,
)


@dataclass
class NoiseTrend:
    """Rise (CUSUM) and drop-after-rise (EWMA below its peak) of the noise level against travel."""

    baseline_samples: int = 20
    rise_allowance_db: float = 1.0
    rise_cusum_db: float = 8.0
    drop_db: float = 3.0
    ewma_weight: float = 0.3
    sd_floor_db: float = 0.2
    samples: list = field(default_factory=list)
    mean_db: float = math.nan
    sd_db: float = math.nan
    cusum_db: float = 0.0
    ewma_db: float = math.nan
    peak_db: float = -math.inf
    rise_travel_m: float | None = None
    drop_travel_m: float | None = None

    def update(self, travel_m: float, level_db: float) -> None:
        if not (math.isfinite(level_db) and math.isfinite(travel_m)):
            raise ValueError(f"noise level and travel must be finite, got {level_db!r} dB at {travel_m!r} m")
        self.ewma_db = level_db if math.isnan(self.ewma_db) else (
            self.ewma_weight * level_db + (1.0 - self.ewma_weight) * self.ewma_db)
        if math.isnan(self.mean_db):
            self.samples.append(level_db)
            if len(self.samples) >= self.baseline_samples:
                self.mean_db = float(np.mean(self.samples))
                self.sd_db = max(float(np.std(self.samples, ddof=1)), self.sd_floor_db)
            return
        self.cusum_db = max(0.0, self.cusum_db + level_db - self.mean_db - self.rise_allowance_db)
        if self.rise_travel_m is None and self.cusum_db > self.rise_cusum_db:
            self.rise_travel_m = travel_m
        if self.rise_travel_m is not None:
            self.peak_db = max(self.peak_db, self.ewma_db)
            if self.drop_travel_m is None and self.peak_db - self.ewma_db > self.drop_db:
                self.drop_travel_m = travel_m

    @property
    def rise_db(self) -> float:
        """EWMA level above the running-in mean [dB] (nan while learning)."""
        return self.ewma_db - self.mean_db


@dataclass
class LifeTestSigns:
    """The failure signs of one guide over blocks at increasing travel (see the module docstring)."""

    sample_rate_hz: float
    kinematics: GuideKinematics
    carriage_speed_m_s: float
    bands: AbnormalBand = None          # type: ignore[assignment]
    noise: NoiseTrend = field(default_factory=NoiseTrend)
    blocks: int = 0
    rejected: int = 0
    last_travel_m: float = -math.inf
    abnormal_travels: list = field(default_factory=list)
    failure_travel_m: float | None = None
    failure_lower_m: float | None = None
    defect: str | None = None
    last: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.bands is None:
            self.bands = AbnormalBand(self.sample_rate_hz)
        self.defects_hz = defect_frequencies(self.kinematics, self.carriage_speed_m_s)

    def update_block(self, travel_m: float, block: np.ndarray) -> dict:
        """One accelerometer block at ``travel_m``; raises ValueError (state unchanged) on a bad block or
        travel that goes backwards."""
        if not (math.isfinite(travel_m) and travel_m >= self.last_travel_m):
            raise ValueError(f"block travel must be finite and not decrease, got {travel_m!r} m")
        r = self.bands.update(block)
        self.blocks += 1
        prev, self.last_travel_m = self.last_travel_m, travel_m
        if not r["learning"]:    # (previous travel, travel, abnormal) of the last persist_n tested blocks
            self.abnormal_travels = (self.abnormal_travels + [(prev, travel_m, r["abnormal"])])[-self.bands.persist_n:]
        if r["alarm"] and self.failure_travel_m is None:
            lower, first, _ = next(a for a in self.abnormal_travels if a[2])
            self.failure_travel_m = first
            self.failure_lower_m = max(lower, 0.0) if math.isfinite(lower) else 0.0
        if r["abnormal"]:
            f, psd = welch_psd(block, self.sample_rate_hz, segment=np.asarray(block).size)   # fine: df = fs / N
            self.defect = name_tone(f, psd, self.defects_hz) or self.defect
        self.last = r
        return r

    def update_level(self, travel_m: float, level_db: float) -> None:
        self.noise.update(travel_m, level_db)

    @property
    def alarm(self) -> bool:
        return bool(self.last.get("alarm")) or self.failure_travel_m is not None

    def level(self) -> tuple[Level, str]:
        """(level, message): ERROR on the seed's end-of-test pattern, WARN on a sustained abnormal band or a
        noise rise, OK otherwise."""
        b, n = self.bands, self.noise
        band_rule = (f"band z > z_threshold {b.threshold:.2f} in {b.persist_k} of {b.persist_n} blocks "
                     f"from {self.failure_travel_m / 1e3:.1f} km" if self.failure_travel_m is not None else "")
        if self.failure_travel_m is not None and n.drop_travel_m is not None:
            return ERROR, (f"end of test: abnormal band ({band_rule}) and noise drop > drop_db {n.drop_db:g} dB "
                           f"after its rise (carriage loosened)")
        if self.failure_travel_m is not None:
            return WARN, f"sustained abnormal vibration band: {band_rule}"
        if n.rise_travel_m is not None:
            return WARN, (f"noise rise from {n.rise_travel_m / 1e3:.1f} km: CUSUM above the running-in level > "
                          f"rise_cusum_db {n.rise_cusum_db:g} dB")
        return OK, "no failure sign"

    def summary(self) -> dict:
        lvl, msg = self.level()
        r = self.last
        return {"level": lvl.name, "message": msg, "blocks": self.blocks,
                "failure_travel_km": None if self.failure_travel_m is None else self.failure_travel_m / 1e3,
                "failure_interval_km": None if self.failure_travel_m is None
                else [self.failure_lower_m / 1e3, self.failure_travel_m / 1e3],
                "defect": self.defect, "defect_frequencies_hz": self.defects_hz,
                "z_max": float(r.get("z_max", 0.0)), "z_threshold": self.bands.threshold,
                "abnormal_band_hz": r.get("band"),
                "noise_level_db": self.noise.ewma_db, "noise_rise_db": self.noise.rise_db,
                "noise_rise_km": None if self.noise.rise_travel_m is None else self.noise.rise_travel_m / 1e3,
                "noise_drop_km": None if self.noise.drop_travel_m is None else self.noise.drop_travel_m / 1e3,
                "last_travel_km": self.last_travel_m / 1e3 if math.isfinite(self.last_travel_m) else 0.0}


class StampedLifeTest:
    """LifeTestSigns fed by header stamps, one object for the live node and the offline bag chain: the travel of a
    sample is ``carriage_speed_m_s`` x (stamp - start) (a constant-speed test bench, seed 004), start = the first
    stamp seen unless given. Blocks and sound levels are independent streams (their order between each other does
    not change the state); each stream must come in stamp order. A bad block or level raises ValueError and
    leaves the state unchanged (the caller counts it)."""

    def __init__(self, signs: LifeTestSigns, carriage_speed_m_s: float, start_ns: int | None = None) -> None:
        self.signs = signs
        self.speed_m_s = float(carriage_speed_m_s)
        self.start_ns = start_ns
        self.rejected_blocks = 0
        self.rejected_levels = 0
        self.last_block: dict = {}

    def travel_m(self, t_ns: int) -> float:
        if self.start_ns is None:
            self.start_ns = int(t_ns)
        return self.speed_m_s * (int(t_ns) - self.start_ns) / 1e9

    def on_block(self, t_ns: int, block: np.ndarray) -> dict | None:
        """One accelerometer block; None when rejected (counted)."""
        try:
            self.last_block = self.signs.update_block(self.travel_m(t_ns), block)
        except ValueError:
            self.rejected_blocks += 1
            return None
        return self.last_block

    def on_level(self, t_ns: int, level_db: float) -> bool:
        """One sound level [dB]; False when rejected (counted)."""
        try:
            self.signs.update_level(self.travel_m(t_ns), level_db)
        except ValueError:
            self.rejected_levels += 1
            return False
        return True
