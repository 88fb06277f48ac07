"""The remaining life with the live wear effects, and its interval (pure numpy/scipy, SI).

The remaining life (seed 000 Eq. 12 from the present state) integrates the running-in decay forward:
A(t_now + T) - A(t_now) = K c [T + r s0 / v_s e^(-s/s0) (1 - e^(-v_s T / s0))], c = dA/dt per K at steady
wear of the present duty, v_s the present sliding speed (closed-form integral of K(s) = K (1 + r e^(-s/s0))),
and the relubrication factor (registry.RELUBRICATION) follows its schedule (:func:`wear_time_s`).
Its interval (:func:`life_interval_s`) profiles K out, as the live model does: the effect parameters phi are
held at the model file's values and K is the online estimate K(phi) from the measurements. A change of phi
moves K(phi) (d K / d phi from the measurements' effective-work gradients, :func:`online_k_sensitivity`),
the straightness now and the rate; the life's variance is grad_phi' Sigma_phi grad_phi (Sigma_phi: the file's
marginal covariance of phi) plus (d life / d K)^2 var(K | phi) (the online update's posterior). With the
same measurements this equals the offline fit's joint delta method (the regression of K on phi is the
fit's Sigma_K,phi Sigma_phi^-1); unlike a fixed joint covariance it stays right when K is recalibrated on
later measurements and whatever stroke range maps the work to straightness (K's scale).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from guide_health.models.lazy_scipy import brentq
from guide_health.models.wear.effect_wear import EffectWear, time_since_relubrication_s
from guide_health.models.wear.effects.parameters import EffectParameters
from guide_health.models.wear.effects.registry import (
    COVARIANCE_NAMES,
    PASS_WEIGHTING,
    PHI_INDEX,
    RATE_NAMES,
    RATE_PHI,
    RELUBRICATION,
    SLIDING_DECAY,
)

#: places in phi (registry.PHI_NAMES) the life reads, by the roles' rows: the pass weight w, A0's deviation, the
#: relubrication growth b and b among the rate terms, running-in's r and s0
W_INDEX, A0_INDEX, B_INDEX = (PHI_INDEX[n] for n in (PASS_WEIGHTING.row_names[0], "straightness_initial_m",
                                                     RELUBRICATION.rate_row))
B_RATE_INDEX = RATE_NAMES.index(RELUBRICATION.rate_row)
R_INDEX, S0_INDEX = (PHI_INDEX[n] for n in SLIDING_DECAY.row_names)
#: ln of the largest float: exp() of more than this overflows
_LN_FLOAT_MAX = math.log(np.finfo(float).max)


#: relative tolerance of a covariance's symmetry: |c_ij - c_ji| <= this x max(|c_ij|, |c_ji|, sd_i sd_j). A
#: matrix product such as J Sigma J' or a pseudo-inverse is symmetric only to rounding (relative ~cond x eps),
#: a hand-edited entry is off by far more; 1e-6 moves no quadratic form grad' C grad by more than 1e-6.
COVARIANCE_SYMMETRY_RTOL = 1e-6


def symmetrised(matrix: np.ndarray) -> np.ndarray:
    """(C + C') / 2: the covariance a product or pseudo-inverse meant, without its rounding asymmetry (the
    quadratic forms x' C x are unchanged)."""
    c = np.asarray(matrix, dtype=float)
    return 0.5 * (c + c.T)


def covariance_problem(values) -> str:
    """'' when ``values`` (row-major, COVARIANCE_NAMES order) is a covariance matrix: the right size, finite,
    variances >= 0, symmetric (COVARIANCE_SYMMETRY_RTOL, relative) and positive semidefinite (no correlation
    beyond +-1: the correlation matrix's smallest eigenvalue >= -1e-6); else what is wrong, naming the
    parameters. A matrix that is none of these would give a narrowed or NaN interval without a word."""
    n = len(COVARIANCE_NAMES)
    c = np.asarray(values, dtype=float).ravel()
    if c.size != n * n:
        return f"has {c.size} numbers, not {n * n} ({n} x {n})"
    if not np.all(np.isfinite(c)):
        return "has non-finite entries"
    c = c.reshape(n, n)
    var = np.diag(c)
    for i in np.flatnonzero(var < 0):
        return f"the variance of {COVARIANCE_NAMES[i]} is negative ({var[i]:.3g})"
    sd = np.sqrt(var)
    scale = np.maximum(np.maximum(np.abs(c), np.abs(c.T)), np.outer(sd, sd))
    bad = np.abs(c - c.T) > COVARIANCE_SYMMETRY_RTOL * scale
    for i, j in zip(*np.nonzero(bad)):
        return (f"is not symmetric: ({COVARIANCE_NAMES[i]}, {COVARIANCE_NAMES[j]}) {c[i, j]:.3g} but "
                f"({COVARIANCE_NAMES[j]}, {COVARIANCE_NAMES[i]}) {c[j, i]:.3g}")
    kept = np.flatnonzero(var > 0)
    corr = c[np.ix_(kept, kept)] / np.outer(sd[kept], sd[kept])
    if kept.size and np.linalg.eigvalsh(corr).min() < -1e-6:
        off = np.abs(corr - np.eye(kept.size))
        i, j = np.unravel_index(int(np.argmax(off)), off.shape)
        return (f"is not positive semidefinite (largest correlation: {COVARIANCE_NAMES[kept[i]]} with "
                f"{COVARIANCE_NAMES[kept[j]]} {corr[i, j]:.3g})")
    return ""


def running_in_extra_m_per_rate(horizon_s, ratio: float, distance_m: float, s_now_m: float,
                                sliding_speed_m_s: float):
    """int_0^T r e^(-(s + v_s t)/s0) dt = r s0 / v_s e^(-s/s0) (1 - e^(-v_s T/s0)) [s] (running-in's extra
    wear time per unit steady wear rate over a horizon T)."""
    if ratio == 0.0 or not sliding_speed_m_s > 0:
        return 0.0 * np.asarray(horizon_s, dtype=float)
    return (ratio * distance_m / sliding_speed_m_s * math.exp(-s_now_m / distance_m)
            * (1.0 - np.exp(-sliding_speed_m_s * np.asarray(horizon_s, dtype=float) / distance_m)))


def lubrication_multiplier_integral_s(horizon_s, growth_per_s: float, tau_now_s: float, interval_s: float):
    """int_0^T max(1 + b tau(u), 0) du [s]: the relubrication factor's wear multiplier (its live form, m = max(1 + b
    tau, 0)) over a horizon T from now. tau(u) = tau_now + u until the next relubrication, due at interval -
    tau_now (now, when overdue), then 0 .. interval, every interval; interval 0: none expected. Closed form
    per relubrication cycle (the multiplier is linear in tau, clipped at 0 for a negative b)."""
    t = np.maximum(np.asarray(horizon_s, dtype=float), 0.0)
    cap = -1.0 / growth_per_s if growth_per_s < 0 else math.inf

    def seg(a, b):      # int_a^b max(1 + g tau, 0) dtau
        a, b = np.minimum(a, cap), np.minimum(b, cap)
        return (b - a) + growth_per_s * (b * b - a * a) / 2.0

    if not interval_s > 0:
        return seg(tau_now_s, tau_now_s + t)
    due = max(interval_s - tau_now_s, 0.0)
    first = seg(tau_now_s, tau_now_s + np.minimum(t, due))
    rest = np.maximum(t - due, 0.0)
    cycles = np.floor(rest / interval_s)
    return first + cycles * seg(0.0, interval_s) + seg(0.0, rest - cycles * interval_s)


def wear_time_s(horizon_s, ratio: float, distance_m: float, s_now_m: float, sliding_speed_m_s: float,
                lubrication: tuple | None = None):
    """E(T) [s] with A(t_now + T) - A(t_now) = (present rate) x E(T), the present rate that of the duty window
    (its steady dA/dt with the effects). Running-in decays on the way: E = T + extra(T)
    (:func:`running_in_extra_m_per_rate`). ``lubrication`` = (b [1/s], tau_now [s], interval [s], the window's
    mean multiplier m_w): the multiplier follows the relubrication schedule instead of staying at the window's,
    E = [M(T) + m(0) extra(T)] / m_w, M of :func:`lubrication_multiplier_integral_s` (the running-in extra
    weighted by the present multiplier: an approximation that matters only with both named, early in life)."""
    extra = running_in_extra_m_per_rate(horizon_s, ratio, distance_m, s_now_m, sliding_speed_m_s)
    if lubrication is None:
        return np.asarray(horizon_s, dtype=float) + extra
    growth, tau_now, interval, window_mean = lubrication
    m_now = max(1.0 + growth * tau_now, 0.0) if not interval > 0 or tau_now < interval else 1.0
    return (lubrication_multiplier_integral_s(horizon_s, growth, tau_now, interval) + m_now * extra) / window_mean


def remaining_life_with_running_in_s(margin_m: float, steady_rate_m_s: float, ratio: float, distance_m: float,
                                     s_now_m: float, sliding_speed_m_s: float,
                                     lubrication: tuple | None = None) -> float:
    """T with steady_rate E(T) = margin (:func:`wear_time_s`): the time to the limit with K(s) decaying and
    the lubrication multiplier following its schedule on the way (seed 000 Eq. 12 with the effects). 0 when
    the margin is used up; inf without wear (or when a negative lubrication growth stops it first)."""
    if not (math.isfinite(margin_m) and math.isfinite(steady_rate_m_s)):
        return math.nan
    if margin_m <= 0:
        return 0.0
    if steady_rate_m_s <= 0:
        return math.inf
    hi = float(margin_m / steady_rate_m_s)
    if lubrication is None and (ratio == 0.0 or not sliding_speed_m_s > 0):
        return hi

    def gap(t):
        return steady_rate_m_s * float(wear_time_s(t, ratio, distance_m, s_now_m, sliding_speed_m_s,
                                                   lubrication)) - margin_m

    lo = 0.0
    for _ in range(80):                 # E(T) grows at least like T m_min / m_w: bracket by doubling
        if gap(hi) >= 0:
            break
        lo, hi = hi, 2.0 * hi
    else:
        return math.inf
    return float(brentq(gap, lo, hi, xtol=1e-9 * hi))


def forecast_straightness_m(horizon_s: np.ndarray, straightness_now_m: float, steady_rate_m_s: float,
                            ratio: float, distance_m: float, s_now_m: float, sliding_speed_m_s: float,
                            lubrication: tuple | None = None) -> np.ndarray:
    """A(t_now + T) at the present duty with the running-in decay and the lubrication schedule [m] (the
    forecast curve)."""
    return straightness_now_m + steady_rate_m_s * wear_time_s(horizon_s, ratio, distance_m, s_now_m,
                                                              sliding_speed_m_s, lubrication)


def online_k_sensitivity(loss_per_k_m: np.ndarray, rise_m: np.ndarray, loss_gradient_m: np.ndarray, k: float,
                         k_sd: float, sigma_m: float, rise_gradient_m: np.ndarray | None = None) -> np.ndarray:
    """d K(phi) / d phi of the online K update (calibration.WearCoefficientEstimator: K = (K0 / v0 + sum g y /
    sigma^2) / P, P = 1 / v0 + sum g^2 / sigma^2 = 1 / k_sd^2) when the effect parameters phi change the
    measurements' losses per unit K g_j by dg_j / dphi (``loss_gradient_m``, one row per measurement) and the
    corrected readings y_j by dy_j / dphi (``rise_gradient_m``: the gauge terms; None = 0):
    dK = k_sd^2 / sigma^2 sum_j [dg_j (y_j - 2 K g_j) + g_j dy_j], y_j the measured rise over A0 [m]."""
    g = np.asarray(loss_per_k_m, dtype=float)
    dg = np.asarray(loss_gradient_m, dtype=float).reshape(g.size, -1)
    dy = np.zeros_like(dg) if rise_gradient_m is None else np.asarray(rise_gradient_m, dtype=float).reshape(dg.shape)
    y = np.asarray(rise_m, dtype=float)
    ok = np.isfinite(g) & np.isfinite(y) & np.all(np.isfinite(dg), axis=1) & np.all(np.isfinite(dy), axis=1)
    if not ok.any() or not sigma_m > 0:
        return np.zeros(dg.shape[1])
    return k_sd ** 2 / sigma_m ** 2 * (dg[ok].T @ (y[ok] - 2.0 * k * g[ok]) + dy[ok].T @ g[ok])


@dataclass(frozen=True)
class EffectLifeNow:
    """The present state :func:`life_interval_s` starts from (SI units; field meanings in its docstring)."""

    margin0: float                       # A_max - A0 [m]
    work: float                          # effective work G [N m]
    loss_work: float                     # straightness per unit K and G [m / (N m)]
    loss_pass: float                     # straightness per unit K and P [m / N]
    work_gradient: np.ndarray            # d G / d phi
    rate_work_per_k: float               # [m/s]
    dln_rate: np.ndarray                 # d ln rate / d(rho, v_lift, n, g, f, b)
    s_now: float                         # [m]
    v_s: float                           # [m/s]
    pass_work: float = 0.0               # P [N]
    rate_pass_per_k: float = 0.0         # [m/s]
    k_sensitivity: np.ndarray | None = None   # d K / d phi (None: zeros)
    lubrication: dict | None = None
    a0_measured: bool = False


def life_interval_s(k: float, k_sd: float, e: EffectParameters, now: EffectLifeNow,
                    z: float) -> tuple[float, float, float]:
    """(life, low, high) [s] of remaining life with the effects, and its interval: the delta method on ln life
    with K profiled (module text): the effect parameters phi = (r, s0, rho, v_lift, n, g, f, b, w, c_T, e, dA0;
    ``EffectParameters.phi``; the change time t_c, the interval T and the rail's x_ref are held) vary with the model
    file's marginal covariance, K follows as the online update would (``now.k_sensitivity`` = dK / dphi),
    and K's own spread given phi is the online posterior sd ``k_sd``.

    ``now`` (:class:`EffectLifeNow`): margin0 = A_max - A0 [m]; work G = effective work [N m] and pass_work
    P [N] (the pass work),
    with straightness per unit K and G, loss_work = 2 / (H b (l_min + l_max)) [m / (N m)], and per unit K and
    P, loss_pass = 1 / (H b) [m / N] (effects.straightness_wear_m: loss = (1 - w) loss_work G + w loss_pass P);
    work_gradient (d G / d phi; P moves in proportion), k_sensitivity (d K / d phi), rate_work_per_k and
    rate_pass_per_k (the two parts of the steady dA/dt per K [m/s]), dln_rate (d ln rate / d(rho, v_lift, n, g,
    f, b) at the present duty), s_now (distance of the present surface [m]), v_s [m/s], lubrication (None, or
    the relubrication schedule: growth_per_unit (b per unit of phi's b: 1, or 1 / T for the interval form),
    tau_now_s, interval_s, window_mean; :func:`wear_time_s`), a0_measured (A0 was set
    by a measurement after a regrind or a new rail: the file's A0 variance no longer applies). A change of phi
    moves the straightness now (through the past effective work and K, and A0 directly) and the rate."""
    phi0 = e.phi()
    dk = np.asarray(np.zeros(phi0.size) if now.k_sensitivity is None else now.k_sensitivity, dtype=float)
    work0, pass0 = now.work, now.pass_work

    def life(k_: float, phi: np.ndarray) -> float:
        d = phi - phi0
        kk = k_ + float(np.dot(dk, d))
        w = phi[W_INDEX]
        work = work0 + float(np.dot(now.work_gradient, d))
        passes = pass0 * work / work0 if work0 > 0 else pass0
        loss = (1.0 - w) * now.loss_work * work + w * now.loss_pass * passes
        rate_per_k = (1.0 - w) * now.rate_work_per_k + w * now.rate_pass_per_k
        rate = kk * rate_per_k * (1.0 + float(np.dot(now.dln_rate, d[RATE_PHI])))
        return remaining_life_with_running_in_s(now.margin0 - d[A0_INDEX] - kk * loss, rate, phi[R_INDEX],
                                                max(phi[S0_INDEX], 1e-9), now.s_now, now.v_s, schedule(phi, d))

    def schedule(phi: np.ndarray, d: np.ndarray) -> tuple | None:
        """The lubrication schedule with b moved: the window's mean multiplier moves with the window's rate
        (d ln rate / d b), the future multiplier with b itself."""
        return schedule_tuple(now.lubrication, phi[B_INDEX], 1.0 + now.dln_rate[B_RATE_INDEX] * d[B_INDEX])

    centre = life(k, phi0)
    if not (math.isfinite(centre) and centre > 0):
        return centre, centre, centre
    cov = e.covariance_matrix()[1:, 1:].copy()
    if now.a0_measured:   # A0 measured after a regrind or a new rail: the file's A0 is not used
        cov[A0_INDEX, :] = cov[:, A0_INDEX] = 0.0

    def dln(h: float, i: int | None) -> float:
        phi = phi0.copy()
        if i is not None:
            phi[i] += h
        return (math.log(max(life(k + (h if i is None else 0.0), phi), 1e-30)) - math.log(centre)) / h

    grad = np.array([dln(1e-2 * math.sqrt(cov[i, i]), i) if cov[i, i] > 0 else 0.0 for i in range(phi0.size)])
    if not np.all(np.isfinite(grad)):
        # a hundredth of a parameter's sd already takes the life to no wear or to the limit: no linear interval
        return float(centre), 0.0, math.inf
    var = float(grad @ cov @ grad)
    if k_sd > 0:
        term = dln(1e-2 * k_sd, None) * k_sd
        var += term * term      # a product overflows to inf, a float ** 2 would raise
    spread = z * math.sqrt(max(var, 0.0))
    if not spread < _LN_FLOAT_MAX:
        # ln(life) spread beyond what a float holds (or NaN): the interval is (0, inf), never an OverflowError
        return float(centre), 0.0, math.inf
    return float(centre), float(centre * math.exp(-spread)), float(centre * math.exp(spread))


def lubrication_schedule(e: EffectParameters, wear: EffectWear, now_ns: int | None, dln_b: float) -> dict | None:
    """The relubrication schedule from now (:func:`wear_time_s`; registry.RELUBRICATION.forecast_schedule at the
    present time since the last relubrication). None without the effect or before any sample."""
    if now_ns is None:
        return None
    now_s = np.array([now_ns * 1e-9])
    tau = float(time_since_relubrication_s(e, now_s, wear.relubrication_base_s(now_s))[0])
    return RELUBRICATION.forecast_schedule(e, tau, dln_b)


def schedule_tuple(lub: dict | None, growth: float, window_scale: float = 1.0) -> tuple | None:
    """A :func:`lubrication_schedule` as :func:`wear_time_s` takes it, for the file's b = ``growth`` (the
    window's mean multiplier scaled by ``window_scale``: b moved in the interval)."""
    if lub is None:
        return None
    return growth * lub["growth_per_unit"], lub["tau_now_s"], lub["interval_s"], lub["window_mean"] * window_scale
