"""Wear-coefficient calibration: pin-on-disc regression (seed 000 Table 2 / Eq. 13) and the online update
of K from measured straightness, with the remaining precision life interval it implies (Eq. 12).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

from guide_health.models.lazy_scipy import stdtrit


@dataclass
class PinOnDiscFit:
    wear_rate_per_load_speed: float       # gamma / (W v) [m^2/N] (seed 000 Eq. 13: 2.22e-14)
    wear_coefficient: float               # K = gamma H / (W v)  (seed 000 Eq. 10 vs Eq. 13)
    wear_coefficient_ci95: tuple[float, float]
    r_squared: float                      # centred: 1 - SS_res / SS_tot about the mean
    r_squared_uncentred: float            # 1 - SS_res / sum(y^2), the usual figure for a fit through 0
    rows: int
    residual_sd_m3_s: float


def fit_pin_on_disc(speed_m_s: np.ndarray, load_n: np.ndarray, wear_rate_m3_s: np.ndarray,
                    hardness_pa: float, confidence: float = 0.95, estimator: str = "ols") -> PinOnDiscFit:
    """Least squares through the origin of gamma = c W v (seed 000 Eq. 13), K = c H (Eq. 10).

    ``estimator`` "ols": ordinary least squares on the wear rate with no intercept (Archard: no wear without
    load or sliding); "ratio": c = sum(gamma) / sum(W v), least squares weighted by 1 / (W v) (residual
    variance proportional to W v), which reproduces the published 2.22e-14 (K = 4.422e-6 with H = 199e6;
    OLS gives +1.8 %). The confidence interval of c is Student-t with n - 1 degrees of freedom.
    """
    if estimator not in ("ols", "ratio"):
        raise ValueError(f"estimator must be 'ols' or 'ratio', got {estimator!r}")
    v = np.asarray(speed_m_s, dtype=float)
    w = np.asarray(load_n, dtype=float)
    y = np.asarray(wear_rate_m3_s, dtype=float)
    if not (v.shape == w.shape == y.shape) or v.size < 2:
        raise ValueError("pin-on-disc fit needs at least two rows of speed, load and wear rate")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(w)) and np.all(np.isfinite(y))):
        raise ValueError("pin-on-disc rows must be finite numbers")
    if np.any(v <= 0) or np.any(w <= 0) or np.any(y < 0):
        raise ValueError("pin-on-disc rows need speed > 0, load > 0 and wear rate >= 0")
    x = w * v
    weight = 1.0 / x if estimator == "ratio" else np.ones_like(x)
    c = float((weight * x) @ y / ((weight * x) @ x))
    residual = y - c * x
    ss_res = float(residual @ residual)
    dof = x.size - 1
    s2 = float((weight * residual) @ residual) / dof
    se_c = math.sqrt(s2 / float((weight * x) @ x))
    t = float(stdtrit(dof, 0.5 + confidence / 2))
    ss_tot = float(((y - y.mean()) ** 2).sum())
    return PinOnDiscFit(
        wear_rate_per_load_speed=c,
        wear_coefficient=c * hardness_pa,
        wear_coefficient_ci95=((c - t * se_c) * hardness_pa, (c + t * se_c) * hardness_pa),
        r_squared=1.0 - ss_res / ss_tot,
        r_squared_uncentred=1.0 - ss_res / float(y @ y),
        rows=int(x.size),
        residual_sd_m3_s=math.sqrt(ss_res / dof),
    )


Z90 = NormalDist().inv_cdf(0.95)


def z90_for_measurements(count: int) -> float:
    """The 90 % interval's half-width in sd after ``count`` measurements: Student-t with count - 1 dof (the
    scatter is estimated from them), the normal Z90 below 3."""
    return float(stdtrit(count - 1, 0.95)) if count >= 3 else Z90


@dataclass
class WearCoefficientEstimator:
    """Online Bayesian update of K from measured straightness, A0 known (conjugate normal).

    Each measurement j gives y_j - A0 = K g_j + e_j, where g_j is the model's straightness loss per unit K
    at the measurement time and e_j ~ N(0, sigma^2). Prior K ~ N(K0, (r K0)^2). sigma is the larger of the
    configured measurement noise and the residual scatter once 3 measurements exist, so an optimistic noise
    parameter does not make the interval too narrow.
    """

    prior_wear_coefficient: float
    prior_rel_sd: float = 0.5
    noise_sd_m: float = 0.5e-6
    straightness_initial_m: float = 0.0
    measurement_t_ns: list = field(default_factory=list)
    measurement_m: list = field(default_factory=list)
    measurement_loss_per_k_m: list = field(default_factory=list)   # g_j
    measurement_work_nm: list = field(default_factory=list)        # Archard work at the measurement

    def add(self, t_ns: int, straightness_m: float, loss_per_k_m: float, work_nm: float) -> None:
        self.measurement_t_ns.append(int(t_ns))
        self.measurement_m.append(float(straightness_m))
        self.measurement_loss_per_k_m.append(float(loss_per_k_m))
        self.measurement_work_nm.append(float(work_nm))

    @property
    def count(self) -> int:
        return len(self.measurement_m)

    def posterior(self, loss_per_k_m: np.ndarray | None = None) -> tuple[float, float, float]:
        """(K mean, K sd, sigma used) from the prior and the measurements with finite g_j.

        ``loss_per_k_m`` overrides the stored g_j (Eq. 7 with stroke limits refined since).
        """
        k0 = self.prior_wear_coefficient
        prior_var = (self.prior_rel_sd * k0) ** 2
        g = np.asarray(self.measurement_loss_per_k_m if loss_per_k_m is None else loss_per_k_m, dtype=float)
        y = np.asarray(self.measurement_m, dtype=float) - self.straightness_initial_m
        ok = np.isfinite(g) & np.isfinite(y)
        g, y = g[ok], y[ok]
        sigma = self.noise_sd_m
        if g.size == 0 or not np.any(g > 0):
            return k0, math.sqrt(prior_var), sigma
        for _ in range(2):  # sigma from residuals needs K; two passes settle it
            precision = 1.0 / prior_var + float(g @ g) / sigma ** 2
            k = (k0 / prior_var + float(g @ y) / sigma ** 2) / precision
            if g.size >= 3:
                residual = y - k * g
                scatter = math.sqrt(float(residual @ residual) / (g.size - 1))
                sigma = max(self.noise_sd_m, scatter)
        precision = 1.0 / prior_var + float(g @ g) / sigma ** 2
        k = (k0 / prior_var + float(g @ y) / sigma ** 2) / precision
        return k, math.sqrt(1.0 / precision), sigma

    def interval90(self, loss_per_k_m: np.ndarray | None = None) -> tuple[float, float, float]:
        """(K low, K mean, K high): 90 % credible interval (Student-t when sigma comes from residuals)."""
        k, sd, _ = self.posterior(loss_per_k_m)
        n = self.count
        z = z90_for_measurements(n)
        return k - z * sd, k, k + z * sd

    def state(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    @classmethod
    def from_state(cls, state: dict) -> WearCoefficientEstimator:
        return cls(**state)


def remaining_life_s(straightness_limit_m: float, straightness_initial_m: float, loss_per_k_m: float,
                     rate_per_k_m_s: float, wear_coefficient: float) -> float:
    """Remaining precision life at the current duty [s]:
    t_rem = (A_max - A0 - K g_now) / (K dg/dt)   (seed 000 Eq. 12 from the present state).

    0 when the limit is already passed; inf when the guide does not wear at the present duty.
    """
    if not (math.isfinite(loss_per_k_m) and math.isfinite(rate_per_k_m_s)):
        return math.nan
    if wear_coefficient <= 0 or rate_per_k_m_s <= 0:
        return math.inf
    margin = straightness_limit_m - straightness_initial_m - wear_coefficient * loss_per_k_m
    if margin <= 0:
        return 0.0
    return margin / (wear_coefficient * rate_per_k_m_s)
