"""Ball/groove contact of a four-row linear rolling guideway: one contact from the wear_monitor parameters, its
Hertz pressure, film, lambda and regime (``rolling_contact_report``, INTERFACES.md ``contact rolling --json``
keys), and ``LubricationRegimeEstimator`` (one-time set-up, then O(1) microseconds per joint-state sample for a
live node).

Source: seed 001 (NSK LH45 guide; the reference: docs/physics.md#the-seeds); equation/table/figure numbers are
the paper's.

Pure physics: numpy/scipy only, SI units at every public boundary (m, N, Pa, m/s), no ROS, no I/O.

* Exact Hertz point contact: :mod:`guide_health.models.contact.hertz_point`, with the contact modulus
  E* = E/(2(1-nu^2)) of two equal steels (:mod:`guide_health.models.contact.elastic`).
* Groove geometry: ball radius r, straight groove (rail and carriage) of radius f D = 2 f r (seed 001 Eq. 2).
  Effective radii: R_x = r along the rolling direction (the groove is straight), 1/R_y = 1/r - 1/(2 f r)
  across it (R_y = 103.18 mm for r = 3.9685 mm, f = 0.52). The contact ellipse is long across the groove,
  so the rolling-direction semi-axis a is the MINOR one (seed Table 1 'a').
* Load distribution of the four rows: :mod:`.carriage`; film, lambda, regime and the JGP/Greenwood-Tripp asperity
  share: :mod:`.lubrication` (its docstring holds the assumptions and the comparison with the seed).

Hertz check (seed 001 Table 1, E = 206 GPa, nu = 0.3 both bodies, contact load = preload): p_max = 1.6796 /
1.9844 / 2.3406 / 2.6132 GPa and a = 0.11598 / 0.13703 / 0.16163 / 0.18045 mm at 385 / 635 / 1042 / 1450 N
against the table's 1.680 / 1.984 / 2.340 / 2.613 GPa and 0.116 / 0.137 / 0.162 / 0.180 mm (all within 0.25 %).
Axis ratio b/a = 8.136, approach 6.01 um per contact at 385 N.
"""
from __future__ import annotations

import bisect
import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from guide_health.models.contact.elastic import effective_modulus_pa
from guide_health.models.contact.hertz_point import HertzPointContact, hertz_point_contact
from guide_health.models.rolling.carriage import (
    CarriageLoadDistribution,
    ball_stiffness_n_per_m15,
    carriage_load_distribution,
    equivalent_fatigue_load_n,
)
from guide_health.models.rolling.lubrication import (
    HD_CENTRAL_U_EXP,
    MixedLubrication,
    entrainment_speed,
    greenwood_tripp_f52_table,
    greenwood_tripp_pressure_coefficient,
    hamrock_dowson_film,
    jgp_greenwood_tripp,
    lubrication_regime,
)
from guide_health.models.rolling.oil import WaltherOil, catalogue_oil

ROWS_SUPPORTED = 4
_isfinite = math.isfinite
_log10 = math.log10


def groove_contact_radii(ball_radius_m: float, groove_conformity: float) -> tuple[float, float]:
    """Effective radii (R_x, R_y) [m] of a ball in a straight groove of radius f D (seed 001 Eq. 2).

    R_x (rolling direction) = r: the groove is straight along the rail. 1/R_y = 1/r - 1/(2 f r) across it.
    """
    if not ball_radius_m > 0:
        raise ValueError(f"ball radius must be > 0, got {ball_radius_m!r}")
    if not groove_conformity > 0.5:
        raise ValueError("groove conformity must be > 0.5 (groove radius larger than the ball), "
                         f"got {groove_conformity!r}")
    groove_radius_m = groove_conformity * 2.0 * ball_radius_m  # seed 001 Eq. 2: R2 = Gf D1 = 2 Gf R1
    return ball_radius_m, 1.0 / (1.0 / ball_radius_m - 1.0 / groove_radius_m)


# ----------------------------------------------------------------------------------------------------------
# Parameters, report and the live estimator
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RollingGuideContact:
    """Numbers of one ball/groove contact of a rolling guide, from wear_monitor parameters (SI)."""

    ball_radius_m: float
    groove_conformity: float
    contact_angle_deg: float
    balls_per_row: int
    rows: int
    preload_per_ball_n: float
    viscosity_pa_s: float
    pressure_viscosity_pa_inv: float
    composite_rms_m: float
    youngs_modulus_pa: float
    poisson: float
    asperity_radius_m: float
    asperity_density_per_m2: float
    carriages: int
    lambda_boundary: float
    lambda_full_film: float
    radius_x_m: float
    radius_y_m: float
    effective_modulus_pa: float        # E* [Pa]
    ball_stiffness: float
    oil: WaltherOil | None = None      # catalogue oil: viscosity_pa_s is its value at oil_temperature_c
    oil_temperature_c: float = math.nan

    @classmethod
    def from_params(cls, params: Any) -> RollingGuideContact:
        """The contact of a guide's parameters (GuideParams, guide_health.params.typed: its fields by their
        parameter names), checked for the physics; raises ValueError with a one-line reason."""
        radius = _positive("ball_radius_m", params.ball_radius_m)
        conformity = _number("groove_conformity", params.groove_conformity)
        if not conformity > 0.5:
            raise ValueError(f"parameter groove_conformity must be > 0.5, got {conformity!r}")
        angle = _number("contact_angle_deg", params.contact_angle_deg)
        if not 0.0 < angle < 90.0:
            raise ValueError(f"parameter contact_angle_deg must be in (0, 90), got {angle!r}")
        rows = _integer("rows", params.rows)
        if rows != ROWS_SUPPORTED:
            raise ValueError(f"parameter rows: only 4-row carriages are modelled, got {rows!r}")
        preload = _number("preload_n", params.preload_n)
        if preload < 0:
            raise ValueError(f"parameter preload_n must be >= 0, got {preload!r}")
        poisson = _number("poisson", params.poisson)
        if not 0.0 <= poisson < 0.5:
            raise ValueError(f"parameter poisson must be in [0, 0.5), got {poisson!r}")
        youngs = _positive("youngs_modulus_pa", params.youngs_modulus_pa)
        e_star = effective_modulus_pa(youngs, poisson)
        lam_b = _positive("lambda_boundary", params.lambda_boundary)
        lam_f = _positive("lambda_full_film", params.lambda_full_film)
        if not lam_f > lam_b:
            raise ValueError("lambda_full_film must be > lambda_boundary")
        r_x, r_y = groove_contact_radii(radius, conformity)
        balls_per_row = _integer("balls_per_row", params.balls_per_row)
        constant_viscosity = _positive("oil_viscosity_pa_s", params.oil_viscosity_pa_s)
        oil = _oil(params)
        return cls(
            ball_radius_m=radius, groove_conformity=conformity, contact_angle_deg=angle,
            balls_per_row=balls_per_row, rows=rows, preload_per_ball_n=preload,
            viscosity_pa_s=(constant_viscosity if oil is None
                            else oil.dynamic_viscosity_pa_s(float(params.oil_temperature_c))),
            pressure_viscosity_pa_inv=_positive("pressure_viscosity_pa_inv", params.pressure_viscosity_pa_inv),
            composite_rms_m=_positive("roughness_rms_m", params.roughness_rms_m), youngs_modulus_pa=youngs,
            poisson=poisson, asperity_radius_m=_positive("asperity_radius_m", params.asperity_radius_m),
            asperity_density_per_m2=_positive("asperity_density_per_m2", params.asperity_density_per_m2),
            carriages=_integer("carriages", params.carriages),
            lambda_boundary=lam_b, lambda_full_film=lam_f,
            radius_x_m=r_x, radius_y_m=r_y, effective_modulus_pa=e_star,
            ball_stiffness=ball_stiffness_n_per_m15(r_x, r_y, e_star),
            oil=oil, oil_temperature_c=float(params.oil_temperature_c),
        )

    def at_temperature(self, temperature_c: float) -> RollingGuideContact:
        """The same contact with the Walther oil at ``temperature_c`` (unchanged without a catalogue oil)."""
        if self.oil is None:
            return self
        return dataclasses.replace(self, viscosity_pa_s=self.oil.dynamic_viscosity_pa_s(temperature_c),
                                   oil_temperature_c=float(temperature_c))

    def hertz(self, load_n: float) -> HertzPointContact:
        """Hertz contact at a ball load [N]."""
        return hertz_point_contact(load_n, self.radius_x_m, self.radius_y_m, self.effective_modulus_pa)

    def film(self, load_n: float, carriage_speed_m_s: float, contact: HertzPointContact | None = None
             ) -> tuple[float, float]:
        """Hamrock-Dowson (central, minimum) film [m] at a ball load and carriage speed."""
        contact = contact or self.hertz(load_n)
        return hamrock_dowson_film(load_n, entrainment_speed(carriage_speed_m_s), self.radius_x_m,
                                   contact.ellipticity_k, self.effective_modulus_pa, self.viscosity_pa_s,
                                   self.pressure_viscosity_pa_inv)

    @property
    def gt_pressure_coefficient_pa(self) -> float:
        """K_GT E' [Pa] of the Greenwood-Tripp asperity pressure."""
        return greenwood_tripp_pressure_coefficient(self.composite_rms_m, self.asperity_density_per_m2,
                                                    self.asperity_radius_m, self.effective_modulus_pa)

    def mixed(self, smooth_central_film_m: float, contact: HertzPointContact,
              f52: Callable[[float], float] | None = None) -> MixedLubrication:
        """JGP/GT load sharing for this contact."""
        return jgp_greenwood_tripp(smooth_central_film_m, contact.mean_pressure_pa, self.composite_rms_m,
                                   self.gt_pressure_coefficient_pa, self.asperity_density_per_m2,
                                   self.asperity_radius_m, f52)

    def load_distribution(self, carriage_load_n: float) -> CarriageLoadDistribution:
        """Ball loads under a vertical load on ONE carriage [N]."""
        return carriage_load_distribution(carriage_load_n, self.preload_per_ball_n, self.contact_angle_deg,
                                          self.balls_per_row, self.ball_stiffness)


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"parameter {name} must be a finite number, got {value!r}")
    return float(value)


def _positive(name: str, value: Any) -> float:
    value = _number(name, value)
    if not value > 0:
        raise ValueError(f"parameter {name} must be > 0, got {value!r}")
    return value


def _integer(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"parameter {name} must be a positive integer, got {value!r}")
    return value


def _oil(params: Any) -> WaltherOil | None:
    try:
        return catalogue_oil(params.oil_viscosity_40c_mm2_s, params.oil_viscosity_100c_mm2_s,
                             params.oil_density_15c_kg_m3)
    except ValueError as exc:
        raise ValueError(f"parameters oil_viscosity_*: {exc}") from None


def rolling_contact_report(params: Any, load_n: float | None, speed_m_s: float,
                           carriage_load_n: float = 0.0, temperature_c: float | None = None) -> dict[str, Any]:
    """Contact, film, lambda and regime of one ball contact (INTERFACES.md ``contact rolling --json`` keys).

    ``load_n``: contact load per ball [N] (default: the most loaded ball under ``carriage_load_n``, i.e.
    ``preload_n`` at 0); ``speed_m_s``: carriage speed [m/s] (its sign is irrelevant); ``carriage_load_n``:
    external load on one carriage [N], > 0 downward, < 0 reverse (lift-off). Also reports the four-row ball
    loads and ``equivalent_fatigue_load_n``, the carriage load for the rating life with the preload in it.
    ``temperature_c``: oil temperature for a catalogue (Walther) oil, default ``oil_temperature_c``.
    Raises ValueError on bad numbers.
    """
    guide = RollingGuideContact.from_params(params)
    if temperature_c is not None:
        if not math.isfinite(float(temperature_c)):
            raise ValueError(f"temperature must be finite, got {temperature_c!r}")
        guide = guide.at_temperature(float(temperature_c))
    carriage = float(carriage_load_n)
    if not math.isfinite(carriage):
        raise ValueError(f"carriage load must be finite, got {carriage!r}")
    distribution = guide.load_distribution(carriage)
    reverse_factor = float(params.reverse_load_rating_factor)
    fatigue_load = equivalent_fatigue_load_n(distribution, reverse_factor)
    load = distribution.max_ball_load_n if load_n is None else float(load_n)
    if not (math.isfinite(load) and load > 0):
        raise ValueError(f"contact load per ball must be a finite number > 0, got {load!r}")
    speed = float(speed_m_s)
    if not math.isfinite(speed):
        raise ValueError(f"speed must be finite, got {speed!r}")
    contact = guide.hertz(load)
    h_central, h_min = guide.film(load, speed, contact)
    mixed = guide.mixed(h_central, contact)
    sigma = guide.composite_rms_m
    lam = h_central / sigma
    regime = lubrication_regime(lam, guide.lambda_boundary, guide.lambda_full_film)
    return {
        "p_max_MPa": contact.p_max_pa * 1e-6,
        "semi_axis_a_mm": contact.semi_axis_x_m * 1e3,
        "semi_axis_b_mm": contact.semi_axis_y_m * 1e3,
        "film_central_nm": h_central * 1e9,
        "film_min_nm": h_min * 1e9,
        "lambda": lam,
        "lambda_min": h_min / sigma,
        "regime": regime,
        "contact_area_ratio": mixed.asperity_load_share,
        "asperity_load_share": mixed.asperity_load_share,
        "asperity_real_area_ratio": mixed.asperity_real_area_ratio,
        "mean_plane_separation_nm": mixed.separation_m * 1e9,
        "contact_load_n": load,
        "approach_um": contact.approach_m * 1e6,
        "entrainment_speed_m_s": entrainment_speed(speed),
        "carriage_speed_m_s": abs(speed),
        "ellipticity_k": contact.ellipticity_k,
        "mean_pressure_MPa": contact.mean_pressure_pa * 1e-6,
        "composite_roughness_nm": sigma * 1e9,
        "radius_x_mm": guide.radius_x_m * 1e3,
        "radius_y_mm": guide.radius_y_m * 1e3,
        "lambda_boundary": guide.lambda_boundary,
        "lambda_full_film": guide.lambda_full_film,
        "carriage_load_n": carriage,
        "upper_ball_load_n": distribution.upper_ball_load_n,
        "lower_ball_load_n": distribution.lower_ball_load_n,
        "equivalent_fatigue_load_n": fatigue_load,
        "reverse_load_rating_factor": reverse_factor,
        "oil_viscosity_pa_s": guide.viscosity_pa_s,
        "oil_temperature_c": guide.oil_temperature_c if guide.oil is not None else math.nan,
        "message": (f"{regime} lubrication: lambda {lam:.3g}, central film {h_central * 1e9:.1f} nm, "
                    f"p_max {contact.p_max_pa * 1e-6:.0f} MPa at {load:.0f} N per ball"),
    }


def speed_sweep(params: Any, load_n: float | None, speeds_m_s: np.ndarray,
                temperature_c: float | None = None) -> dict[str, np.ndarray]:
    """Film, lambda and JGP shares over carriage speeds [m/s] at one ball load (for plots and checks);
    ``temperature_c``: oil temperature of a catalogue oil, default ``oil_temperature_c`` (as the report)."""
    guide = RollingGuideContact.from_params(params)
    if temperature_c is not None:
        guide = guide.at_temperature(float(temperature_c))
    load = guide.preload_per_ball_n if load_n is None else float(load_n)
    contact = guide.hertz(load)
    out = {k: np.empty(len(speeds_m_s)) for k in ("film_central_m", "film_min_m", "lambda", "asperity_load_share",
                                                  "asperity_real_area_ratio", "separation_m")}
    for i, v in enumerate(np.asarray(speeds_m_s, dtype=float)):
        hc, hm = guide.film(load, v, contact)
        mixed = guide.mixed(hc, contact)
        out["film_central_m"][i], out["film_min_m"][i] = hc, hm
        out["lambda"][i] = hc / guide.composite_rms_m
        out["asperity_load_share"][i] = mixed.asperity_load_share
        out["asperity_real_area_ratio"][i] = mixed.asperity_real_area_ratio
        out["separation_m"][i] = mixed.separation_m
    out["speed_m_s"] = np.asarray(speeds_m_s, dtype=float)
    return out


class RegimeSample(NamedTuple):
    """Per-sample output of :class:`LubricationRegimeEstimator` (a NamedTuple: cheap to build)."""

    lambda_ratio: float
    regime: str
    asperity_load_share: float
    ball_load_n: float



@functools.lru_cache(maxsize=16)
def _asperity_share_table(guide: RollingGuideContact, log_lambda: tuple[float, ...],
                          log_ball_load: tuple[float, ...]) -> tuple[tuple[float, ...], ...]:
    """Asperity load share of the mixed-lubrication contact at lambda = 10^log_lambda and the ball load
    10^log_ball_load [N] (rows: lambda): a pure function of the contact, computed once per guide (the
    regime model of every monitor, live or offline, of the same guide takes the same table)."""
    f52 = greenwood_tripp_f52_table()
    share = np.empty((len(log_lambda), len(log_ball_load)))
    for j, lw in enumerate(log_ball_load):
        contact = guide.hertz(10.0 ** lw)
        for i, ll in enumerate(log_lambda):
            share[i, j] = guide.mixed(10.0 ** ll * guide.composite_rms_m, contact, f52).asperity_load_share
    return tuple(tuple(row) for row in share.tolist())

class LubricationRegimeEstimator:
    """O(1) lambda / regime / asperity share from (carriage speed, carriage vertical load) for a live node.

    Set-up (once, ~0.4 s): Hertz geometry (the ellipticity does not depend on load), the film constant
    C in h_c = C u^0.67 w^-0.067 (Hamrock-Dowson is a pure power law at fixed geometry), a table of the
    dimensionless 4-row equilibrium F_u/F_0 vs F/(2 n sin(alpha) F_0), and a table of the JGP asperity share
    over (log lambda, log ball load). Per sample: a few float operations, two bisections and one bilinear
    interpolation (microseconds). ``carriage_load_n`` is the vertical load on the guide (compressive > 0),
    shared equally by ``carriages``; the most loaded ball row sets lambda.
    """

    _LAMBDA_LOG_GRID = np.linspace(-3.5, 1.0, 46)
    _LOAD_LOG_SPAN = (0.5, 5.0)       # ball loads 3.2 N .. 100 kN on the share table

    def __init__(self, params: Any) -> None:
        guide = RollingGuideContact.from_params(params)
        self.guide = guide
        self._preload = guide.preload_per_ball_n
        self._sin_alpha = math.sin(math.radians(guide.contact_angle_deg))
        self._rows_pair = 2.0 * guide.balls_per_row * self._sin_alpha
        self._load_scale = 1.0 / (guide.carriages * self._rows_pair)
        reference = guide.hertz(1.0)
        h_ref, _ = hamrock_dowson_film(1.0, 1.0, guide.radius_x_m, reference.ellipticity_k,
                                       guide.effective_modulus_pa, guide.viscosity_pa_s,
                                       guide.pressure_viscosity_pa_inv)
        self._lambda_coeff = h_ref / guide.composite_rms_m       # lambda = coeff u^0.67 w^-0.067
        # Hamrock-Dowson: h_c ~ (eta_0 u)^0.67, so a new oil temperature only rescales the coefficient
        self._lambda_coeff_per_eta = self._lambda_coeff / guide.viscosity_pa_s ** HD_CENTRAL_U_EXP
        self.oil_temperature_c = guide.oil_temperature_c if guide.oil is not None else math.nan
        self.viscosity_pa_s = guide.viscosity_pa_s
        self._lambda_boundary = guide.lambda_boundary
        self._lambda_full_film = guide.lambda_full_film
        # dimensionless equilibrium table q -> F_u/F_0 for q < 2^1.5 (x in [0, 1])
        x = np.linspace(0.0, 1.0, 401)
        self._q_table = ((1.0 + x) ** 1.5 - (1.0 - x) ** 1.5).tolist()
        self._fu_table = ((1.0 + x) ** 1.5).tolist()
        self._q_unloaded = 2.0 ** 1.5
        # asperity share table over (log10 lambda, log10 ball load)
        log_w = np.linspace(self._LOAD_LOG_SPAN[0], self._LOAD_LOG_SPAN[1], 19)
        self._log_lambda_axis = self._LAMBDA_LOG_GRID.tolist()
        self._log_load_axis = log_w.tolist()
        self._share = [list(row) for row in _asperity_share_table(guide, tuple(self._log_lambda_axis),
                                                                  tuple(self._log_load_axis))]

    def set_oil_temperature(self, temperature_c: float) -> None:
        """Walther viscosity at a new oil temperature [degC] (no effect without a catalogue oil)."""
        oil = self.guide.oil
        if oil is None or not _isfinite(temperature_c) or temperature_c == self.oil_temperature_c:
            return
        self.viscosity_pa_s = oil.dynamic_viscosity_pa_s(temperature_c)
        self._lambda_coeff = self._lambda_coeff_per_eta * self.viscosity_pa_s ** HD_CENTRAL_U_EXP
        self.oil_temperature_c = float(temperature_c)

    def ball_load(self, carriage_load_n: float) -> float:
        """Highest ball load [N] under a vertical carriage load [N] (table of the 4-row equilibrium)."""
        per_row_pair = abs(carriage_load_n) * self._load_scale       # |F| / (2 n sin a) per carriage
        if self._preload <= 0.0:
            return per_row_pair
        q = per_row_pair / self._preload
        if q >= self._q_unloaded:
            return per_row_pair
        table = self._q_table
        i = bisect.bisect_right(table, q) - 1
        f = (q - table[i]) / (table[i + 1] - table[i])
        return self._preload * (self._fu_table[i] + f * (self._fu_table[i + 1] - self._fu_table[i]))

    def fatigue_load_n(self, guide_load_n: float) -> float:
        """Carriage load for the rating life [N] from the internal ball loads under preload, before the
        direction's rating factor: 2 n sin(alpha) x the highest ball load (the table form of
        :func:`~guide_health.models.rolling.carriage.equivalent_fatigue_load_n`)."""
        return self.ball_load(guide_load_n) * self._rows_pair

    def sample(self, carriage_speed_m_s: float, carriage_load_n: float) -> RegimeSample:
        """lambda, regime, asperity share and ball load for one (speed [m/s], load [N]) sample."""
        if not (_isfinite(carriage_speed_m_s) and _isfinite(carriage_load_n)):
            raise ValueError("speed and load must be finite")
        w = self.ball_load(carriage_load_n)
        if w <= 0.0:
            return RegimeSample(math.inf, "full_film", 0.0, 0.0)
        u = 0.5 * abs(carriage_speed_m_s)
        if u == 0.0:
            return RegimeSample(0.0, "boundary", 1.0, w)
        lam = self._lambda_coeff * u ** 0.67 * w ** -0.067        # Hamrock-Dowson central-film exponents
        if lam < self._lambda_boundary:
            regime = "boundary"
        elif lam >= self._lambda_full_film:
            regime = "full_film"
        else:
            regime = "mixed"
        return RegimeSample(lam, regime, self._share_at(_log10(lam), _log10(w)), w)

    def _share_at(self, log_lambda: float, log_load: float) -> float:
        ax, ay, table = self._log_lambda_axis, self._log_load_axis, self._share
        if log_lambda >= ax[-1]:
            log_lambda = ax[-1]
        if log_lambda <= ax[0]:
            log_lambda = ax[0]
        log_load = min(max(log_load, ay[0]), ay[-1])
        i = min(bisect.bisect_right(ax, log_lambda) - 1, len(ax) - 2)
        j = min(bisect.bisect_right(ay, log_load) - 1, len(ay) - 2)
        fx = (log_lambda - ax[i]) / (ax[i + 1] - ax[i])
        fy = (log_load - ay[j]) / (ay[j + 1] - ay[j])
        r0, r1 = table[i], table[i + 1]
        return ((1 - fx) * ((1 - fy) * r0[j] + fy * r0[j + 1])
                + fx * ((1 - fy) * r1[j] + fy * r1[j + 1]))
