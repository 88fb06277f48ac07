"""Life-test statistics of rolling guides: interval-censored failure mileages from periodic inspection and the
Weibull maximum-likelihood fit with confidence intervals on the shape, scale and B10 life (seed 004 Sec. 3.2:
periodic (5 km) inspection and the equal-spacing estimate of failure mileages inside an inspection interval).

Pure numpy/scipy, no ROS, no I/O. Lives in km.
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from guide_health.models.rolling.rating_life import RATING_RELIABILITY, checked_positive


def equal_spacing_lives_km(lower_km: Iterable[float], upper_km: Iterable[float]) -> np.ndarray:
    """Seed 004 Sec. 3.2 equal-spacing estimate of failure mileages inside inspection intervals [km].

    The l_j specimens found failed at the inspection L_j (interval (L_{j-1}, L_j]) are spread evenly:
    L_jm = L_{j-1} + m (L_j - L_{j-1}) / (l_j + 1), m = 1..l_j (the seed's formula is an image missing from
    its text; this is the usual equal-spacing rule for periodic-inspection life data). Rows with the same
    (lower, upper) form one interval, ranked m = 1, 2, ... in input order. Suspended rows (upper = inf) and
    exact rows (lower == upper) are returned unchanged as nan and as the exact value respectively.
    Output is aligned with the input rows.
    """
    lo = np.asarray(list(lower_km) if not isinstance(lower_km, np.ndarray) else lower_km, dtype=float)
    up = np.asarray(list(upper_km) if not isinstance(upper_km, np.ndarray) else upper_km, dtype=float)
    _check_intervals(lo, up)
    out = np.full(lo.shape, np.nan)
    groups: dict[tuple[float, float], list[int]] = {}
    for i, (a, b) in enumerate(zip(lo, up)):
        if np.isinf(b):
            continue
        if a == b:
            out[i] = a
            continue
        groups.setdefault((float(a), float(b)), []).append(i)
    for (a, b), idx in groups.items():
        n = len(idx)
        for m, i in enumerate(idx, start=1):
            out[i] = a + m * (b - a) / (n + 1)
    return out


def intervals_from_index(failure_interval: Iterable[int], interval_km: float) -> tuple[np.ndarray, np.ndarray]:
    """Inspection-interval index j (1-based) -> (L_{j-1}, L_j] = ((j-1) I, j I] [km] (seed 004 Sec. 3.2)."""
    interval_km = checked_positive("inspection interval", interval_km)
    j = np.asarray(list(failure_interval), dtype=float)
    if np.any(~np.isfinite(j)) or np.any(j < 1) or np.any(j != np.round(j)):
        raise ValueError("failure_interval must be integers >= 1")
    return (j - 1) * interval_km, j * interval_km


def _check_intervals(lo: np.ndarray, up: np.ndarray) -> None:
    if lo.shape != up.shape or lo.ndim != 1:
        raise ValueError("lower and upper need the same number of rows")
    if lo.size == 0:
        raise ValueError("no failure data")
    if np.any(np.isnan(lo)) or np.any(np.isnan(up)) or np.any(np.isinf(lo)):
        raise ValueError("interval ends must be numbers (upper may be inf for a suspension)")
    if np.any(lo < 0) or np.any(up < lo):
        raise ValueError("intervals need 0 <= lower <= upper")
    if np.any((up == lo) & (lo == 0)):
        raise ValueError("an exact failure at 0 km is not a valid life")


class _WeibullLogLik:
    """Log-likelihood of (log beta, log eta) for interval/right-censored/exact Weibull data (weights w).

    Interval (l, u]: log[F(u) - F(l)] = -H(l) + log(1 - exp(-(H(u) - H(l)))), H(t) = (t / eta)^beta;
    right-censored (u = inf): -H(l); exact (l == u): log f(l). Logs of the data are precomputed once.
    """

    def __init__(self, lo: np.ndarray, up: np.ndarray, w: np.ndarray) -> None:
        exact = lo == up
        interval = ~exact & np.isfinite(up)
        susp = np.isinf(up)
        with np.errstate(divide="ignore"):
            self.i_logl = np.log(lo[interval])              # -inf at l = 0 (H = 0 there)
        self.i_logl0 = np.where(np.isfinite(self.i_logl), self.i_logl, 0.0)
        self.i_logu = np.log(up[interval])
        self.i_w = w[interval]
        self.s_logl = np.log(lo[susp & (lo > 0)])          # suspensions at 0 km carry no information
        self.s_w = w[susp & (lo > 0)]
        self.e_logt = np.log(lo[exact])
        self.e_w = w[exact]
        self.e_sw = float(self.e_w.sum())
        self.e_swlogt = float(self.e_w @ self.e_logt)

    def __call__(self, theta, grad: bool = False):
        lb, le = float(theta[0]), float(theta[1])
        if not (abs(lb) < 30.0 and abs(le) < 100.0):        # beta or eta absurd: outside the model
            return (-math.inf, np.zeros(2)) if grad else -math.inf
        beta = math.exp(lb)
        ll = g0 = g1 = 0.0
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            if self.i_w.size:
                hl = np.exp(beta * (self.i_logl - le))      # 0 at l = 0
                xu = self.i_logu - le
                hu = np.exp(beta * xu)
                d = hu - hl
                q = -np.expm1(-d)                           # (S(l) - S(u)) / S(l)
                ll += float(self.i_w @ (np.log(q) - hl))
                if grad:
                    hue = hu * np.exp(-d)                   # H(u) S(u) / S(l), -> 0 as H(u) -> inf
                    hue = np.where(np.isfinite(hue), hue, 0.0)
                    a = self.i_w / q
                    # dH/dlog(beta) = beta H x, dH/dlog(eta) = -beta H (H x -> 0 at t = 0)
                    g0 += beta * float(a @ (hue * xu - hl * (self.i_logl0 - le)))
                    g1 += beta * float(a @ (hl - hue))
            if self.s_w.size:
                xs = self.s_logl - le
                hs = np.exp(beta * xs)
                ll -= float(self.s_w @ hs)
                if grad:
                    g0 -= beta * float(self.s_w @ (hs * xs))
                    g1 += beta * float(self.s_w @ hs)
            if self.e_w.size:
                x = self.e_logt - le
                h = np.exp(beta * x)
                ll += self.e_sw * lb - self.e_swlogt + float(self.e_w @ (beta * x - h))
                if grad:
                    g0 += float(self.e_w @ (1.0 + beta * x * (1.0 - h)))
                    g1 += beta * float(self.e_w @ (h - 1.0))
        if not math.isfinite(ll):
            ll = -math.inf
        return (ll, np.array([g0, g1])) if grad else ll


def _weibull_loglik(theta: np.ndarray, lo: np.ndarray, up: np.ndarray, w: np.ndarray, grad: bool = False):
    """Weibull log-likelihood of (log beta, log eta) (see :class:`_WeibullLogLik`)."""
    return _WeibullLogLik(lo, up, w)(theta, grad)


@dataclass
class WeibullFit:
    """Weibull fit of (interval-censored) lives; scale and lives in km."""
    shape: float                          # beta
    scale_km: float                       # eta
    shape_ci: tuple[float, float]
    scale_ci_km: tuple[float, float]
    b_life_km: float                      # life at `reliability` (B10 for 0.90)
    b_life_ci_km: tuple[float, float]
    reliability: float
    confidence: float
    ci_method: str                        # "profile" (likelihood ratio) or "wald" (delta method, log scale)
    log_likelihood: float
    n: float                              # specimens (sum of weights)
    failures: float                       # specimens not suspended
    cov_log: np.ndarray = field(repr=False)  # covariance of (log beta, log eta), observed information

    @property
    def b10_km(self) -> float:
        """B_R life [km] (B10 for the default reliability 0.90)."""
        return self.b_life_km

    @property
    def b10_ci_km(self) -> tuple[float, float]:
        return self.b_life_ci_km


def _exp(v: float) -> float:
    """exp that saturates to inf (or 0) instead of raising, for interval ends."""
    return math.exp(v) if v < 700.0 else math.inf


def _b_const(reliability: float) -> float:
    return math.log(-math.log(reliability))   # log B_R = log eta + c / beta


def _numerical_hessian(fun_grad, theta: np.ndarray, step: float = 1e-5) -> np.ndarray:
    """Central differences of the analytic gradient, symmetrised."""
    h = np.zeros((2, 2))
    for i in range(2):
        e = np.zeros(2)
        e[i] = step
        h[:, i] = (fun_grad(theta + e)[1] - fun_grad(theta - e)[1]) / (2 * step)
    return 0.5 * (h + h.T)


def fit_weibull(lower_km: Iterable[float], upper_km: Iterable[float], weights: Iterable[float] | None = None,
                confidence: float = 0.90, reliability: float = RATING_RELIABILITY,
                ci_method: str = "profile") -> WeibullFit:
    """Weibull maximum-likelihood fit of interval-censored lives (seed 004 Sec. 3.2 periodic inspection).

    Likelihood prod [F(u_i) - F(l_i)] (right-censored rows: u = inf, 1 - F(l); exact rows l == u: density),
    F(t) = 1 - exp(-(t/eta)^beta), maximised over (log beta, log eta) with BFGS and the analytic gradient.
    Covariance from the observed information (numerical Hessian of the gradient). Confidence intervals:
    ``"wald"`` = normal on the log scale (delta method for log B_R = log eta + ln(-ln R) / beta);
    ``"profile"`` = likelihood ratio, 2 (l_max - l_profile) <= chi2_1(confidence).
    """
    lo, up, w, failed = _fit_rows(lower_km, upper_km, weights, confidence, reliability, ci_method)
    loglik = _WeibullLogLik(lo, up, w)
    theta, ll_max = _maximise_log_likelihood(loglik, _start_point(lo, up, w, failed), float(w.sum()))
    cov = _observed_covariance(loglik, theta)

    c = _b_const(reliability)
    lb, le = float(theta[0]), float(theta[1])
    beta = math.exp(lb)
    if not 1e-2 < beta < 1e3:
        raise ValueError(f"Weibull shape runs off to {beta:.3g}: the data do not determine it "
                         "(e.g. all failures in one or two inspection intervals)")
    log_b = le + c / beta
    se_lb, se_le, se_b = _log_scale_standard_errors(cov, c, beta)
    if ci_method == "wald":
        z = float(stats.norm.ppf(0.5 + confidence / 2))
        shape_ci = (_exp(lb - z * se_lb), _exp(lb + z * se_lb))
        scale_ci = (_exp(le - z * se_le), _exp(le + z * se_le))
        b_ci = (_exp(log_b - z * se_b), _exp(log_b + z * se_b))
    else:
        shape_ci, scale_ci, b_ci = _profile_intervals(loglik, ll_max, confidence, c, (lb, le, log_b),
                                                      (se_lb, se_le, se_b))
    return WeibullFit(shape=beta, scale_km=math.exp(le), shape_ci=tuple(shape_ci),
                      scale_ci_km=tuple(scale_ci), b_life_km=math.exp(log_b), b_life_ci_km=tuple(b_ci),
                      reliability=reliability, confidence=confidence, ci_method=ci_method,
                      log_likelihood=float(ll_max), n=float(w.sum()), failures=float(w[failed].sum()),
                      cov_log=cov)


def _fit_rows(lower_km, upper_km, weights, confidence: float, reliability: float,
              ci_method: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Checked (lower, upper, weight) rows of :func:`fit_weibull` without the zero-weight rows, and the mask
    of the failed (not suspended) rows; ValueError on bad input or fewer than two failures."""
    lo = np.asarray(list(lower_km) if not isinstance(lower_km, np.ndarray) else lower_km, dtype=float)
    up = np.asarray(list(upper_km) if not isinstance(upper_km, np.ndarray) else upper_km, dtype=float)
    _check_intervals(lo, up)
    w = np.ones_like(lo) if weights is None else np.asarray(list(weights), dtype=float)
    if w.shape != lo.shape or np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights (counts) must be finite, >= 0, one per row")
    if not 0 < confidence < 1:
        raise ValueError("confidence must be in (0, 1)")
    if not 0 < reliability < 1:
        raise ValueError("reliability must be in (0, 1)")
    if ci_method not in ("profile", "wald"):
        raise ValueError("ci_method must be 'profile' or 'wald'")
    keep = w > 0
    lo, up, w = lo[keep], up[keep], w[keep]
    failed = np.isfinite(up)
    if w[failed].sum() < 2:
        raise ValueError("a Weibull fit needs at least two failures")
    return lo, up, w, failed


def _start_point(lo: np.ndarray, up: np.ndarray, w: np.ndarray, failed: np.ndarray) -> np.ndarray:
    """Start (log beta, log eta): moments of log(midpoint) of the failures (sd of ln T = pi / (beta sqrt 6))."""
    mid = np.where(lo[failed] == up[failed], lo[failed], 0.5 * (lo[failed] + up[failed]))
    lm = np.log(mid)
    wf = w[failed]
    mean = float(np.average(lm, weights=wf))
    sd = math.sqrt(float(np.average((lm - mean) ** 2, weights=wf)))
    beta0 = min(max(math.pi / math.sqrt(6) / sd, 0.3), 20.0) if sd > 0 else 5.0
    return np.array([math.log(beta0), mean + 0.5772 / beta0])


def _maximise_log_likelihood(loglik: _WeibullLogLik, theta0: np.ndarray,
                             total_weight: float) -> tuple[np.ndarray, float]:
    """(theta, log-likelihood) at the maximum: BFGS with the analytic gradient, Nelder-Mead then BFGS again
    when BFGS stops short; ValueError when the gradient at the end is not ~0."""
    def negfg(th):
        ll, g = loglik(th, grad=True)
        if not math.isfinite(ll):
            return 1e300, np.zeros(2)
        return -ll, -g

    res = optimize.minimize(negfg, theta0, jac=True, method="BFGS", options={"gtol": 1e-8})
    theta = res.x
    if not (res.success or np.max(np.abs(negfg(theta)[1])) < 1e-4):
        res2 = optimize.minimize(lambda th: negfg(th)[0], theta, method="Nelder-Mead",
                                 options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
        theta = optimize.minimize(negfg, res2.x, jac=True, method="BFGS").x
    ll_max, g_end = loglik(theta, grad=True)
    if not (math.isfinite(ll_max) and np.max(np.abs(g_end)) < 1e-4 * max(1.0, total_weight)):
        raise ValueError("Weibull fit did not converge (the data may not determine beta and eta)")
    return theta, ll_max


def _observed_covariance(loglik: _WeibullLogLik, theta: np.ndarray) -> np.ndarray:
    """Covariance of (log beta, log eta): inverse of the observed information (numerical Hessian of the
    analytic gradient); ValueError when the likelihood is flat."""
    info = -_numerical_hessian(lambda th: loglik(th, grad=True), theta)
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.nan)
    if not (np.all(np.isfinite(cov)) and cov[0, 0] > 0 and cov[1, 1] > 0):
        raise ValueError("Weibull fit is not identifiable from these data (flat likelihood)")
    return cov


def _log_scale_standard_errors(cov: np.ndarray, c: float, beta: float) -> tuple[float, float, float]:
    """Standard errors of log beta, log eta and log B_R (delta method); ValueError when they are so wide that
    the maximum is not determined."""
    # delta method: d logB / d log beta = -c / beta, d logB / d log eta = 1
    grad_b = np.array([-c / beta, 1.0])
    se_lb = math.sqrt(cov[0, 0])
    se_le = math.sqrt(cov[1, 1])
    if se_lb > 5.0 or se_le > 20.0:     # interval spanning e^(+-8) or more: the maximum is not determined
        raise ValueError("Weibull fit is not identifiable from these data (flat likelihood, e.g. all "
                         "failures in one or two inspection intervals)")
    return se_lb, se_le, math.sqrt(float(grad_b @ cov @ grad_b))


def _profile_intervals(loglik: _WeibullLogLik, ll_max: float, confidence: float, c: float,
                       estimates: tuple[float, float, float], standard_errors: tuple[float, float, float]
                       ) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """Likelihood-ratio intervals of beta, eta and B_R from the log-scale estimates (log beta, log eta,
    log B_R) and their standard errors (used to bracket the interval ends)."""
    lb, le, log_b = estimates
    se_lb, se_le, se_b = standard_errors
    crit = float(stats.chi2.ppf(confidence, 1))
    shape_ci = _profile_ci(loglik, ll_max, crit, lb, le, se_lb, lambda psi, nu: (psi, nu),
                           lambda psi, nu: (0.0, 1.0))
    scale_ci = _profile_ci(loglik, ll_max, crit, le, lb, se_le, lambda psi, nu: (nu, psi),
                           lambda psi, nu: (1.0, 0.0))
    # (log beta, log B_R): log eta = log B_R - c / beta
    b_ci = _profile_ci(loglik, ll_max, crit, log_b, lb, se_b,
                       lambda psi, nu: (nu, psi - c * math.exp(-nu)),
                       lambda psi, nu: (1.0, c * math.exp(-nu)))
    return tuple(tuple(_exp(v) for v in ci) for ci in (shape_ci, scale_ci, b_ci))


def _profile_ci(ll_fn, ll_max: float, crit: float, psi_hat: float, nu_hat: float, se_psi: float,
                to_theta, dtheta_dnu) -> tuple[float, float]:
    """Likelihood-ratio interval of psi (log scale): {psi: 2 (ll_max - max_nu ll(psi, nu)) <= crit}.

    theta = to_theta(psi, nu) maps (parameter of interest, nuisance) to (log beta, log eta); the nuisance
    is maximised by a secant search on d ll / d nu (analytic gradient), with Brent as fallback.
    """
    nu_start = [nu_hat]

    def d_ll(psi: float, nu: float) -> tuple[float, float]:
        ll, g = ll_fn(np.array(to_theta(psi, nu)), grad=True)
        return float(g @ np.asarray(dtheta_dnu(psi, nu))), ll

    def max_nu(psi: float) -> tuple[float, float]:
        x0 = nu_start[0]
        f0, ll0 = d_ll(psi, x0)
        if math.isfinite(ll0) and math.isfinite(f0):
            x1 = x0 + math.copysign(1e-3, f0)
            f1, ll1 = d_ll(psi, x1)
            for _ in range(40):
                if not (math.isfinite(ll1) and math.isfinite(f1)) or f1 == f0:
                    break
                step = -f1 * (x1 - x0) / (f1 - f0)
                step = max(-1.0, min(1.0, step))
                x0, f0 = x1, f1
                x1 = x1 + step
                f1, ll1 = d_ll(psi, x1)
                if abs(step) < 1e-9 or abs(f1) < 1e-9:
                    if math.isfinite(ll1) and ll1 >= ll0 - 1e-9:
                        return x1, ll1
                    break

        def neg(nu):
            v = ll_fn(np.array(to_theta(psi, nu)))
            return -v if math.isfinite(v) else 1e300
        try:
            r = optimize.minimize_scalar(neg, bracket=(nu_start[0] - 0.05, nu_start[0] + 0.05),
                                         method="brent", options={"xtol": 1e-8})
        except (RuntimeError, ValueError, OverflowError):
            r = optimize.minimize_scalar(neg, bounds=(nu_hat - 20.0, nu_hat + 20.0), method="bounded",
                                         options={"xatol": 1e-8})
        return float(r.x), -float(r.fun)

    def deficit(psi: float) -> float:
        nu, ll = max_nu(psi)
        if math.isfinite(ll):
            nu_start[0] = nu
        return 2.0 * (ll_max - ll) - crit

    z = math.sqrt(crit)
    ends = []
    for sign in (-1.0, 1.0):
        # bracket the root around the Wald end psi_hat +- z se, widening outwards when needed
        nu_start[0] = nu_hat
        step = max(z * se_psi, 1e-6)
        inner, outer = psi_hat, psi_hat + sign * 0.8 * step
        if deficit(outer) < 0:
            inner, outer = outer, psi_hat + sign * 1.25 * step
        found = False
        for _ in range(40):
            if abs(outer - psi_hat) > 25.0:      # likelihood flat this way: unbounded interval
                break
            if deficit(outer) > 0:
                found = True
                break
            inner, outer = outer, outer + sign * step
            step *= 1.6
        if not found:
            ends.append(sign * math.inf)
            continue
        nu_start[0] = nu_hat
        ends.append(optimize.brentq(deficit, min(inner, outer), max(inner, outer), xtol=1e-6, rtol=1e-9))
    return ends[0], ends[1]


def weibull_interval_sample(rng: np.random.Generator, n: int, shape: float, scale_km: float,
                            interval_km: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulated periodic-inspection test: n Weibull lives, each reported as the inspection interval
    ((j-1) I, j I] it fell in (seed 004 Sec. 3.2). Returns (true lives, lower, upper) [km]."""
    t = scale_km * rng.weibull(shape, size=n)
    j = np.floor(t / interval_km) + 1.0
    return t, (j - 1.0) * interval_km, j * interval_km
