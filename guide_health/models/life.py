"""Rolling-guide fatigue life: rating life, Miner consumption over a varying duty, and the rated dynamic
load C from (accelerated) life tests with interval-censored failure mileages.

Pure numpy/scipy, no ROS, no I/O. Units: N for loads, m for travel fed to the accumulator, km for lives
(every name that holds km says so). Sources:

* ISO 14728-1 (linear motion rolling bearings, dynamic load ratings and rating life):
  L10 = (C / P)^p x 100 km, p = 3 for balls, 10/3 for rollers.
* Catalogue form used by most ball-guide makers and by seed 004 (Eq. 4, its ref. [9]):
  L = (fh ft fc C / (fw P))^p x 50 km, fh hardness, ft temperature, fc contact (seed 004 calls it the
  lubrication factor), fw load/impact factor.
* Seed 004 Eq. 5: C back-calculated from a test life; seed 004 Sec. 3.2: periodic (5 km) inspection and the
  equal-spacing estimate of failure mileages inside an inspection interval.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np
from scipy import optimize, stats

BALL = "ball"
ROLLER = "roller"
ISO_RATING_DISTANCE_KM = 100.0        # ISO 14728-1 reference travel
CATALOGUE_RATING_DISTANCE_KM = 50.0   # most ball-guide catalogues and seed 004
RATING_RELIABILITY = 0.90             # rating life = L10 (seed 004 Sec. 0: 90 % reach the rated travel)

LifeFactors = Sequence[float]   # (fh, ft, fc, fw), dimensionless


# --------------------------------------------------------------------------------------------------
# Rating life (ISO 14728-1, catalogue form)
# --------------------------------------------------------------------------------------------------

def life_exponent(element: str) -> float:
    """Load-life exponent p: 3 for balls, 10/3 for rollers (ISO 14728-1)."""
    if element == BALL:
        return 3.0
    if element == ROLLER:
        return 10.0 / 3.0
    raise ValueError(f"rolling element must be 'ball' or 'roller', got {element!r}")


def _factors(life_factors: LifeFactors | None) -> tuple[float, float, float, float]:
    if life_factors is None:
        return 1.0, 1.0, 1.0, 1.0
    f = tuple(float(x) for x in life_factors)
    if len(f) != 4:
        raise ValueError(f"life_factors must be (fh, ft, fc, fw), got {len(f)} values")
    if not all(math.isfinite(x) and x > 0 for x in f):
        raise ValueError(f"life_factors must be finite and > 0, got {f}")
    return f  # type: ignore[return-value]


def factor_ratio(life_factors: LifeFactors | None) -> float:
    """K = fh ft fc / fw [-]: the effective rating is K C (catalogue form, seed 004 Eq. 4)."""
    fh, ft, fc, fw = _factors(life_factors)
    return fh * ft * fc / fw


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return value


def rating_life_km(c_n: float, load_n: float | np.ndarray, element: str = BALL,
                   rating_distance_km: float = CATALOGUE_RATING_DISTANCE_KM,
                   life_factors: LifeFactors | None = None,
                   exponent: float | None = None) -> float | np.ndarray:
    """Rating life L [km] = (fh ft fc C / (fw P))^p x L_ref (ISO 14728-1 with L_ref = 100 km; catalogue
    form with L_ref = 50 km, seed 004 Eq. 4).

    ``c_n`` is C [N] *for the same* ``rating_distance_km``; ``load_n`` the equivalent load P [N] (its absolute
    value is used; P = 0 gives an infinite life). ``exponent`` overrides p (default from ``element``).
    Accepts an array of loads and returns an array.
    """
    c_n = _check_positive("dynamic load rating C", c_n)
    l_ref = _check_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    k = factor_ratio(life_factors)
    load = np.abs(np.asarray(load_n, dtype=float))
    with np.errstate(divide="ignore"):
        life = l_ref * (k * c_n / load) ** p
    return float(life) if life.ndim == 0 else life


def load_for_life_n(c_n: float, life_km: float, element: str = BALL,
                    rating_distance_km: float = CATALOGUE_RATING_DISTANCE_KM,
                    life_factors: LifeFactors | None = None, exponent: float | None = None) -> float:
    """Equivalent load P [N] that gives rating life ``life_km``: P = K C (L_ref / L)^(1/p) (inverse of
    ISO 14728-1 / seed 004 Eq. 4)."""
    c_n = _check_positive("dynamic load rating C", c_n)
    life_km = _check_positive("life", life_km)
    l_ref = _check_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    return factor_ratio(life_factors) * c_n * (l_ref / life_km) ** (1.0 / p)


def convert_rating_n(c_n: float, from_distance_km: float, to_distance_km: float, element: str = BALL,
                     exponent: float | None = None) -> float:
    """C for another reference travel [N]: C_to = C_from (L_from / L_to)^(1/p) (same life curve, ISO 14728-1).

    50 -> 100 km: C_100 = C_50 / 2^(1/3) = 0.7937 C_50 for balls, C_50 (1/2)^(3/10) = 0.8123 C_50 for rollers.
    """
    c_n = _check_positive("dynamic load rating C", c_n)
    a = _check_positive("rating distance", from_distance_km)
    b = _check_positive("rating distance", to_distance_km)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    return c_n * (a / b) ** (1.0 / p)


# --------------------------------------------------------------------------------------------------
# C from a life test (seed 004 Eq. 5)
# --------------------------------------------------------------------------------------------------

def c_ratio_from_life(load_fraction: float | np.ndarray, life_km: float | np.ndarray,
                      rating_distance_km: float = CATALOGUE_RATING_DISTANCE_KM, element: str = BALL,
                      exponent: float | None = None,
                      life_factors: LifeFactors | None = None) -> float | np.ndarray:
    """C_test / C [-] from a test at load F = ``load_fraction`` x C that lasted ``life_km`` (seed 004 Eq. 5):

        C_test / C = (fw / (fh ft fc)) (F / C) (L / L_ref)^(1/p)

    Seed 004 Sec. 4.2: ball, F = 0.30 C, L = 450 km, L_ref = 50 km, p = 3 -> 0.624; roller, F = C, L = 62 km
    -> 0.852 only with L_ref = 100 km and p = 3 (ISO's p = 10/3 gives 0.866). ``life_km`` should be an L10
    estimate (e.g. a Weibull B10); a single specimen's life is nearer its median, see
    :func:`median_to_b_life`. Accepts arrays (e.g. confidence-interval ends).
    """
    l_ref = _check_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    frac = np.asarray(load_fraction, dtype=float)
    life = np.asarray(life_km, dtype=float)
    if np.any(~np.isfinite(frac)) or np.any(frac <= 0):
        raise ValueError("load fraction F/C must be finite and > 0")
    if np.any(np.isnan(life)) or np.any(life < 0):
        raise ValueError("test life must be >= 0 km")
    out = frac * (life / l_ref) ** (1.0 / p) / factor_ratio(life_factors)
    return float(out) if out.ndim == 0 else out


def median_to_b_life(life_km: float, shape: float, reliability: float = RATING_RELIABILITY) -> float:
    """Weibull life at ``reliability`` [km] from a median life: L_R = L_50 (ln(1/R) / ln 2)^(1/beta).

    A single failed specimen estimates the median (median rank of 1 of 1 is 0.5), not L10.
    """
    life_km = _check_positive("life", life_km)
    shape = _check_positive("Weibull shape", shape)
    if not 0 < reliability < 1:
        raise ValueError("reliability must be in (0, 1)")
    return life_km * (math.log(1.0 / reliability) / math.log(2.0)) ** (1.0 / shape)


# --------------------------------------------------------------------------------------------------
# Equivalent load and Miner's rule over a varying duty
# --------------------------------------------------------------------------------------------------

@dataclass
class FatigueSummary:
    """Fatigue consumption of a guide (keys of the ``<joint> fatigue`` diagnostics)."""
    travel_km: float
    equivalent_load_n: float          # p-th power mean over travel, whole history
    rating_life_km: float             # L at equivalent_load_n
    life_used_fraction: float         # Miner: sum ds_i / L(F_i) = travel / L(P_eq)
    remaining_life_km: float          # (1 - used) x L(P_duty), P_duty = recent (or whole-history) P_eq
    duty_load_n: float                # load used for remaining_life_km
    exponent: float


def _summary(s0_m: float, sp: float, r0_m: float, rp: float, c_n: float, p: float, l_ref_km: float,
             k: float, recent: bool) -> FatigueSummary:
    travel_km = s0_m / 1000.0
    nan = float("nan")
    if s0_m > 0:
        p_eq = (sp / s0_m) ** (1.0 / p)
        life = l_ref_km * (k * c_n / p_eq) ** p if p_eq > 0 else math.inf
    else:
        p_eq, life = nan, nan
    used = (sp / 1000.0) / l_ref_km * (1.0 / (k * c_n)) ** p
    if recent and r0_m > 0:
        p_duty = (rp / r0_m) ** (1.0 / p)
    else:
        p_duty = p_eq
    if math.isnan(p_duty):
        remaining = nan
    elif p_duty > 0:
        remaining = max(0.0, 1.0 - used) * l_ref_km * (k * c_n / p_duty) ** p
    else:
        remaining = math.inf
    return FatigueSummary(travel_km=travel_km, equivalent_load_n=p_eq, rating_life_km=life,
                          life_used_fraction=used, remaining_life_km=remaining, duty_load_n=p_duty,
                          exponent=p)


def equivalent_load_n(travel_m: np.ndarray, load_n: np.ndarray, element: str = BALL,
                      exponent: float | None = None) -> float:
    """P_eq [N] = (sum |F_i|^p ds_i / sum ds_i)^(1/p) (ISO 14728-1 mean load over travel)."""
    ds, f = _duty_arrays(travel_m, load_n)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    s0 = float(ds.sum())
    return float((float((ds * f ** p).sum()) / s0) ** (1.0 / p)) if s0 > 0 else float("nan")


def _duty_arrays(travel_m, load_n) -> tuple[np.ndarray, np.ndarray]:
    ds = np.asarray(travel_m, dtype=float).ravel()
    f = np.abs(np.asarray(load_n, dtype=float).ravel())
    if ds.shape != f.shape:
        raise ValueError("travel and load need the same number of samples")
    if not (np.all(np.isfinite(ds)) and np.all(np.isfinite(f))):
        raise ValueError("travel and load samples must be finite")
    if np.any(ds < 0):
        raise ValueError("travel increments must be >= 0 (use |dx|)")
    return ds, f


def miner_summary(travel_m: np.ndarray, load_n: np.ndarray, c_n: float, element: str = BALL,
                  rating_distance_km: float = CATALOGUE_RATING_DISTANCE_KM,
                  life_factors: LifeFactors | None = None, recent_window_m: float = 0.0,
                  exponent: float | None = None) -> FatigueSummary:
    """Vectorised fatigue consumption of a duty given as travel increments ds_i [m] at loads F_i [N].

    P_eq = (sum |F_i|^p ds_i / sum ds_i)^(1/p); Miner: used = sum ds_i / L(F_i) = travel / L(P_eq)
    (ISO 14728-1 life with seed 004 Eq. 4 factors). ``recent_window_m`` > 0: the remaining life uses the
    duty of the recent travel, weighted by exp(-(travel since the sample) / window); 0 uses the whole history.
    Gives the same numbers as :class:`FatigueAccumulator` fed sample by sample.
    """
    c_n = _check_positive("dynamic load rating C", c_n)
    l_ref = _check_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else _check_positive("life exponent", exponent)
    k = factor_ratio(life_factors)
    window = float(recent_window_m)
    if not (math.isfinite(window) and window >= 0):
        raise ValueError("recent window must be >= 0 m")
    ds, f = _duty_arrays(travel_m, load_n)
    fp = ds * f ** p
    s0, sp = float(ds.sum()), float(fp.sum())
    r0 = rp = 0.0
    if window > 0 and ds.size:
        cum = np.cumsum(ds)
        w = np.exp(-(cum[-1] - cum) / window)
        r0, rp = float((w * ds).sum()), float((w * fp).sum())
    return _summary(s0, sp, r0, rp, c_n, p, l_ref, k, window > 0)


class FatigueAccumulator:
    """O(1)-per-sample Miner accumulator for a live node (ISO 14728-1 life, seed 004 Eq. 4 factors).

    Keeps S0 = sum ds [m] and Sp = sum ds |F|^p [m N^p] (and, with ``recent_window_m`` > 0, the same sums
    with exponential forgetting over travel for the current duty). ``state()``/``from_state()`` round-trip
    the sums for persistence.
    """

    STATE_VERSION = 1

    def __init__(self, dynamic_load_rating_n: float, rolling_element: str = BALL,
                 rating_distance_km: float = CATALOGUE_RATING_DISTANCE_KM,
                 life_factors: LifeFactors | None = None, recent_window_m: float = 0.0,
                 exponent: float | None = None) -> None:
        self.c_n = _check_positive("dynamic load rating C", dynamic_load_rating_n)
        self.element = rolling_element
        self.exponent = life_exponent(rolling_element) if exponent is None else _check_positive(
            "life exponent", exponent)
        self.rating_distance_km = _check_positive("rating distance", rating_distance_km)
        self.life_factors = _factors(life_factors)
        window = float(recent_window_m)
        if not (math.isfinite(window) and window >= 0):
            raise ValueError("recent window must be >= 0 m")
        self.recent_window_m = window
        self._k = factor_ratio(self.life_factors)
        self._s0 = 0.0
        self._sp = 0.0
        self._r0 = 0.0
        self._rp = 0.0
        self.samples = 0

    def add(self, travel_m: float, load_n: float) -> None:
        """Add a travel increment ds [m] (>= 0) run at load F [N] (|F| is used)."""
        ds = float(travel_m)
        f = abs(float(load_n))
        if not (math.isfinite(ds) and math.isfinite(f)):
            raise ValueError("travel and load must be finite")
        if ds < 0:
            raise ValueError("travel increment must be >= 0 (use |dx|)")
        fp = ds * f ** self.exponent
        self._s0 += ds
        self._sp += fp
        if self.recent_window_m > 0:
            w = math.exp(-ds / self.recent_window_m)
            self._r0 = self._r0 * w + ds
            self._rp = self._rp * w + fp
        self.samples += 1

    def summary(self) -> FatigueSummary:
        return _summary(self._s0, self._sp, self._r0, self._rp, self.c_n, self.exponent,
                        self.rating_distance_km, self._k, self.recent_window_m > 0)

    @property
    def travel_km(self) -> float:
        return self._s0 / 1000.0

    @property
    def equivalent_load_n(self) -> float:
        """P_eq [N] over the whole history (nan before any travel)."""
        return self.summary().equivalent_load_n

    @property
    def duty_load_n(self) -> float:
        """Equivalent load of the recent duty [N] (whole history when recent_window_m == 0)."""
        return self.summary().duty_load_n

    @property
    def rating_life_km(self) -> float:
        return self.summary().rating_life_km

    @property
    def life_used_fraction(self) -> float:
        return self.summary().life_used_fraction

    @property
    def remaining_life_km(self) -> float:
        return self.summary().remaining_life_km

    def diagnostics(self) -> dict[str, float]:
        """The ``<joint> fatigue`` KeyValues (INTERFACES.md)."""
        s = self.summary()
        return {"equivalent_load_n": s.equivalent_load_n, "rating_life_km": s.rating_life_km,
                "travel_km": s.travel_km, "life_used_fraction": s.life_used_fraction,
                "remaining_life_km": s.remaining_life_km}

    def state(self) -> dict:
        """Plain dict (JSON/YAML-able) of the sums and the parameters they were accumulated with."""
        return {"version": self.STATE_VERSION, "exponent": self.exponent, "travel_m": self._s0,
                "load_power_travel": self._sp, "recent_travel_m": self._r0,
                "recent_load_power_travel": self._rp, "samples": self.samples,
                "dynamic_load_rating_n": self.c_n, "rolling_element": self.element,
                "rating_distance_km": self.rating_distance_km, "life_factors": list(self.life_factors),
                "recent_window_m": self.recent_window_m}

    @classmethod
    def from_state(cls, state: dict, **overrides) -> "FatigueAccumulator":
        """Rebuild from :meth:`state`. ``overrides`` (constructor keywords, e.g. a re-rated
        ``dynamic_load_rating_n``) replace stored parameters; the exponent must stay the same because the
        stored sums are sums of |F|^p."""
        if not isinstance(state, dict) or state.get("version") != cls.STATE_VERSION:
            raise ValueError("not a FatigueAccumulator state (version mismatch)")
        kwargs = {"dynamic_load_rating_n": state["dynamic_load_rating_n"],
                  "rolling_element": state["rolling_element"],
                  "rating_distance_km": state["rating_distance_km"],
                  "life_factors": state["life_factors"], "recent_window_m": state["recent_window_m"],
                  "exponent": state["exponent"]}
        if "rolling_element" in overrides and "exponent" not in overrides:
            kwargs["exponent"] = None
        kwargs.update(overrides)
        acc = cls(**kwargs)
        if not math.isclose(acc.exponent, float(state["exponent"]), rel_tol=0, abs_tol=1e-12):
            raise ValueError(f"stored sums use exponent {state['exponent']}, not {acc.exponent}")
        sums = [float(state[k]) for k in ("travel_m", "load_power_travel", "recent_travel_m",
                                          "recent_load_power_travel")]
        if not all(math.isfinite(v) and v >= 0 for v in sums):
            raise ValueError("stored fatigue sums must be finite and >= 0")
        acc._s0, acc._sp, acc._r0, acc._rp = sums
        acc.samples = int(state.get("samples", 0))
        return acc


# --------------------------------------------------------------------------------------------------
# Interval-censored failure mileages (seed 004 Sec. 3.2) and Weibull maximum likelihood
# --------------------------------------------------------------------------------------------------

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
    interval_km = _check_positive("inspection interval", interval_km)
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

    # start: moments of log(midpoint) of the failures (sd of ln T = pi / (beta sqrt 6))
    mid = np.where(lo[failed] == up[failed], lo[failed], 0.5 * (lo[failed] + up[failed]))
    lm = np.log(mid)
    wf = w[failed]
    mean = float(np.average(lm, weights=wf))
    sd = math.sqrt(float(np.average((lm - mean) ** 2, weights=wf)))
    beta0 = min(max(math.pi / math.sqrt(6) / sd, 0.3), 20.0) if sd > 0 else 5.0
    theta0 = np.array([math.log(beta0), mean + 0.5772 / beta0])

    loglik = _WeibullLogLik(lo, up, w)

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
    if not (math.isfinite(ll_max) and np.max(np.abs(g_end)) < 1e-4 * max(1.0, float(w.sum()))):
        raise ValueError("Weibull fit did not converge (the data may not determine beta and eta)")
    info = -_numerical_hessian(lambda th: loglik(th, grad=True), theta)
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.nan)
    if not (np.all(np.isfinite(cov)) and cov[0, 0] > 0 and cov[1, 1] > 0):
        raise ValueError("Weibull fit is not identifiable from these data (flat likelihood)")

    c = _b_const(reliability)
    lb, le = float(theta[0]), float(theta[1])
    beta = math.exp(lb)
    if not 1e-2 < beta < 1e3:
        raise ValueError(f"Weibull shape runs off to {beta:.3g}: the data do not determine it "
                         "(e.g. all failures in one or two inspection intervals)")
    log_b = le + c / beta
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    # delta method: d logB / d log beta = -c / beta, d logB / d log eta = 1
    grad_b = np.array([-c / beta, 1.0])
    se_lb = math.sqrt(cov[0, 0])
    se_le = math.sqrt(cov[1, 1])
    if se_lb > 5.0 or se_le > 20.0:     # interval spanning e^(+-8) or more: the maximum is not determined
        raise ValueError("Weibull fit is not identifiable from these data (flat likelihood, e.g. all "
                         "failures in one or two inspection intervals)")
    se_b = math.sqrt(float(grad_b @ cov @ grad_b))

    if ci_method == "wald":
        shape_ci = (_exp(lb - z * se_lb), _exp(lb + z * se_lb))
        scale_ci = (_exp(le - z * se_le), _exp(le + z * se_le))
        b_ci = (_exp(log_b - z * se_b), _exp(log_b + z * se_b))
    else:
        crit = float(stats.chi2.ppf(confidence, 1))
        ll_fn = loglik
        shape_ci = _profile_ci(ll_fn, ll_max, crit, lb, le, se_lb, lambda psi, nu: (psi, nu),
                               lambda psi, nu: (0.0, 1.0))
        scale_ci = _profile_ci(ll_fn, ll_max, crit, le, lb, se_le, lambda psi, nu: (nu, psi),
                               lambda psi, nu: (1.0, 0.0))
        # (log beta, log B_R): log eta = log B_R - c / beta
        b_ci = _profile_ci(ll_fn, ll_max, crit, log_b, lb, se_b,
                           lambda psi, nu: (nu, psi - c * math.exp(-nu)),
                           lambda psi, nu: (1.0, c * math.exp(-nu)))
        shape_ci, scale_ci, b_ci = (tuple(_exp(v) for v in ci) for ci in (shape_ci, scale_ci, b_ci))
    return WeibullFit(shape=beta, scale_km=math.exp(le), shape_ci=tuple(shape_ci),
                      scale_ci_km=tuple(scale_ci), b_life_km=math.exp(log_b), b_life_ci_km=tuple(b_ci),
                      reliability=reliability, confidence=confidence, ci_method=ci_method,
                      log_likelihood=float(ll_max), n=float(w.sum()), failures=float(w[failed].sum()),
                      cov_log=cov)


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
