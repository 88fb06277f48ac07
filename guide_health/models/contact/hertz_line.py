"""Ideal Hertz line contact of a roller (infinitely long, load uniform along it): Johnson, *Contact
Mechanics* (1985), Sec. 4.2, Eqs. 4.43-4.45, written with the contact modulus E* of :mod:`.elastic`.

Pure physics: numpy only, SI units (m, N, Pa).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from guide_health.models.contact.elastic import effective_modulus_pa


def checked_load_n(name: str, value: float, allow_negative: bool = False) -> float:
    """``value`` as a float load [N]; ValueError if it is not finite, or negative unless ``allow_negative``."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value < 0 and not allow_negative:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


def effective_radius_m(roller_diameter_m: float, raceway_radius_m: float = math.inf) -> float:
    """R = 1/(2/d + 1/R_race) [m]; R_race > 0 convex, < 0 concave, inf flat (axial rows).  # Johnson Sec. 4.2"""
    curvature = 2.0 / roller_diameter_m + (0.0 if math.isinf(raceway_radius_m) else 1.0 / raceway_radius_m)
    if not curvature > 0:
        raise ValueError("raceway curvature must be smaller than the roller's (conforming contact)")
    return 1.0 / curvature


def contact_half_width_m(line_load_n_m: float, effective_radius_m_: float, effective_modulus_pa: float) -> float:
    """a = sqrt(4 P1 R/(pi E*)) = sqrt(2 P1 d/(pi E*)) for a flat raceway [m].  # seed 003 Eq. 3/8"""
    return math.sqrt(4.0 * line_load_n_m * effective_radius_m_ / (math.pi * effective_modulus_pa))


def peak_contact_pressure_pa(line_load_n_m: float, half_width_m: float) -> float:
    """p0 = 2 P1/(pi a) [Pa].  # seed 003 Eq. 10"""
    return 2.0 * line_load_n_m / (math.pi * half_width_m) if half_width_m > 0 else 0.0


def pressure_across_contact_pa(x_m: np.ndarray, line_load_n_m: float, half_width_m: float) -> np.ndarray:
    """p(x) = 2 P1/(pi a^2) sqrt(a^2 - x^2) inside |x| < a, 0 outside [Pa].  # seed 003 Eq. 9"""
    x = np.asarray(x_m, dtype=float)
    inside = np.clip(half_width_m ** 2 - x ** 2, 0.0, None)
    return 2.0 * line_load_n_m / (math.pi * half_width_m ** 2) * np.sqrt(inside)


def hertz_line_pressure_and_half_width(load_per_length_n_m: float, effective_radius_m_: float,
                                       effective_modulus_pa: float) -> tuple[float, float]:
    """Hertz 2D line contact: (p0 [Pa], half-width b [m]).

    p0 = sqrt(P' E* / (pi R)), b = sqrt(4 P' R / (pi E*)) with P' the load per unit length [N/m],
    R the effective radius [m] and E* the contact modulus [Pa].
    Johnson, *Contact Mechanics* (1985), eqs. 4.43-4.45.
    """
    p0 = math.sqrt(load_per_length_n_m * effective_modulus_pa / (math.pi * effective_radius_m_))
    b = math.sqrt(4.0 * load_per_length_n_m * effective_radius_m_ / (math.pi * effective_modulus_pa))
    return p0, b


@dataclass(slots=True)
class HertzLineContact:
    """Ideal (infinitely long) Hertz line contact: line load [N/m], E* [Pa], R [m], a [m], p0 [Pa]."""

    line_load_n_m: float
    effective_modulus_pa: float
    effective_radius_m: float
    half_width_m: float
    p0_pa: float


def hertz_line_contact(load_n: float, contact_length_m: float, roller_diameter_m: float,
                       youngs_modulus_pa: float, poisson: float,
                       raceway_radius_m: float = math.inf) -> HertzLineContact:
    """Ideal Hertz line contact of a roller (diameter d) on a raceway, load spread uniformly on l_e.

    load_n: Q [N]; contact_length_m: l_e [m]; raceway_radius_m: inf for a flat raceway.
    # seed 003 Eqs. 3, 10 (Johnson 1985 Eqs. 4.43-4.45)
    """
    load = checked_load_n("roller load", load_n)
    modulus = effective_modulus_pa(youngs_modulus_pa, poisson)
    radius = effective_radius_m(roller_diameter_m, raceway_radius_m)
    line_load = load / contact_length_m
    half_width = contact_half_width_m(line_load, radius, modulus)
    return HertzLineContact(line_load, modulus, radius, half_width, peak_contact_pressure_pa(line_load, half_width))
