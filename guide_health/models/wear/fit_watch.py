"""Does the model still fit the machine? Innovations of the straightness measurements and a running test.

For each accepted straightness measurement, before K is updated with it, the model predicts it:

    y_pred = A0 + K g,   s_pred^2 = g^2 sd(K)^2 + sigma^2 + s_T^2,   z = (y - y_pred) / s_pred

with g the straightness loss per unit K at the measurement, K and sd(K) the posterior of the measurements
before it (models/wear/calibration.py), sigma the configured measurement noise and s_T the thermal term
(the registry's GAUGE_TEMPERATURE: the model file's variance of the correction c_T (T - T_ref) + e,
:func:`thermal_sd_m`). This is the one-step predictive distribution of the conjugate normal update; when the
model is right, z ~ N(0, 1) and successive z are independent.

Two tests run on z, each at half the stated false-alarm rate per measurement ``FALSE_ALARM_RATE`` (so the
union fires at most at that rate, Bonferroni):

* a two-sided CUSUM (Page 1954): S+ = max(0, S+ + z - k), S- = max(0, S- - z - k), alarm when either passes
  h. k = 0.5 (optimal for a shift of one predictive sd); h solves ARL0(h) = 2 / FALSE_ALARM_RATE with
  Siegmund's approximation of the in-control average run length (:func:`cusum_arl0`);
* the count of |z| outside the 99 % band (|z| > 2.576) among the last ``WINDOW_MEASUREMENTS``: alarm when the
  count reaches the smallest m with P(Binomial(N, 0.01) >= m) <= FALSE_ALARM_RATE / 2.

``model_fit`` rule: ``broken`` from the measurement at which either test fires, latched until :meth:`FitWatch.clear`
(a maintenance event that resets the wear, or a new model file); otherwise ``drifting`` while the CUSUM is
above the threshold of a 10x higher false-alarm rate (an early sign, no WARN), else ``ok``. While broken,
the remaining-life interval is widened by the innovations' observed rms (:func:`widened_life_interval_s`).
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime, timedelta

import numpy as np

#: the stated false-alarm rate of the fit test per measurement (both tests together) on a fitting model
FALSE_ALARM_RATE = 1e-3
#: the CUSUM's reference value k [predictive sd]: tuned to a shift of one predictive sd (k = shift / 2)
CUSUM_REFERENCE = 0.5
#: the measurements the 99 % band count looks back over
WINDOW_MEASUREMENTS = 10
#: the two-sided 99 % band of N(0, 1)
BAND_99 = 2.5758293035489004
#: ``drifting``: the CUSUM above the threshold of this multiple of the false-alarm rate
DRIFT_RATE_FACTOR = 10.0
FIT_STATES = ("ok", "drifting", "broken")
#: the status keys of the test (FitWatch.values; docs/interfaces.md)
FIT_STATUS_KEYS = ("last_innovation_sigma", "innovation_cusum", "innovation_cusum_threshold", "innovations_outside_99",
                   "innovation_window", "model_fit", "model_fit_since_utc", "model_fit_first_fired_utc")


def cusum_arl0(h: float, k: float = CUSUM_REFERENCE) -> float:
    """In-control average run length of the two-sided CUSUM on N(0, 1) inputs [measurements].

    Siegmund's approximation of a one-sided CUSUM with drift D = mu - k = -k (D. Siegmund, Sequential
    Analysis, Springer 1985; as given in D. C. Montgomery, Introduction to Statistical Quality Control,
    Sec. 9.1, whose table of the two-sided k = 0.5 CUSUM lists ARL0 168 at h = 4 and 465 at h = 5):
    ARL1 = (exp(-2 D b) + 2 D b - 1) / (2 D^2), b = h + 1.166; two sides: 1/ARL = 1/ARL1+ + 1/ARL1-, = ARL1/2.
    """
    b = h + 1.166
    d = -k
    one_sided = (math.exp(-2.0 * d * b) + 2.0 * d * b - 1.0) / (2.0 * d * d)
    return one_sided / 2.0


def cusum_threshold(false_alarm_rate: float, k: float = CUSUM_REFERENCE) -> float:
    """h with :func:`cusum_arl0` (h, k) = 1 / false_alarm_rate (bisection: the ARL rises with h)."""
    target = 1.0 / false_alarm_rate
    low, high = 0.0, 100.0
    for _ in range(100):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if cusum_arl0(mid, k) < target else (low, mid)
    return 0.5 * (low + high)


def band_count_threshold(false_alarm_rate: float, window: int = WINDOW_MEASUREMENTS, p_out: float = 0.01) -> int:
    """The smallest m with P(Binomial(window, p_out) >= m) <= false_alarm_rate (outside-band count alarm)."""
    for m in range(1, window + 1):
        tail = sum(math.comb(window, i) * p_out ** i * (1.0 - p_out) ** (window - i) for i in range(m, window + 1))
        if tail <= false_alarm_rate:
            return m
    return window + 1


CUSUM_THRESHOLD = cusum_threshold(FALSE_ALARM_RATE / 2.0)
CUSUM_DRIFT_THRESHOLD = cusum_threshold(DRIFT_RATE_FACTOR * FALSE_ALARM_RATE / 2.0)
BAND_COUNT_THRESHOLD = band_count_threshold(FALSE_ALARM_RATE / 2.0)


@dataclass(frozen=True)
class Innovation:
    """One measurement against the model's prediction of it (SI units)."""

    predicted_m: float
    predictive_sd_m: float
    measured_m: float

    @property
    def sigma(self) -> float:
        """The standardized innovation z = (y - y_pred) / s_pred."""
        return (self.measured_m - self.predicted_m) / self.predictive_sd_m


def predict(measured_m: float, initial_m: float, loss_per_k_m: float, k: float, k_sd: float, noise_sd_m: float,
            thermal_sd_m: float = 0.0) -> Innovation:
    """The one-step predictive of y = A0 + K g + e (seed 000 Eq. 11 with K ~ N(k, k_sd^2), e ~ N(0, sigma^2)):
    mean A0 + k g, sd sqrt(g^2 k_sd^2 + sigma^2 + s_T^2)."""
    sd = math.sqrt((loss_per_k_m * k_sd) ** 2 + noise_sd_m ** 2 + thermal_sd_m ** 2)
    return Innovation(initial_m + k * loss_per_k_m, sd, measured_m)


def thermal_sd_m(offset_k: float, covariance_ct_e) -> float:
    """sd of the gauge temperature correction c_T (T - T_ref) + e [m] from the model file's 2x2 covariance of
    (c_T [m/K], e [m]): sqrt(dT^2 var c_T + 2 dT cov + var e)."""
    c = np.asarray(covariance_ct_e, dtype=float)
    var = offset_k * offset_k * c[0, 0] + 2.0 * offset_k * c[0, 1] + c[1, 1]
    return math.sqrt(max(var, 0.0))


def utc_text(t_ns: int | None) -> str:
    """ISO 8601 UTC of a stamp [ns]; '' for None."""
    if t_ns is None:
        return ""
    return datetime.fromtimestamp(t_ns * 1e-9, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def parse_utc_ns(text: str, option: str = "--since") -> int:
    """The stamp [ns since the epoch] of a date given to ``option`` (diagnose --since, replay --model-at): ISO
    8601 in UTC ('2023-11-15T14:43:20Z', as :func:`utc_text` writes it, or with +00:00 / without a zone: read
    as UTC); ValueError (one line) otherwise."""
    try:
        when = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"{option} {text!r}: not an ISO 8601 date (e.g. 2026-11-27T14:05:00Z)") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    if when.utcoffset() != timedelta(0):
        raise ValueError(f"{option} {text!r}: give the date in UTC (Z), as model_fit_since_utc does")
    return int(round(when.timestamp() * 1e9))


#: K's prior, A0 and the measurement noise: with the effects (the model file) the model the test judges
MODEL_PARAMS = ("wear_coefficient", "wear_coefficient_prior_rel_sd", "straightness_initial_m", "straightness_noise_m")


def model_key(params, effects) -> str:
    """A short digest of the model the test judges (MODEL_PARAMS, the effect parameters, covariance included,
    and the anchor stamp model_from_stamp_s when set): another model file gives another key."""
    stamp = [params.model_from_stamp_s] if params.model_from_stamp_s else []    # unanchored: the key as before
    text = repr([getattr(params, n) for n in MODEL_PARAMS] + [effects] + stamp)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


@dataclass
class FitWatch:
    """The running fit test of one guide (module docstring); its fields are its saved state."""

    cusum_high: float = 0.0
    cusum_low: float = 0.0
    recent_sigma: list = field(default_factory=list)     # z of the last WINDOW_MEASUREMENTS
    last_sigma: float = math.nan
    model_fit: str = "ok"
    since_t_ns: int | None = None                        # the measurement at which model_fit took its value
    first_fired_t_ns: int | None = None                  # the first alarm since the start (kept by clear)
    innovations: int = 0
    model_key: str = ""                                  # the model the test judges (a new one clears it)

    @property
    def cusum(self) -> float:
        return max(self.cusum_high, self.cusum_low)

    @property
    def outside_band(self) -> int:
        return sum(1 for z in self.recent_sigma if abs(z) > BAND_99)

    def update(self, t_ns: int, z: float) -> None:
        """One standardized innovation (a finite z) of the measurement stamped ``t_ns``."""
        self.innovations += 1
        self.last_sigma = z
        self.cusum_high = max(0.0, self.cusum_high + z - CUSUM_REFERENCE)
        self.cusum_low = max(0.0, self.cusum_low - z - CUSUM_REFERENCE)
        self.recent_sigma = (self.recent_sigma + [z])[-WINDOW_MEASUREMENTS:]
        fired = self.cusum > CUSUM_THRESHOLD or self.outside_band >= BAND_COUNT_THRESHOLD
        if self.model_fit == "broken":
            state = "broken"
        elif fired:
            state = "broken"
            if self.first_fired_t_ns is None:
                self.first_fired_t_ns = int(t_ns)
        else:
            state = "drifting" if self.cusum > CUSUM_DRIFT_THRESHOLD else "ok"
        if state != self.model_fit or self.since_t_ns is None:
            self.model_fit, self.since_t_ns = state, int(t_ns)

    def clear(self, t_ns: int | None, model_key: str | None = None) -> None:
        """A new start of the test (the model was changed, or the surface renewed): ``ok`` from ``t_ns``."""
        self.cusum_high = self.cusum_low = 0.0
        self.recent_sigma = []
        self.model_fit, self.since_t_ns = "ok", t_ns
        if model_key is not None:
            self.model_key = model_key

    def rms_sigma(self) -> float:
        """sqrt(mean z^2) of the recent innovations (1 on a fitting model); nan without any."""
        return math.sqrt(float(np.mean(np.square(self.recent_sigma)))) if self.recent_sigma else math.nan

    def values(self) -> dict:
        """The status keys (docs/interfaces.md)."""
        return {"last_innovation_sigma": self.last_sigma, "innovation_cusum": self.cusum,
                "innovation_cusum_threshold": CUSUM_THRESHOLD, "innovations_outside_99": self.outside_band,
                "innovation_window": len(self.recent_sigma), "model_fit": self.model_fit,
                "model_fit_since_utc": utc_text(self.since_t_ns),
                "model_fit_first_fired_utc": utc_text(self.first_fired_t_ns)}

    def state(self) -> dict:
        return asdict(self)

    @classmethod
    def from_state(cls, state: dict | None) -> FitWatch:
        """A saved watch; None (a state saved before the watch existed): a new one."""
        if not state:
            return cls()
        known = {k: v for k, v in state.items() if k in cls.__dataclass_fields__}
        if known.get("model_fit") not in FIT_STATES:
            raise ValueError(f"model_fit must be one of {FIT_STATES}, got {known.get('model_fit')!r}")
        return cls(**known)


def widened_life_interval_s(life: tuple[float, float, float], rms_sigma: float) -> tuple[float, float, float]:
    """(life, low, high) [s] while the model is broken: each half-width times max(1, rms z) of the recent
    innovations (the interval from their observed variance instead of the nominal one), low not below 0."""
    mid, low, high = life
    scale = rms_sigma if math.isfinite(rms_sigma) and rms_sigma > 1.0 else 1.0
    if not math.isfinite(mid):
        return mid, low, high
    return mid, max(0.0, mid - scale * (mid - low)), mid + scale * (high - mid)
