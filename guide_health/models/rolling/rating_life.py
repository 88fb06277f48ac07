"""Rolling-guide fatigue life: rating life, the rated dynamic load C from a life test, and Miner consumption over
a varying duty.

Pure numpy, no ROS, no I/O. Units: N for loads, m for travel fed to the accumulator, km for lives
(every name that holds km says so). Sources:

* ISO 14728-1 (linear motion rolling bearings, dynamic load ratings and rating life):
  L10 = (C / P)^p x 100 km, p = 3 for balls, 10/3 for rollers.
* Catalogue form used by most ball-guide makers and by seed 004 (Eq. 4, its ref. [9]):
  L = (fh ft fc C / (fw P))^p x 50 km, fh hardness, ft temperature, fc contact (seed 004 calls it the
  lubrication factor), fw load/impact factor.
* Seed 004 Eq. 5: C back-calculated from a test life. The Weibull analysis of interval-censored test lives
  (seed 004 Sec. 3.2) is :mod:`guide_health.models.rolling.weibull`.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

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


def checked_positive(name: str, value: float) -> float:
    """``value`` as a float; ValueError naming ``name`` unless it is finite and > 0."""
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
    c_n = checked_positive("dynamic load rating C", c_n)
    l_ref = checked_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
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
    c_n = checked_positive("dynamic load rating C", c_n)
    life_km = checked_positive("life", life_km)
    l_ref = checked_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
    return factor_ratio(life_factors) * c_n * (l_ref / life_km) ** (1.0 / p)


def convert_rating_n(c_n: float, from_distance_km: float, to_distance_km: float, element: str = BALL,
                     exponent: float | None = None) -> float:
    """C for another reference travel [N]: C_to = C_from (L_from / L_to)^(1/p) (same life curve, ISO 14728-1).

    50 -> 100 km: C_100 = C_50 / 2^(1/3) = 0.7937 C_50 for balls, C_50 (1/2)^(3/10) = 0.8123 C_50 for rollers.
    """
    c_n = checked_positive("dynamic load rating C", c_n)
    a = checked_positive("rating distance", from_distance_km)
    b = checked_positive("rating distance", to_distance_km)
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
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
    l_ref = checked_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
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
    life_km = checked_positive("life", life_km)
    shape = checked_positive("Weibull shape", shape)
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
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
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
    c_n = checked_positive("dynamic load rating C", c_n)
    l_ref = checked_positive("rating distance", rating_distance_km)
    p = life_exponent(element) if exponent is None else checked_positive("life exponent", exponent)
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
        self.c_n = checked_positive("dynamic load rating C", dynamic_load_rating_n)
        self.element = rolling_element
        self.exponent = life_exponent(rolling_element) if exponent is None else checked_positive(
            "life exponent", exponent)
        self.rating_distance_km = checked_positive("rating distance", rating_distance_km)
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
    def from_state(cls, state: dict, **overrides) -> FatigueAccumulator:
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
