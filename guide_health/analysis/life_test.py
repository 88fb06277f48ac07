"""Rolling-guide life tests (seed 004): C_test / C of a test life under each rating convention, and the
seed's equal-spacing estimate from interval-censored failure mileages (next to the Weibull ML fit of
models/rolling/weibull.py)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guide_health.models.rolling import rating_life as lm
from guide_health.models.rolling import weibull


@dataclass(frozen=True)
class LifeTestLoad:
    """A life test's load as a fraction of the catalogue C, and the convention C is rated under:
    reference travel L_ref [km], load-life exponent p, life factors fh ft fc fw."""

    load_fraction: float
    rating_distance_km: float
    exponent: float
    life_factors: list[float]

    def c_ratio(self, life_km: float) -> float:
        """C_test / C of a test life [km] at this load (seed 004 Eq. 5)."""
        return lm.c_ratio_from_life(self.load_fraction, life_km, self.rating_distance_km, exponent=self.exponent,
                                    life_factors=self.life_factors)


def c_ratio_alternatives(load_fraction: float, life_km: float, life_factors: list[float]) -> list[dict]:
    """C_test / C of one test life under each convention: L_ref 50 km (catalogues, seed 004) and 100 km
    (ISO 14728-1), each with the ball (p = 3) and the roller (p = 10/3) exponent."""
    alternatives = []
    for l_ref in (lm.CATALOGUE_RATING_DISTANCE_KM, lm.ISO_RATING_DISTANCE_KM):
        for name, p in (("ball", 3.0), ("roller", 10.0 / 3.0)):
            alternatives.append({"rating_distance_km": l_ref, "exponent": p, "exponent_of": name,
                                 "c_ratio": lm.c_ratio_from_life(load_fraction, life_km, l_ref, exponent=p,
                                                                 life_factors=life_factors)})
    return alternatives


def equal_spacing_refit(lower_km: np.ndarray, upper_km: np.ndarray, counts: np.ndarray, confidence: float,
                        test_load: LifeTestLoad | None = None) -> dict:
    """Seed 004 Sec. 3.2: failures spread evenly in their interval, then treated as exact lives.

    Rows ``lower_km < life <= upper_km`` (upper inf: survived), ``counts`` units each. Returns the lives
    [km] and their mean, and (when the exact-life Weibull fit is determined) its shape, scale and B10
    [km], with C_test / C of that B10 at ``test_load``."""
    rep = np.repeat(np.arange(lower_km.size), counts.astype(int))
    lives = weibull.equal_spacing_lives_km(lower_km[rep], upper_km[rep])
    failed = lives[np.isfinite(lives)]
    eq = {"lives_km": sorted(failed.tolist()),
          "mean_km": float(failed.mean()) if failed.size else float("nan")}
    try:
        susp = upper_km[rep] == np.inf
        efit = weibull.fit_weibull(np.where(susp, lower_km[rep], lives), np.where(susp, np.inf, lives),
                                   confidence=confidence, ci_method="wald")
        eq.update({"shape": efit.shape, "scale_km": efit.scale_km, "b10_km": efit.b_life_km})
        if test_load is not None:
            eq["c_ratio"] = test_load.c_ratio(efit.b_life_km)
    except ValueError:
        pass
    return eq


#: the Weibull shape of the alternative single-specimen reading (rolling guides 1.1-1.5)
SINGLE_SPECIMEN_WEIBULL_SHAPE = 1.5


def life_test_readings(load_fraction: float, life_km: float, life_factors: list[float],
                       weibull_shape: float = SINGLE_SPECIMEN_WEIBULL_SHAPE) -> dict:
    """C_test / C of one test life under every reading that changes it, side by side:
    rating distance 50 km (the seed's own definition, catalogues) or 100 km (ISO 14728-1), exponent p = 3 or
    10/3, and the single specimen's life read as L10 (the seed) or as a median converted to B10 with a Weibull
    shape. Each row says whether the catalogue C is confirmed (C_test/C >= 1) or optimistic (< 1).

    Seed 004: roller, 62 km at 1.0 C: 1.07 with 50 km and p = 10/3 (C confirmed), 0.852 only with 100 km and
    p = 3; ball, 450 km at 0.3 C: 0.624 as L10, 0.41 as a median with shape 1.5."""
    rows = []
    b10 = lm.median_to_b_life(life_km, weibull_shape)
    for l_ref in (lm.CATALOGUE_RATING_DISTANCE_KM, lm.ISO_RATING_DISTANCE_KM):
        for exponent_of, p in (("ball", 3.0), ("roller", 10.0 / 3.0)):
            for reading, life in (("single life as L10", life_km),
                                  (f"median, Weibull shape {weibull_shape:g} -> B10", b10)):
                ratio = lm.c_ratio_from_life(load_fraction, life, l_ref, exponent=p, life_factors=life_factors)
                rows.append({"rating_distance_km": l_ref, "exponent": p, "exponent_of": exponent_of,
                             "life_reading": reading, "life_km": life, "c_ratio": ratio,
                             "verdict": "catalogue C confirmed" if ratio >= 1.0 else "catalogue C optimistic"})
    ratios = [r["c_ratio"] for r in rows]
    verdicts = {r["verdict"] for r in rows}
    return {"readings": rows, "c_ratio_min": min(ratios), "c_ratio_max": max(ratios),
            "weibull_shape": weibull_shape, "b10_from_median_km": b10,
            "conclusion_depends_on_reading": len(verdicts) > 1}
