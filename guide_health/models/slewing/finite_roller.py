"""The seed's finite-roller ("non-Hertz") method, seed 003 Eqs. 2-10: approach at the roller centre (Eq. 2)
and at the end (Eq. 5), approach along the roller (Eq. 4), line load from Palmgren's stiffness (Eqs. 6/7),
half-width and peak pressure along the roller (Eqs. 8-10).

Pure physics: numpy/scipy only, SI units at every public boundary (m, N, Pa). The seed's Eqs. 6/7
(Palmgren's line-contact stiffness) are dimensional in N and mm; they are evaluated in those units
internally and converted at the function boundary.

Notes on the seed's printed equations (checked numerically, see test/test_roller_contact.py)
------------------------------------------------------------------------------------------
* Eq. 2 needs the half-width a "at the roller centre", which itself follows from P1(0,0) (Eq. 7 via Eq. 2).
  The paper's numbers (delta(0,0) = 0.0894 mm, p0 = 2675 MPa at the centre) are reproduced with the ideal
  Hertz half-width of the mean line load Q/l_e (a = 0.764 mm); that is what is used here. (Iterating
  a <-> P1(0,0) to a fixed point instead gives a = 0.744 mm and p0,centre = 2683 MPa, +0.3 %.)
* Eq. 4 diverges at the roller end; the approach along the roller is taken as Eq. 4 until it reaches the
  Eq. 5 end value (at |y| = 0.9926 l for the seed example) and the Eq. 5 value beyond, so the highest
  pressure sits on the last ~0.1 mm of the roller and ``p_max_position_mm`` reports the end, l.
* Eqs. 2/4/5 (Johnson Sec. 5.8: the surface of a half-space loaded uniformly along y on a 2a x 2l
  rectangle sinks less at the ends) are combined with Palmgren's empirical stiffness (Eqs. 6/7, a different
  model) without re-imposing equilibrium. The resulting line load integrates to 1.0076 Q for the seed
  example (0.76 % more than the roller carries): the two models are consistent to under 1 %, but the
  method is not an exact load balance.
* The end/centre pressure ratio is (delta_end/delta_centre)^(1/(2*0.925)) with
  delta_end/delta_centre = 1 + (1.193 + ln(l/a)) / (2 (1.886 + ln(l/a))): independent of E and of Palmgren's
  constant, but weakly load dependent through ln(l/a) (a ~ sqrt(Q)): 1.2152 at 50 kN, 1.2130 at
  103.4 kN, 1.2107 at 200 kN.
  It is therefore evaluated per load (a few math calls), not cached.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import integrate

from guide_health.models.contact.elastic import effective_modulus_pa
from guide_health.models.contact.hertz_line import (
    HertzLineContact,
    checked_load_n,
    contact_half_width_m,
    effective_radius_m,
    peak_contact_pressure_pa,
)

#: seed 003 Eq. 2 / Eq. 5 constants (Johnson, Contact Mechanics, 1985, Sec. 5.8)
EQ2_CENTRE_CONSTANT: float = 1.886
EQ5_END_CONSTANT: float = 1.193
#: seed 003 Eq. 6/7: delta = 4.05e-5 P^0.925 / l_e^0.85 [mm, N]; Eq. 7 prints 1/4.05e-5 as 2.47e4
PALMGREN_LOAD_EXPONENT: float = 0.925
PALMGREN_LENGTH_EXPONENT: float = 0.85
PALMGREN_STIFFNESS_EQ7: float = 2.47e4


def centre_approach_m(load_n: float, half_length_m: float, half_width_m: float,
                      effective_modulus_pa: float) -> float:
    """delta(0,0) = P/(pi l E*) (1.886 + ln(l/a)) [m]; l = half-length.  # seed 003 Eq. 2"""
    return (load_n / (math.pi * half_length_m * effective_modulus_pa)
            * (EQ2_CENTRE_CONSTANT + math.log(half_length_m / half_width_m)))


def approach_excess_along_roller_m(y_m: np.ndarray, load_n: float, half_length_m: float,
                                   effective_modulus_pa: float) -> np.ndarray:
    """delta(0,y) - delta(0,0) = -P/(2 pi l E*) ln(1 - (y/l)^2) >= 0 [m], |y| < l.  # seed 003 Eq. 4 (sign: -Delta_y)"""
    ratio = np.clip(np.abs(np.asarray(y_m, dtype=float)) / half_length_m, 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return -load_n / (2.0 * math.pi * half_length_m * effective_modulus_pa) * np.log1p(-ratio ** 2)


def end_approach_excess_m(load_n: float, half_length_m: float, half_width_m: float,
                          effective_modulus_pa: float) -> float:
    """delta(0,l) - delta(0,0) = -Delta_l = P/(2 pi l E*) (1.193 + ln(l/a)) [m].  # seed 003 Eq. 5"""
    return (load_n / (2.0 * math.pi * half_length_m * effective_modulus_pa)
            * (EQ5_END_CONSTANT + math.log(half_length_m / half_width_m)))


def palmgren_line_stiffness(effective_length_m: float) -> float:
    """k1 = (2.47e4 l_e^0.85)^(1/0.925) / l_e in N/mm per mm^(1/0.925) (seed units N, mm).  # seed 003 Eq. 7"""
    length_mm = effective_length_m * 1e3
    stiffness = PALMGREN_STIFFNESS_EQ7 * length_mm ** PALMGREN_LENGTH_EXPONENT
    return stiffness ** (1.0 / PALMGREN_LOAD_EXPONENT) / length_mm


def line_load_from_approach_n_m(approach_m: np.ndarray | float, effective_length_m: float) -> np.ndarray | float:
    """P1 = k1 delta^(1/0.925) [N/m] from the local approach delta [m] (Palmgren).  # seed 003 Eqs. 6/7"""
    k1 = palmgren_line_stiffness(effective_length_m)
    approach_mm = np.clip(np.asarray(approach_m, dtype=float) * 1e3, 0.0, None)
    result = k1 * approach_mm ** (1.0 / PALMGREN_LOAD_EXPONENT) * 1e3  # N/mm -> N/m
    return float(result) if np.ndim(result) == 0 else result


def end_to_centre_pressure_ratio(load_n: float, half_length_m: float, hertz_half_width_m: float) -> float:
    """p0(end)/p0(centre) = (delta_end/delta_centre)^(1/(2*0.925)) (E*, k1 cancel).  # seed 003 Eqs. 2, 5, 7, 10"""
    log_ratio = math.log(half_length_m / hertz_half_width_m)
    approach_ratio = 1.0 + (EQ5_END_CONSTANT + log_ratio) / (2.0 * (EQ2_CENTRE_CONSTANT + log_ratio))
    return approach_ratio ** (1.0 / (2.0 * PALMGREN_LOAD_EXPONENT))


@dataclass(slots=True)
class FiniteRollerScalars:
    """Scalar results of the seed's finite-roller method for one roller load (SI units)."""

    load_n: float
    hertz: HertzLineContact
    centre_approach_m: float
    end_approach_m: float
    centre_line_load_n_m: float
    end_line_load_n_m: float
    centre_half_width_m: float
    end_half_width_m: float
    p0_centre_pa: float
    p0_end_pa: float
    end_plateau_start_m: float   # |y| from which Eq. 4 exceeds the Eq. 5 end value

    @property
    def end_stress_ratio(self) -> float:
        """p0(end)/p0(centre) [-]."""
        return self.p0_end_pa / self.p0_centre_pa if self.p0_centre_pa > 0 else float("nan")


def finite_roller_scalars(load_n: float, half_length_m: float, radius_m: float, effective_modulus_pa: float,
                          length_m: float, k1: float) -> FiniteRollerScalars:
    """Eqs. 2, 3, 5, 7, 8, 10 with plain math (fast path and direct path share it)."""
    line_load = load_n / length_m
    hertz_a = contact_half_width_m(line_load, radius_m, effective_modulus_pa)             # Eq. 3
    hertz = HertzLineContact(line_load, effective_modulus_pa, radius_m, hertz_a,
                             peak_contact_pressure_pa(line_load, hertz_a))
    delta_c = centre_approach_m(load_n, half_length_m, hertz_a, effective_modulus_pa)     # Eq. 2
    delta_e = delta_c + end_approach_excess_m(load_n, half_length_m, hertz_a, effective_modulus_pa)  # Eq. 5
    exponent = 1.0 / PALMGREN_LOAD_EXPONENT
    p1_c = k1 * (delta_c * 1e3) ** exponent * 1e3                                         # Eq. 7 [N/m]
    p1_e = k1 * (delta_e * 1e3) ** exponent * 1e3
    a_c = contact_half_width_m(p1_c, radius_m, effective_modulus_pa)                      # Eq. 8
    a_e = contact_half_width_m(p1_e, radius_m, effective_modulus_pa)
    # Eq. 4 reaches the Eq. 5 value where -ln(1-(y/l)^2) = 1.193 + ln(l/a)
    plateau = half_length_m * math.sqrt(-math.expm1(-(EQ5_END_CONSTANT + math.log(half_length_m / hertz_a))))
    return FiniteRollerScalars(load_n, hertz, delta_c, delta_e, p1_c, p1_e, a_c, a_e,
                               peak_contact_pressure_pa(p1_c, a_c), peak_contact_pressure_pa(p1_e, a_e),  # Eq. 10
                               plateau)


@dataclass(frozen=True)
class FiniteRollerContact:
    """Finite-roller contact along the roller (seed 003 Eqs. 2-10); arrays over ``y_m`` [m]."""

    scalars: FiniteRollerScalars
    y_m: np.ndarray
    approach_m: np.ndarray
    line_load_n_m: np.ndarray
    half_width_m: np.ndarray
    p0_pa: np.ndarray
    load_balance_ratio: float     # integral of P1(y) dy over the roller / Q


def finite_roller_contact(load_n: float, roller_length_m: float, roller_diameter_m: float,
                          youngs_modulus_pa: float, poisson: float, raceway_radius_m: float = math.inf,
                          points: int = 401) -> FiniteRollerContact:
    """Approach, line load, half-width and p0 along a roller of length l_e = 2 l.  # seed 003 Eqs. 2-10

    load_n: Q [N]; roller_length_m: effective contact length l_e [m] (Eq. 2 uses l = l_e/2);
    ``points`` samples y in [-l, l] (the ends included, where Eq. 5 applies).
    """
    load = checked_load_n("roller load", load_n)
    if load == 0:
        raise ValueError("roller load must be > 0 for the finite-roller method")
    modulus = effective_modulus_pa(youngs_modulus_pa, poisson)
    radius = effective_radius_m(roller_diameter_m, raceway_radius_m)
    half_length = 0.5 * roller_length_m
    k1 = palmgren_line_stiffness(roller_length_m)
    s = finite_roller_scalars(load, half_length, radius, modulus, roller_length_m, k1)
    y = np.linspace(-half_length, half_length, points)
    approach = np.minimum(s.centre_approach_m + approach_excess_along_roller_m(y, load, half_length, modulus),
                          s.end_approach_m)                                   # Eq. 4 capped by Eq. 5
    line_load = line_load_from_approach_n_m(approach, roller_length_m)
    half_width = np.sqrt(4.0 * line_load * radius / (math.pi * modulus))      # Eq. 8
    p0 = 2.0 * line_load / (math.pi * half_width)                             # Eq. 10

    def line_load_at(y_abs: float) -> float:
        a = s.centre_approach_m + float(approach_excess_along_roller_m(y_abs, load, half_length, modulus))
        return float(line_load_from_approach_n_m(min(a, s.end_approach_m), roller_length_m))

    inner, _ = integrate.quad(line_load_at, 0.0, s.end_plateau_start_m, limit=200, epsrel=1e-10)
    total = 2.0 * (inner + (half_length - s.end_plateau_start_m) * s.end_line_load_n_m)
    return FiniteRollerContact(s, y, approach, line_load, half_width, p0, total / load)
