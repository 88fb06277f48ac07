"""The defect named from the measured spectrum: envelope analysis of a rolling guide's vibration.

Pure numpy/scipy, no ROS, no I/O. Signals in m/s^2, frequencies in Hz, durations in s.

A spall struck by the balls gives short impacts that ring the structure at its resonances: the defect rate is the
rate of the impacts, not a tone of the raw spectrum (Randall & Antoni 2011, "Rolling element bearing
diagnostics - a tutorial", MSSP 25, Sec. 3-4). The standard chain:

1. the band where the impacts ring, found from the data: the band of highest spectral kurtosis
   SK(f) = <|X(t, f)|^4> / <|X(t, f)|^2>^2 - 2 of short-time spectra (Antoni 2006 Eq. 9; Gaussian noise
   gives 0, a tone -1, impacts > 0), over a few window lengths (a coarse kurtogram);
2. band-pass (Butterworth, order 4), Hilbert envelope |x + i H[x]| (scipy.signal.hilbert), mean removed;
3. envelope spectrum (Hann window, zero-padded x4): the impact rate and its harmonics stand out.

When the impacts' rate is also a tone of the raw signal (a defect modulating the guide's own motion) the direct
spectrum shows it: both spectra are measured and the one whose fundamental stands higher above its floor is used.

The measured fundamental is the least-squares fit f0 = sum(k f_k) / sum(k^2) of the interpolated harmonic peaks
f_k (parabola through the log power of the three highest bins). A signal of duration T resolves two rates
1/T apart (Rayleigh): candidates closer than 1/T are *not separable*; each peak's position before interpolation
is known to one bin 1/T (uniform, sd 1/(T sqrt 12)), so the stated uncertainty of f0 is 1/(T sqrt(12 sum k^2)),
an upper bound of what the interpolation achieves on a clean peak.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import signal

KURTOGRAM_SEGMENTS = (16, 32, 64, 128, 256)  # short-time window lengths of the band search [samples]
ZERO_PAD = 4                                # envelope spectrum zero padding (interpolation grid df / 4)
SLIP_TOLERANCE = 0.02                       # balls slip: a candidate matches within 2 % (+ the uncertainty)


def kurtosis_band(x: np.ndarray, fs_hz: float, low_hz: float = 0.0,
                  min_half_width_hz: float = 0.0) -> tuple[float, float, float]:
    """(low, high, SK): the band of highest spectral kurtosis over the windows KURTOGRAM_SEGMENTS (module step 1).

    The band is the bin's main lobe (+-fs/nperseg around its centre, Hann), kept inside (low_hz, 0.45 fs);
    only windows whose half width fs/nperseg >= min_half_width_hz (the envelope of a band B wide holds rates
    up to B / 2: the harmonics searched must fit)."""
    best = (0.0, 0.0, -math.inf)
    for nper in KURTOGRAM_SEGMENTS:
        if nper * 4 > x.size or fs_hz / nper < min_half_width_hz:
            continue
        f, _t, z = signal.stft(x, fs=fs_hz, window="hann", nperseg=nper, noverlap=nper // 2, boundary=None,
                               padded=False)
        p = np.abs(z) ** 2
        sk = np.mean(p * p, axis=1) / np.maximum(np.mean(p, axis=1) ** 2, 1e-300) - 2.0
        half = fs_hz / nper
        ok = (f - half > max(low_hz, 0.0)) & (f + half < 0.45 * fs_hz)
        if not np.any(ok):
            continue
        i = int(np.flatnonzero(ok)[np.argmax(sk[ok])])
        if sk[i] > best[2]:
            best = (float(f[i] - half), float(f[i] + half), float(sk[i]))
    return best


@lru_cache(maxsize=64)
def _bandpass_sos(low_hz: float, high_hz: float, fs_hz: float) -> np.ndarray:
    """Butterworth order-4 band-pass (designed once per band: the kurtogram's bands are a fixed grid)."""
    return signal.butter(4, (low_hz, high_hz), btype="bandpass", fs=fs_hz, output="sos")


def envelope(x: np.ndarray, fs_hz: float, band_hz: tuple[float, float]) -> np.ndarray:
    """Hilbert envelope of x band-passed to band_hz (Butterworth order 4), mean removed (module step 2)."""
    sos = _bandpass_sos(float(band_hz[0]), float(band_hz[1]), float(fs_hz))
    env = np.abs(signal.hilbert(signal.sosfilt(sos, x)))
    return env - env.mean()


def power_spectrum(x: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies, power) of x with a Hann window, zero-padded ZERO_PAD times (module step 3)."""
    n = x.size * ZERO_PAD
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(x.size), n=n)) ** 2
    return np.fft.rfftfreq(n, 1.0 / fs_hz), spec


def interpolated_peak(freq: np.ndarray, power: np.ndarray, lo_hz: float, hi_hz: float) -> tuple[float, float]:
    """(frequency, power) of the highest bin in [lo, hi] (nan, 0 when empty), its frequency refined by the
    parabola through the log power of it and its neighbours (vertex offset d = (a - c) / (2 (a - 2b + c)) bins)."""
    idx = np.flatnonzero((freq >= lo_hz) & (freq <= hi_hz))
    if idx.size == 0:
        return math.nan, 0.0
    i = int(idx[np.argmax(power[idx])])
    if 0 < i < freq.size - 1:
        a, b, c = np.log(np.maximum(power[i - 1:i + 2], 1e-300))
        den = a - 2.0 * b + c
        d = 0.5 * (a - c) / den if den < 0 else 0.0
        return float(freq[i] + d * (freq[1] - freq[0])), float(power[i])
    return float(freq[i]), float(power[i])


@dataclass(frozen=True)
class MeasuredDefect:
    """The measured defect rate and what it matches (see the module docstring)."""

    frequency_hz: float             # f0, nan when no peak stands out
    uncertainty_hz: float           # 1 / (T sqrt(12 sum k^2))
    resolution_hz: float            # 1 / T
    duration_s: float               # T
    spectrum: str                   # "envelope" or "direct"
    band_hz: tuple[float, float]    # the envelope band (kurtosis band)
    prominence: float               # fundamental power / floor
    harmonics: tuple                # ((k, f_k, power / floor), ...) found
    sidebands: tuple                # (f0 - f_rec, f0 + f_rec) power / floor
    candidates: dict                # name -> {"hz", "deviation_hz", "relative", "matches"}
    named: str | None               # the matching candidate or the not-separable text

    def as_dict(self) -> dict:
        return {"defect_measured_hz": self.frequency_hz, "defect_measured_uncertainty_hz": self.uncertainty_hz,
                "defect_resolution_hz": self.resolution_hz, "defect_signal_s": self.duration_s,
                "defect_spectrum": self.spectrum, "defect_band_hz": list(self.band_hz),
                "defect_prominence": self.prominence, "defect_harmonics": [list(h) for h in self.harmonics],
                "defect_sidebands": list(self.sidebands), "defect_candidates": self.candidates,
                "defect_named": self.named}


def _harmonic_series(freq, power, f1: float, floor: float, df: float, harmonics: int) -> list:
    """[(k, f_k, power / floor)] of the harmonics k = 1..harmonics standing min 10x above the floor."""
    found = [(1, f1, 0.0)]
    for k in range(2, harmonics + 1):
        f0 = sum(j * fj for j, fj, _ in found) / sum(j * j for j, _, _ in found)
        fk, pk = interpolated_peak(freq, power, k * f0 - 1.5 * df, k * f0 + 1.5 * df)
        if math.isfinite(fk) and pk > 10.0 * floor:
            found.append((k, fk, pk / floor))
    return found


def _measure(freq, power, search_hz: tuple[float, float], df: float, harmonics: int):
    """(f1, prominence, floor) of the highest peak in the search range against the median floor of
    [search low / 2, (harmonics + 0.5) search high]."""
    f1, p1 = interpolated_peak(freq, power, *search_hz)
    span = (freq >= 0.5 * search_hz[0]) & (freq <= (harmonics + 0.5) * search_hz[1])
    floor = float(np.median(power[span])) if np.count_nonzero(span) >= 8 else math.inf
    return f1, (p1 / floor if floor > 0 else 0.0), floor


def separability_text(names: list[str], gap_hz: float) -> str:
    """'a or b (not separable at this resolution: N s of signal would separate them)', N = 1 / gap (Rayleigh)."""
    need = 1.0 / gap_hz if gap_hz > 0 else math.inf
    return f"{' or '.join(names)} (not separable at this resolution: {need:.2g} s of signal would separate them)"


def name_candidate(f0: float, u_hz: float, resolution_hz: float, candidates_hz: dict[str, float]) -> tuple:
    """(candidates with their match, named): a candidate matches when |f0 - f_c| <= 2 u + SLIP_TOLERANCE f_c;
    the nearest matching candidate is named, unless another candidate lies within the resolution of it, then
    the not-separable text names both (nearest first)."""
    table = {}
    for name, fc in candidates_hz.items():
        dev = f0 - fc
        table[name] = {"hz": fc, "deviation_hz": dev, "relative": dev / fc,
                       "matches": bool(abs(dev) <= 2.0 * u_hz + SLIP_TOLERANCE * fc)}
    order = sorted(candidates_hz, key=lambda n: abs(f0 - candidates_hz[n]))
    if not math.isfinite(f0) or not table[order[0]]["matches"]:
        return table, None
    close = [n for n in order if abs(candidates_hz[n] - candidates_hz[order[0]]) < resolution_hz]
    if len(close) > 1:
        gap = min(abs(candidates_hz[a] - candidates_hz[order[0]]) for a in close[1:])
        return table, separability_text(close, gap)
    return table, order[0]


def measure_defect(x: np.ndarray, fs_hz: float, candidates_hz: dict[str, float], recirculation_hz: float = 0.0,
                   harmonics: int = 4, min_prominence: float = 10.0) -> MeasuredDefect:
    """The defect rate measured from the signal x (module docstring): envelope and direct spectrum searched in
    [0.7 min, 1.3 max] of the candidates; the spectrum whose fundamental stands higher is used; the candidate
    it matches named (:func:`name_candidate`). No fundamental above min_prominence x floor with at least its second
    harmonic above 10 x floor: frequency nan, named None."""
    x = np.asarray(x, dtype=float)
    duration = x.size / fs_hz
    df = 1.0 / duration
    search = (0.7 * min(candidates_hz.values()), 1.3 * max(candidates_hz.values()))
    band = kurtosis_band(x, fs_hz, low_hz=(harmonics + 1) * search[1],
                         min_half_width_hz=(harmonics + 0.5) * search[1])
    tries = []
    if band[1] > band[0]:
        tries.append(("envelope", power_spectrum(envelope(x, fs_hz, band[:2]), fs_hz)))
    tries.append(("direct", power_spectrum(x, fs_hz)))
    best = None
    for kind, (freq, power) in tries:
        f1, prom, floor = _measure(freq, power, search, df, harmonics)
        if best is None or prom > best[2]:
            best = (kind, f1, prom, floor, freq, power)
    kind, f1, prom, floor, freq, power = best
    found = _harmonic_series(freq, power, f1, floor, df, harmonics) if math.isfinite(f1) else []
    if not (prom > min_prominence and len(found) >= 2):     # a fundamental and one harmonic: noise seldom both
        table, _ = name_candidate(math.nan, math.inf, df, candidates_hz)
        return MeasuredDefect(math.nan, math.nan, df, duration, kind, band[:2], prom, (), (), table, None)
    found[0] = (1, f1, prom)
    sum_k2 = sum(k * k for k, _, _ in found)
    f0 = sum(k * fk for k, fk, _ in found) / sum_k2
    u = df / math.sqrt(12.0 * sum_k2)
    sides = tuple(float(interpolated_peak(freq, power, f0 + s * recirculation_hz - df, f0 + s * recirculation_hz
                                          + df)[1] / floor) if recirculation_hz > 1.5 * df else math.nan
                  for s in (-1, 1))
    table, named = name_candidate(f0, u, df, candidates_hz)
    return MeasuredDefect(f0, u, df, duration, kind, band[:2], prom, tuple(found), sides, table, named)
