"""Exact Hertz point (elliptical) contact: Johnson, *Contact Mechanics* (1985), Sec. 4.2, Eqs. 4.36-4.41,
with complete elliptic integrals (``scipy.special.ellipk/ellipe``, parameter m = e^2): the axis ratio is solved
from the curvature ratio with ``scipy.optimize.brentq``; semi-axes, peak pressure and mutual approach follow in
closed form. Written with the contact modulus E* of :mod:`.elastic`.

Pure physics: scipy only, SI units (m, N, Pa).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from guide_health.models.lazy_scipy import brentq, ellipe, ellipk


def hertz_axis_ratio(radius_ratio: float) -> float:
    """Axis ratio kappa = major/minor semi-axis >= 1 of an elliptical Hertz contact [-].

    ``radius_ratio`` = R_large/R_small >= 1 of the effective radii. Solves (Johnson 1985 Eq. 4.39)
    R_large/R_small = (kappa^2 E(m) - K(m)) / (K(m) - E(m)),  m = e^2 = 1 - 1/kappa^2,
    with brentq; the right side rises monotonically from 1 at kappa = 1.
    """
    if not radius_ratio >= 1.0:
        raise ValueError(f"radius ratio must be >= 1, got {radius_ratio!r}")
    excess = radius_ratio - 1.0
    if excess < 1e-12:
        return 1.0
    if excess < 1e-5:
        # near-circular series: the right side is 1 + 3/2 (kappa - 1) + O((kappa - 1)^2); the elliptic-integral
        # difference K - E loses digits at m < 1e-5, the series error here is < 1e-10
        return 1.0 + 2.0 * excess / 3.0

    def residual(kappa: float) -> float:
        m = 1.0 - 1.0 / kappa ** 2
        k_m, e_m = ellipk(m), ellipe(m)
        return (kappa ** 2 * e_m - k_m) / (k_m - e_m) - radius_ratio

    return brentq(residual, 1.0 + 1e-9, radius_ratio + 1.0, xtol=1e-14, rtol=1e-13)


@dataclass(frozen=True)
class HertzPointContact:
    """Elliptical Hertz contact (Johnson 1985 Sec. 4.2). Semi-axes along the x (rolling) and y directions."""

    load_n: float
    semi_axis_x_m: float        # along x (rolling direction); the minor axis when R_x < R_y
    semi_axis_y_m: float        # along y (across the groove)
    p_max_pa: float             # peak pressure p0 = 3 P / (2 pi a b)
    approach_m: float           # mutual approach delta of distant points of the two bodies
    axis_ratio: float           # major/minor >= 1
    eccentricity_sq: float      # m = e^2 = 1 - (minor/major)^2
    elliptic_k: float           # K(m)
    elliptic_e: float           # E(m)

    @property
    def ellipticity_k(self) -> float:
        """Hamrock-Dowson k = semi-axis across / along the entrainment (x) direction [-]."""
        return self.semi_axis_y_m / self.semi_axis_x_m

    @property
    def area_m2(self) -> float:
        """Contact area pi a b [m^2]."""
        return math.pi * self.semi_axis_x_m * self.semi_axis_y_m

    @property
    def mean_pressure_pa(self) -> float:
        """Mean pressure P / (pi a b) = 2/3 p_max [Pa]."""
        return self.load_n / self.area_m2


def hertz_point_contact(load_n: float, radius_x_m: float, radius_y_m: float,
                        effective_modulus_pa: float) -> HertzPointContact:
    """Exact Hertz solution for a gap x^2/(2 R_x) + y^2/(2 R_y) under load P (Johnson 1985 Eqs. 4.36-4.41).

    E* = ``effective_modulus_pa`` (:func:`~guide_health.models.contact.elastic.effective_modulus_pa`); the major
    semi-axis c (along the larger radius R_l), kappa = c/a_minor:
        c^3 = 3 P R_l (K - E) / (pi E* m),   p0 = 3 P / (2 pi a c),   delta = p0 a_minor K(m) / E*.
    Circular limit (R_x = R_y = R): a^3 = 3 P R / (4 E*), p0 = 3 P / (2 pi a^2), delta = a^2 / R.
    """
    if not load_n > 0:
        raise ValueError(f"contact load must be > 0, got {load_n!r}")
    if not (radius_x_m > 0 and radius_y_m > 0 and effective_modulus_pa > 0):
        raise ValueError("radii and modulus must be > 0")
    e_star = effective_modulus_pa
    r_large, r_small = max(radius_x_m, radius_y_m), min(radius_x_m, radius_y_m)
    kappa = hertz_axis_ratio(r_large / r_small)
    if kappa == 1.0:
        radius = r_large
        a = (3.0 * load_n * radius / (4.0 * e_star)) ** (1.0 / 3.0)
        p0 = 3.0 * load_n / (2.0 * math.pi * a * a)
        half_pi = 0.5 * math.pi
        return HertzPointContact(load_n, a, a, p0, a * a / radius, 1.0, 0.0, half_pi, half_pi)
    m = 1.0 - 1.0 / kappa ** 2
    k_m, e_m = float(ellipk(m)), float(ellipe(m))
    # (K - E)/m, by its series pi/4 (1 + 3m/8 + 15m^2/64) where the difference would lose digits
    k_minus_e_over_m = (0.25 * math.pi * (1.0 + 0.375 * m + 15.0 / 64.0 * m * m)) if m < 1e-4 else (k_m - e_m) / m
    major = (3.0 * load_n * r_large * k_minus_e_over_m / (math.pi * e_star)) ** (1.0 / 3.0)
    minor = major / kappa
    p0 = 3.0 * load_n / (2.0 * math.pi * major * minor)
    approach = p0 * minor * k_m / e_star
    if radius_x_m <= radius_y_m:       # contact elongated across x: x is the minor axis
        ax, ay = minor, major
    else:
        ax, ay = major, minor
    return HertzPointContact(load_n, ax, ay, p0, approach, kappa, m, k_m, e_m)
