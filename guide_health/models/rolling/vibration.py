"""Vibration of a rolling guide (seed 004 Sec. 2: the machine's own band, 5.5-6 kHz on its rig, and vibration in
an abnormal band as the sign of fatigue pitting and the criterion to stop a life test).

Pure numpy/scipy, no ROS, no I/O. SI units: accelerations in m/s^2, frequencies in Hz, speeds in m/s,
lengths in m.

* Spectra: Welch's averaged periodogram of one accelerometer block (Hann window, 50 % overlap).
* Bands: ``n_bands`` equal-width bands from 0 to fs/2; band energy E_b = sum of the PSD over the band x df
  [(m/s^2)^2]. The abnormal-band statistic uses the *spectral shape* x_b = ln E_b - median_b(ln E_b): a
  broadband rise with wear lifts every band alike and cancels, a tone or a new resonance lifts one band.
* Baseline: the machine's own bands are learned over a running-in span (mean and sd of x_b per band over the
  first blocks): the seed's 5.5-6 kHz band is one such learned baseline, not a constant.
* Statistic: z_b = (x_b - mean_b) / sd_b; a block is abnormal when max_b z_b > z_threshold. The threshold is
  set from a per-block false-alarm probability alpha_block split over the bands (Bonferroni):
  alpha_band = alpha_block / n_bands, z_threshold = Phi^-1(1 - alpha_band) (one-sided, a band gaining
  energy). An alarm needs k abnormal blocks out of the last n (persistence); for independent blocks the
  false-alarm probability per block of the k-of-n rule is at most C(n, k) alpha_block^k
  (:func:`persistence_false_alarm`): 1e-3 and 3 of 5 give 1e-8 per block.
* Kinematic defect frequencies of a linear guide (:func:`defect_frequencies`, derived there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal, special, stats


def checked_block(block: np.ndarray, sample_rate_hz: float, min_samples: int = 64) -> np.ndarray:
    """The block as a 1-D float array; ValueError when it is not a finite 1-D signal of >= min_samples."""
    x = np.asarray(block, dtype=float)
    if x.ndim != 1 or x.size < min_samples:
        raise ValueError(f"accelerometer block needs >= {min_samples} samples in 1-D, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("accelerometer block has non-finite samples")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise ValueError(f"sample rate must be finite and > 0, got {sample_rate_hz!r}")
    return x


def welch_psd(block: np.ndarray, sample_rate_hz: float, segment: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """One-sided PSD [(m/s^2)^2/Hz] of a block by Welch (Hann, 50 % overlap, segment samples per segment).

    Returns (frequencies [Hz], psd)."""
    x = checked_block(block, sample_rate_hz)
    nper = min(int(segment), x.size)
    return signal.welch(x, fs=sample_rate_hz, window="hann", nperseg=nper, noverlap=nper // 2,
                        detrend="constant", scaling="density")


def band_edges_hz(sample_rate_hz: float, n_bands: int) -> np.ndarray:
    """n_bands + 1 equally spaced band edges from 0 to the Nyquist frequency [Hz]."""
    return np.linspace(0.0, sample_rate_hz / 2.0, int(n_bands) + 1)


def band_energies(freq_hz: np.ndarray, psd: np.ndarray, edges_hz: np.ndarray) -> np.ndarray:
    """Energy per band [(m/s^2)^2]: the PSD summed over [edge_i, edge_i+1) times the bin width."""
    df = freq_hz[1] - freq_hz[0]
    idx = np.clip(np.searchsorted(edges_hz, freq_hz, side="right") - 1, 0, edges_hz.size - 2)
    return np.bincount(idx, weights=psd, minlength=edges_hz.size - 1) * df


def spectral_shape(energies: np.ndarray) -> np.ndarray:
    """x_b = ln E_b - median_b(ln E_b): the band log-energies relative to the block's own level."""
    log_e = np.log(np.maximum(energies, 1e-300))
    return log_e - np.median(log_e)


def z_threshold(alpha_block: float, n_bands: int) -> float:
    """One-sided z threshold so that max over n_bands z-scores exceeds it with probability <= alpha_block
    (Bonferroni: alpha_band = alpha_block / n_bands) for normal z."""
    if not 0 < alpha_block < 1:
        raise ValueError(f"false-alarm probability must be in (0, 1), got {alpha_block!r}")
    return float(stats.norm.isf(alpha_block / n_bands))


def persistence_false_alarm(alpha_block: float, k: int, n: int) -> float:
    """Upper bound of the false-alarm probability per block of the k-of-n rule for independent blocks:
    P(>= k of n abnormal) <= C(n, k) alpha_block^k."""
    if not 1 <= k <= n:
        raise ValueError(f"persistence needs 1 <= k <= n, got k={k}, n={n}")
    return float(special.comb(n, k) * alpha_block ** k)


@dataclass
class BandBaseline:
    """Mean and sd of the spectral shape x_b over a running-in span: the machine's own bands."""

    edges_hz: np.ndarray
    mean: np.ndarray
    sd: np.ndarray
    blocks: int

    @classmethod
    def learn(cls, shapes: np.ndarray, edges_hz: np.ndarray, sd_floor: float = 0.05) -> BandBaseline:
        """Baseline from the spectral shapes of the running-in blocks (rows); sd floored at ``sd_floor``
        (ln units) so that a perfectly steady band cannot trip the test on rounding."""
        s = np.asarray(shapes, dtype=float)
        if s.ndim != 2 or s.shape[0] < 3:
            raise ValueError("a baseline needs >= 3 running-in blocks")
        return cls(np.asarray(edges_hz), s.mean(axis=0), np.maximum(s.std(axis=0, ddof=1), sd_floor),
                   int(s.shape[0]))

    def z_scores(self, shape: np.ndarray) -> np.ndarray:
        return (shape - self.mean) / self.sd

    def machine_bands_hz(self, top: int = 1) -> list[tuple[float, float]]:
        """The ``top`` bands of highest baseline shape (the machine's own bands) as (low, high) [Hz]."""
        order = np.argsort(self.mean)[::-1][:top]
        return [(float(self.edges_hz[i]), float(self.edges_hz[i + 1])) for i in order]


@dataclass(frozen=True)
class GuideKinematics:
    """Ball-guide geometry: ball diameter D [m], ball pitch p [m] (centre distance of neighbouring balls in a
    row), recirculation loop length L_loop [m] (one ball's full circuit: loaded zone, return and turn-rounds),
    contact angle alpha [rad] (rolling radius of the ball r_r = D/2 cos(alpha), 0 for contact at the
    ball's equator)."""

    ball_diameter_m: float
    ball_pitch_m: float
    loop_length_m: float
    contact_angle_rad: float = math.radians(45.0)

    def __post_init__(self) -> None:
        for name in ("ball_diameter_m", "ball_pitch_m", "loop_length_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
        if self.ball_pitch_m < self.ball_diameter_m:
            raise ValueError("ball pitch must be >= ball diameter")


def defect_frequencies(kin: GuideKinematics, carriage_speed_m_s: float) -> dict[str, float]:
    """Kinematic defect frequencies [Hz] of a linear ball guide at carriage speed v.

    The balls roll without slip between the rail raceway (fixed) and the carriage raceway (moving at v):
    the ball centres move at v_ball = v / 2 relative to the rail and at v / 2 relative to the carriage.
    * raceway defect (rail or carriage spall, in the loaded zone): the balls pass a point of either raceway
      at f_race = (v / 2) / p (one ball per pitch p);
    * ball defect (spin): a ball turns at f_spin = (v / 2) / (2 pi r_r), r_r = D/2 cos(alpha) its rolling
      radius; a spall on it strikes both raceways once per turn: f_ball = 2 f_spin = v / (2 pi r_r);
    * recirculation: one ball completes its circuit at f_rec = (v / 2) / L_loop; a ball defect enters the
      loaded zone at f_rec and modulates f_ball (sidebands f_ball +- f_rec).
    """
    v = abs(float(carriage_speed_m_s))
    r_roll = 0.5 * kin.ball_diameter_m * math.cos(kin.contact_angle_rad)
    f_race = 0.5 * v / kin.ball_pitch_m
    f_spin = 0.5 * v / (2.0 * math.pi * r_roll)
    return {"raceway_hz": f_race, "ball_spin_hz": f_spin, "ball_defect_hz": 2.0 * f_spin,
            "recirculation_hz": 0.5 * v / kin.loop_length_m}


def name_tone(freq_hz: np.ndarray, psd: np.ndarray, defects: dict[str, float], min_ratio: float = 10.0,
              harmonics: int = 3, tolerance: float = 0.02) -> str | None:
    """Name the defect whose first ``harmonics`` harmonics stand out of the spectrum, or None.

    For each defect frequency f (raceway, ball defect), the prominence of harmonic k is the PSD peak within
    +-max(tolerance k f, 1.5 df) of k f over the floor, the median PSD of [0.5 f, (harmonics + 0.5) f] away from
    the harmonics. A defect is named when the mean log10 prominence of its harmonics exceeds log10(min_ratio);
    the best-scoring defect wins. Use a fine spectrum (df well below f)."""
    df = float(freq_hz[1] - freq_hz[0])
    best, best_score = None, math.log10(min_ratio)
    for name in ("raceway_hz", "ball_defect_hz"):
        f0 = defects.get(name, 0.0)
        if not f0 > 4.0 * df or (harmonics + 0.5) * f0 > freq_hz[-1]:
            continue
        span = (freq_hz >= 0.5 * f0) & (freq_hz <= (harmonics + 0.5) * f0)
        near = [np.abs(freq_hz - k * f0) <= max(tolerance * k * f0, 1.5 * df) for k in range(1, harmonics + 1)]
        away = span & ~np.logical_or.reduce(near)
        floor = float(np.median(psd[away])) if np.count_nonzero(away) >= 3 else 0.0
        if not floor > 0:
            continue
        score = float(np.mean([math.log10(max(float(psd[m].max()), 1e-300) / floor) for m in near]))
        if score > best_score:
            best, best_score = name[:-3], score
    return best


@dataclass
class AbnormalBand:
    """Sequential abnormal-band test over blocks: learn the baseline over the first ``baseline_blocks``, then
    flag each block with max z > threshold and alarm on k of the last n flagged (persistence)."""

    sample_rate_hz: float
    n_bands: int = 32
    baseline_blocks: int = 20
    alpha_block: float = 1e-3
    persist_k: int = 3
    persist_n: int = 5
    segment: int = 1024
    shapes: list = field(default_factory=list)
    baseline: BandBaseline | None = None
    flags: list = field(default_factory=list)

    def __post_init__(self) -> None:
        persistence_false_alarm(self.alpha_block, self.persist_k, self.persist_n)    # checks k, n
        self.threshold = z_threshold(self.alpha_block, self.n_bands)
        self.edges_hz = band_edges_hz(self.sample_rate_hz, self.n_bands)

    def update(self, block: np.ndarray) -> dict:
        """One block -> {energies, z (None while learning), z_max, band (of z_max), abnormal, alarm, psd}."""
        f, psd = welch_psd(block, self.sample_rate_hz, self.segment)
        e = band_energies(f, psd, self.edges_hz)
        shape = spectral_shape(e)
        out = {"freq_hz": f, "psd": psd, "energies": e, "z": None, "z_max": 0.0, "band": None,
               "abnormal": False, "alarm": False, "learning": self.baseline is None}
        if self.baseline is None:
            self.shapes.append(shape)
            if len(self.shapes) >= self.baseline_blocks:
                self.baseline = BandBaseline.learn(np.array(self.shapes), self.edges_hz)
            return out
        z = self.baseline.z_scores(shape)
        i = int(np.argmax(z))
        abnormal = bool(z[i] > self.threshold)
        self.flags = (self.flags + [abnormal])[-self.persist_n:]
        out.update({"z": z, "z_max": float(z[i]), "band": (float(self.edges_hz[i]), float(self.edges_hz[i + 1])),
                    "abnormal": abnormal, "alarm": sum(self.flags) >= self.persist_k})
        return out
