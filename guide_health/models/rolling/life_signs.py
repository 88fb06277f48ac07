"""Failure signs of a rolling guide in a life test (seed 004 Sec. 2 and 4.1): the noise level [dB] against travel
(rises gradually, then drops near the end, at about 450 km in the seed's ball-guide test, when spalled balls
and raceway let the carriage loosen) and vibration in an abnormal band (fatigue pitting, the seed's criterion to
stop the test).

Pure numpy, no ROS, no I/O. Travel in m (km where the name says so), levels in dB.

* :class:`NoiseTrend`: baseline mean/sd of the level over the running-in span; a one-sided CUSUM for the rise,
  S_i = max(0, S_{i-1} + (L_i - mu0 - k)), rise when S_i > h (k = rise_allowance_db, h = rise_cusum_db);
  level shifts both ways relative to the level's own recent history (:class:`LevelShift`): a drop needs no rise
  before it.
* :class:`LifeTestSigns`: one object for live and offline use: the abnormal-band test
  (:class:`~guide_health.models.rolling.vibration.AbnormalBand`), the noise trend, the named defect tone and
  the status level: WARN on a sustained abnormal band or a noise rise, ERROR on the seed's end-of-test pattern
  (a sustained abnormal band and a level drop at or after the spall signature). The failure travel is the
  travel of the first abnormal block of the run that met the persistence rule; its interval (previous block,
  that block] is the interval-censored life for the Weibull fit (seed 004 Sec. 3.2).
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from guide_health.models.levels import ERROR, OK, WARN, Level
from guide_health.models.rolling.envelope import MeasuredDefect, measure_defect
from guide_health.models.rolling.travel import TravelClock
from guide_health.models.rolling.vibration import AbnormalBand, GuideKinematics, defect_frequencies

ROBUST_SD_OF_MAD = 1.4826      # sd = 1.4826 MAD for normal data


def robust_noise_sd(levels) -> float:
    """The level's noise sd from its first differences, robust to a step and a trend:
    sd = 1.4826 MAD(diff) / sqrt(2) (a difference of two independent samples has variance 2 sd^2)."""
    d = np.diff(np.asarray(levels, dtype=float))
    return float(ROBUST_SD_OF_MAD * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0)) if d.size else math.nan


@dataclass
class LevelShift:
    """Sustained level shifts both ways (two-sided CUSUM, Page 1954) in units of the level's own noise sd.

    After ``learn_samples`` levels: reference mu = their median, sd = :func:`robust_noise_sd` (floored at
    ``sd_floor_db``, a meter's resolution). Per level z = (L - mu) / sd, S+ = max(0, S+ + z - k),
    S- = max(0, S- - z - k) (k = allowance_sd); S > h (h = decision_sd) is a shift: the new reference is the
    median of the levels since that CUSUM left 0 after their most likely change point, and both sums restart.
    A downward shift of at least ``min_drop_db`` is a drop (travel, size). For normal noise, k = 1 and h = 10
    give an in-control run length above 1e6 levels per side (Siegmund's approximation), and a 3 dB drop at
    sd 0.3 dB (10 sd) is found at the first level after it."""

    learn_samples: int = 20
    allowance_sd: float = 1.0
    decision_sd: float = 10.0
    min_drop_db: float = 3.0
    sd_floor_db: float = 0.01
    learning: list = field(default_factory=list)
    ref_db: float = math.nan
    sd_db: float = math.nan
    up: float = 0.0
    down: float = 0.0
    since_up: list = field(default_factory=list)
    since_down: list = field(default_factory=list)
    drops: list = field(default_factory=list)
    rises: list = field(default_factory=list)

    def update(self, travel_m: float, level_db: float) -> None:
        if math.isnan(self.ref_db):
            self.learning.append(level_db)
            if len(self.learning) >= self.learn_samples:
                self.ref_db = float(np.median(self.learning))
                self.sd_db = max(robust_noise_sd(self.learning), self.sd_floor_db)
            return
        z = (level_db - self.ref_db) / self.sd_db
        self.up = max(0.0, self.up + z - self.allowance_sd)
        self.down = max(0.0, self.down - z - self.allowance_sd)
        self.since_up = self.since_up + [level_db] if self.up > 0 else []
        self.since_down = self.since_down + [level_db] if self.down > 0 else []
        if self.down > self.decision_sd:
            new = self._new_level(self.since_down)
            if self.ref_db - new >= self.min_drop_db:
                self.drops.append((travel_m, self.ref_db - new))
            self._restart(new)
        elif self.up > self.decision_sd:
            new = self._new_level(self.since_up)
            self.rises.append((travel_m, new - self.ref_db))
            self._restart(new)

    def _new_level(self, run: list) -> float:
        """The level after the shift: the median of the run's levels after its most likely change point j (least
        squares of a step from the known reference, sum (x_i<j - mu)^2 + sum (x_i>=j - mean_j)^2 minimal); the
        run may start with a few noise levels that left the CUSUM above 0 before the shift."""
        x = np.asarray(run, dtype=float)
        cost = [float(np.sum((x[:j] - self.ref_db) ** 2) + np.sum((x[j:] - x[j:].mean()) ** 2))
                for j in range(x.size)]
        return float(np.median(x[int(np.argmin(cost)):]))

    def _restart(self, ref_db: float) -> None:
        self.ref_db, self.up, self.down, self.since_up, self.since_down = ref_db, 0.0, 0.0, [], []


@dataclass
class NoiseTrend:
    """Rise (CUSUM above the running-in level) and level shifts both ways (:class:`LevelShift`) of the noise
    level against travel."""

    baseline_samples: int = 20
    rise_allowance_db: float = 1.0
    rise_cusum_db: float = 8.0
    ewma_weight: float = 0.3
    sd_floor_db: float = 0.2
    shift: LevelShift = field(default_factory=LevelShift)
    samples: list = field(default_factory=list)
    mean_db: float = math.nan
    sd_db: float = math.nan
    cusum_db: float = 0.0
    ewma_db: float = math.nan
    rise_travel_m: float | None = None
    levels: int = 0                 # levels accepted
    last_travel_m: float = 0.0      # travel of the last accepted level [m]

    def update(self, travel_m: float, level_db: float) -> None:
        """One level [dB] at ``travel_m``; raises ValueError (state unchanged) on a non-finite level or travel, or
        travel that goes backwards (a level stamped before the start or before the previous level)."""
        if not (math.isfinite(level_db) and math.isfinite(travel_m) and travel_m >= self.last_travel_m):
            raise ValueError(f"noise level must be finite and its travel not decrease, got {level_db!r} dB at "
                             f"{travel_m!r} m after {self.last_travel_m!r} m")
        self.levels += 1
        self.last_travel_m = travel_m
        self.ewma_db = level_db if math.isnan(self.ewma_db) else (
            self.ewma_weight * level_db + (1.0 - self.ewma_weight) * self.ewma_db)
        self.shift.update(travel_m, level_db)
        if math.isnan(self.mean_db):
            self.samples.append(level_db)
            if len(self.samples) >= self.baseline_samples:
                self.mean_db = float(np.mean(self.samples))
                self.sd_db = max(float(np.std(self.samples, ddof=1)), self.sd_floor_db)
            return
        self.cusum_db = max(0.0, self.cusum_db + level_db - self.mean_db - self.rise_allowance_db)
        if self.rise_travel_m is None and self.cusum_db > self.rise_cusum_db:
            self.rise_travel_m = travel_m

    def drop_from(self, travel_m: float) -> tuple[float, float] | None:
        """The first level drop (travel [m], size [dB]) at or after travel_m, None without one."""
        return next((d for d in self.shift.drops if d[0] >= travel_m), None)

    @property
    def rise_db(self) -> float:
        """EWMA level above the running-in mean [dB] (nan while learning)."""
        return self.ewma_db - self.mean_db


@dataclass
class LifeTestSigns:
    """The failure signs of one guide over blocks at increasing travel (see the module docstring). The defect is
    measured (:func:`~guide_health.models.rolling.envelope.measure_defect`) on an abnormal block over the
    contiguous signal before it (up to ``envelope_max_s``): once per refill of that span, and on every abnormal
    block that starts a new span."""

    sample_rate_hz: float
    kinematics: GuideKinematics
    carriage_speed_m_s: float
    bands: AbnormalBand = None          # type: ignore[assignment]
    noise: NoiseTrend = field(default_factory=NoiseTrend)
    envelope_max_s: float = 2.0
    blocks: int = 0
    last_travel_m: float = -math.inf
    abnormal_travels: list = field(default_factory=list)
    failure_travel_m: float | None = None
    failure_lower_m: float | None = None
    defect: str | None = None
    measured: MeasuredDefect | None = None
    span: list = field(default_factory=list)
    span_samples: int = 0
    span_new: int = 0
    span_measured: bool = False
    last: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.bands is None:
            self.bands = AbnormalBand(self.sample_rate_hz)
        self.defects_hz = defect_frequencies(self.kinematics, self.carriage_speed_m_s)
        self.candidates_hz = {"raceway": self.defects_hz["raceway_hz"],
                              "ball_defect": self.defects_hz["ball_defect_hz"]}

    def update_block(self, travel_m: float, block: np.ndarray, contiguous: bool = False) -> dict:
        """One accelerometer block at ``travel_m`` (``contiguous``: it follows the previous block without a gap);
        raises ValueError (state unchanged) on a bad block or travel that goes backwards."""
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
        self._extend_span(np.asarray(block, dtype=float), contiguous)
        if r["abnormal"] and not self.span_measured:
            m = measure_defect(np.concatenate(self.span), self.sample_rate_hz, self.candidates_hz,
                               self.defects_hz["recirculation_hz"])
            self.span_measured, self.span_new = True, 0
            if m.named is not None:
                self.measured, self.defect = m, m.named
        self.last = r
        return r

    def _extend_span(self, block: np.ndarray, contiguous: bool) -> None:
        """The contiguous signal up to and with this block, at most envelope_max_s (older blocks dropped); a
        measured span may be measured again once envelope_max_s of new signal has come in."""
        limit = max(int(self.envelope_max_s * self.sample_rate_hz), block.size)
        if not contiguous:
            self.span, self.span_samples, self.span_new, self.span_measured = [], 0, 0, False
        self.span.append(block)
        self.span_samples += block.size
        self.span_new += block.size
        while self.span_samples - self.span[0].size >= limit:
            self.span_samples -= self.span.pop(0).size
        if self.span_measured and self.span_new >= limit:
            self.span_measured = False

    def update_level(self, travel_m: float, level_db: float) -> None:
        self.noise.update(travel_m, level_db)

    @property
    def alarm(self) -> bool:
        return bool(self.last.get("alarm")) or self.failure_travel_m is not None

    def loosening(self) -> tuple[float, float] | None:
        """The level drop (travel [m], size [dB]) at or after the spall signature's interval, None without one."""
        return None if self.failure_travel_m is None else self.noise.drop_from(self.failure_lower_m)

    def level(self) -> tuple[Level, str]:
        """(level, message): ERROR on the seed's end-of-test pattern (the spall signature and a level drop at or
        after it), WARN on a sustained abnormal band or a noise rise, OK otherwise."""
        b, n = self.bands, self.noise
        band_rule = (f"band z > z_threshold {b.threshold:.2f} in {b.persist_k} of {b.persist_n} blocks "
                     f"from {self.failure_travel_m / 1e3:.1f} km" if self.failure_travel_m is not None else "")
        drop = self.loosening()
        if drop is not None:
            sh = n.shift
            return ERROR, (f"end of test: abnormal band ({band_rule}) and noise drop of {drop[1]:.1f} dB at "
                           f"{drop[0] / 1e3:.1f} km >= noise_drop_db {sh.min_drop_db:g} dB (two-sided CUSUM > "
                           f"{sh.decision_sd:g} noise sd {sh.sd_db:.2g} dB): carriage loosened")
        if self.failure_travel_m is not None:
            return WARN, f"sustained abnormal vibration band: {band_rule}"
        if n.rise_travel_m is not None:
            return WARN, (f"noise rise from {n.rise_travel_m / 1e3:.1f} km: CUSUM above the running-in level > "
                          f"rise_cusum_db {n.rise_cusum_db:g} dB")
        return OK, "no failure sign"

    def drop_km(self) -> float | None:
        """The reported drop: the loosening when there is one, else the latest level drop."""
        drop = self.loosening() or (self.noise.shift.drops[-1] if self.noise.shift.drops else None)
        return None if drop is None else drop[0] / 1e3

    def summary(self) -> dict:
        lvl, msg = self.level()
        r = self.last
        m = self.measured
        return {"level": lvl.name, "message": msg, "blocks": self.blocks,
                "failure_travel_km": None if self.failure_travel_m is None else self.failure_travel_m / 1e3,
                "failure_interval_km": None if self.failure_travel_m is None
                else [self.failure_lower_m / 1e3, self.failure_travel_m / 1e3],
                "defect": self.defect, "defect_frequencies_hz": self.defects_hz,
                "defect_measured_hz": math.nan if m is None else m.frequency_hz,
                "defect_measured_uncertainty_hz": math.nan if m is None else m.uncertainty_hz,
                "defect_resolution_hz": math.nan if m is None else m.resolution_hz,
                "defect_spectrum": "" if m is None else m.spectrum,
                "defect_measurement": None if m is None else m.as_dict(),
                "z_max": float(r.get("z_max", 0.0)), "z_threshold": self.bands.threshold,
                "abnormal_band_hz": r.get("band"),
                "noise_level_db": self.noise.ewma_db, "noise_rise_db": self.noise.rise_db,
                "noise_sd_db": self.noise.shift.sd_db,
                "noise_rise_km": None if self.noise.rise_travel_m is None else self.noise.rise_travel_m / 1e3,
                "noise_drop_km": self.drop_km(),
                "last_travel_km": self.last_travel_m / 1e3 if math.isfinite(self.last_travel_m) else 0.0}


class StampedLifeTest:
    """LifeTestSigns fed by header stamps, one object for the live node and the offline bag chain.

    Travel of a stamp from :class:`~guide_health.models.rolling.travel.TravelClock` (the axis position when
    positions come, else speed x moving time; start = the first stamp unless given). Channels: one LifeTestSigns
    per accelerometer channel (made from a fresh copy of the first), all sharing one NoiseTrend (the sound level
    is one); the reported channel is the worst (highest level, then the first to fail). A block's sample rate is
    checked against sample_rate_hz (relative 1e-6) per block; a block is contiguous when its stamp is the end
    of the channel's previous block (within half a sample). Blocks and levels are independent streams, each in
    stamp order. A bad block, level or position raises nothing: it is counted and leaves the state unchanged."""

    def __init__(self, signs: LifeTestSigns, carriage_speed_m_s: float, start_ns: int | None = None,
                 clock: TravelClock | None = None) -> None:
        self.fresh = copy.deepcopy(signs)
        self.channels: dict[str, LifeTestSigns] = {"": signs}
        self.clock = clock or TravelClock(float(carriage_speed_m_s), start_ns=start_ns)
        self.speed_m_s = float(carriage_speed_m_s)
        self.rejected_blocks = 0
        self.rejected_levels = 0
        self.rejected_positions = 0
        self.block_end_ns: dict[str, float] = {}
        self.last_block: dict = {}
        self.last_channel = ""

    @property
    def start_ns(self) -> int | None:
        return self.clock.start_ns

    def travel_m(self, t_ns: int) -> float:
        return self.clock.travel_m(t_ns)

    def channel(self, name: str) -> LifeTestSigns:
        """The channel's LifeTestSigns (the first block of a new name starts it from the fresh copy; the
        single-channel form's block is channel '')."""
        if name not in self.channels:
            if list(self.channels) == [""] and self.channels[""].blocks == 0:
                self.channels = {name: self.channels.pop("")}
            else:
                c = copy.deepcopy(self.fresh)
                c.noise = next(iter(self.channels.values())).noise
                self.channels[name] = c
        return self.channels[name]

    @property
    def worst_channel(self) -> str:
        def rank(item):
            name, s = item
            fail = math.inf if s.failure_travel_m is None else s.failure_travel_m
            return (-int(s.level()[0]), fail, list(self.channels).index(name))
        return min(self.channels.items(), key=rank)[0]

    @property
    def signs(self) -> LifeTestSigns:
        return self.channels[self.worst_channel]

    def on_block(self, t_ns: int, block: np.ndarray, channel: str = "",
                 sample_rate_hz: float | None = None) -> dict | None:
        """One accelerometer block of a channel; None when rejected (counted): rate other than sample_rate_hz,
        non-finite or too short block, travel going back."""
        signs = self.channel(channel)
        fs = signs.sample_rate_hz
        if sample_rate_hz is not None and not abs(sample_rate_hz - fs) <= 1e-6 * fs:
            self.rejected_blocks += 1
            return None
        end = self.block_end_ns.get(channel)
        contiguous = end is not None and abs(int(t_ns) - end) <= 0.5e9 / fs
        try:
            r = signs.update_block(self.travel_m(t_ns), block, contiguous)
        except ValueError:
            self.rejected_blocks += 1
            return None
        self.block_end_ns[channel] = int(t_ns) + np.asarray(block).size * 1e9 / fs
        self.last_block, self.last_channel = r, channel
        return r

    def on_level(self, t_ns: int, level_db: float) -> bool:
        """One sound level [dB]; False when rejected (counted)."""
        try:
            next(iter(self.channels.values())).update_level(self.travel_m(t_ns), level_db)
        except ValueError:
            self.rejected_levels += 1
            return False
        return True

    def on_position(self, t_ns: int, x_m: float) -> bool:
        """One position of the test axis [m]; False when rejected (counted)."""
        try:
            self.clock.on_position(t_ns, x_m)
        except ValueError:
            self.rejected_positions += 1
            return False
        return True
