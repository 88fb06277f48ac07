"""``speed_dependent_wear`` (v_lift [m/s]): mixed lubrication. The film grows with speed, lambda =
(v / v_lift)^0.7 (the speed exponent of Hamrock-Dowson film formulas, seed 001), and the asperities carry the
share 1 / (1 + lambda^2) of the load, so m = 1 / (1 + (v / v_lift)^1.4). v_lift is the speed at which film and
asperities share the load equally (the seed's boundary-to-mixed transition)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from guide_health.models.wear.effects.base import (
    CovarianceRow,
    Effect,
    EffectParameter,
    FitContext,
    FitParameter,
    LiveRequirement,
    SimulateValue,
)

LUBRICATION_SPEED_EXPONENT = 0.7     # lambda ~ v^0.7 (Hamrock-Dowson film thickness, seed 001)


class SpeedDependentWear(Effect):
    """A material factor: the asperity share of the load."""

    def plausible_strong_size(self, c):
        lam2 = (c.feed_speed_m_s / 0.02) ** (2.0 * LUBRICATION_SPEED_EXPONENT)
        return {"lift_speed_m_s": 0.02}, "lambda^2 at the feed speed", lam2

    def live_values(self, p, named):
        return {"lift_speed_m_s": (float(p["lift_speed_m_s"]) if named else math.inf) if p["lift_speed_m_s"] > 0
                else math.inf}

    def rate_factor(self, e, speed_m_s, load_n, retract):
        return asperity_load_share(speed_m_s, e.lift_speed_m_s)

    def live_rate_gradients(self, e, seg):
        share = asperity_load_share(seg.speed_m_s, e.lift_speed_m_s)
        return {self.rate_row: live_gradient(seg.effective_work_nm, share, e.lift_speed_m_s)}

    def speed_factor(self, e):
        """The factor as a function of the instantaneous sliding speed v [m/s] (a move whose speed varies, as a
        double-S move's, averages it along the move); None: no effect (v_lift infinite)."""
        if not math.isfinite(e.lift_speed_m_s):
            return None
        return lambda v: asperity_load_share(v, e.lift_speed_m_s)

    def without(self, e):
        """``e`` with the factor at its no-effect value (the rest of the multiplier, when this factor is averaged
        separately)."""
        return replace(e, lift_speed_m_s=math.inf)

    def scenario_rate_factor(self, e, scales, v_s):
        """The asperity share at the scaled mean sliding speed over the present one's (None: no speed change)."""
        if self.id not in e.effects or scales.speed_scale == 1.0 or not v_s > 0:
            return None
        return float(asperity_load_share(scales.speed_scale * v_s, e.lift_speed_m_s)
                     / asperity_load_share(v_s, e.lift_speed_m_s))

    def scenario_dln(self, e, scales, v_s, dln):
        """d ln m / d v_lift = (1 - share) 1.4 / v_lift: scales with the film's share 1 - share at the new speed."""
        if self.id not in e.effects or scales.speed_scale == 1.0 or not v_s > 0:
            return dln
        old, new = (1.0 - float(asperity_load_share(v, e.lift_speed_m_s)) for v in (v_s, scales.speed_scale * v_s))
        return dln * (new / old if old > 0 else 1.0)


EFFECT = SpeedDependentWear(
    id="speed_dependent_wear",
    term="asperity share of the load 1/(1 + lambda²), lambda = (v/v_lift)^0.7 (seed 001's film-speed exponent)",
    meaning="speed-dependent wear: the lubricant film lifts the load off the asperities at speed",
    separating_duty="jobs at two or more feed speeds under the same load",
    simulate=SimulateValue("lift_speed_m_s", "m/s", math.inf, "(0, 100]"),
    material=True,
    parameters=(
        EffectParameter("lift_speed_m_s", 0.0, "m/s", "[0, 100]",
                        "speed_dependent_wear v_lift: asperity share 1 / (1 + (v / v_lift)^1.4); 0 = no effect"),
    ),
    fitted_to_file=("lift_speed_m_s",),
    covariance_rows=(CovarianceRow("lift_speed_m_s", 4, 1, rate=True),),
    requires=LiveRequirement("lift_speed_m_s", "> 0"),
    fields=(("lift_speed_m_s", math.inf, "v_lift"),),
    recorded=("lift_speed_m_s",),
)


def asperity_load_share(speed_m_s: np.ndarray, lift_speed_m_s: float) -> np.ndarray:
    """Share of the load on asperities, 1 / (1 + lambda^2), lambda = (v / v_lift)^0.7 [-]."""
    v = np.abs(np.asarray(speed_m_s, dtype=float))
    if not math.isfinite(lift_speed_m_s):
        return np.ones_like(v)
    return 1.0 / (1.0 + (v / lift_speed_m_s) ** (2.0 * LUBRICATION_SPEED_EXPONENT))


def live_gradient(effective_work_nm: np.ndarray, share: np.ndarray, lift_speed_m_s: float) -> np.ndarray:
    """d(effective work)/d v_lift [N m / (m/s)]: m' / m = (1 - share) 1.4 / v_lift."""
    if not math.isfinite(lift_speed_m_s):
        return np.zeros_like(effective_work_nm)
    return effective_work_nm * (1.0 - share) * 2.0 * LUBRICATION_SPEED_EXPONENT / lift_speed_m_s


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """v_lift (log-scaled, started around the feed speed)."""
    return [FitParameter("lift_speed_m_s", "m/s", 1e-5, 100.0, True,
                         tuple(c.feed_speed_m_s * f for f in (0.5, 2.0, 8.0)))]
