"""Roller/raceway contact of three-row roller slewing bearings (seed 003).

Source: FENG Jianyou, QI Xiaoli, TONG Jinyu, "Non-Hertz contact characteristics analysis of three-row
roller slewing bearings", China Mechanical Engineering 28(4), 2017, DOI 10.3969/j.issn.1004-132X.2017.04.004
("seed 003" below; equation numbers are the paper's).

Pure physics: numpy/scipy only, SI units at every public boundary (m, N, Pa, N m), no ROS, no I/O.
The seed's Eqs. 6/7 (Palmgren's line-contact stiffness) are dimensional in N and mm; they are evaluated in
those units internally and converted at the function boundary.

Contents
--------
* Eq. 1: roller loads of the two axial rows from F_a and M_T (rigid rings, zero clearance), and of the
  radial row from F_r (Stribeck/Harris, line contact, zero clearance: Q_r,max = 4.08 F_r / n_r).
* Ideal Hertz line contact (E* = E/(2(1-nu^2)) for two equal steels, Johnson 1985 Sec. 4.2).
* The seed's finite-roller ("non-Hertz") method, Eqs. 2-10: approach at the roller centre (Eq. 2) and at
  the end (Eq. 5), approach along the roller (Eq. 4), line load from Palmgren's stiffness (Eqs. 6/7),
  half-width and peak pressure along the roller (Eqs. 8-10).
* McEwen's plane-strain stress field under a Hertz pressure plus a proportional friction traction
  (Eqs. 11-24), vectorised over (x, z) grids, with von Mises and maximum-shear maxima located on a grid and
  refined with scipy.optimize.
* ``slewing_contact_report`` (direct, uncached) and ``SlewingContactModel`` (geometry-only work done once;
  a report costs microseconds) returning the INTERFACES.md ``contact slewing --json`` keys.

Sign conventions
----------------
x: across the contact (rolling direction), z: depth into the raceway (z >= 0), y: along the roller axis
from its mid-length. Stresses: tension positive, so the contact pressure gives negative sigma_z.
``friction`` f is signed: f > 0 is a surface traction q(x) = f p(x) acting on the raceway in +x.

Notes on the seed's printed equations (checked numerically, see test/test_roller_contact.py)
------------------------------------------------------------------------------------------
* McEwen signs. Eqs. 11-12 (normal sigma_x, sigma_z) agree with a direct integration of Flamant's line-load
  solutions (Johnson Eqs. 2.15/2.16) when m >= 0 carries the sign of z and n the sign of x (the paper's text
  says the reverse: with m signed by x, sigma_z would turn tensile for x < 0). With that, the printed
  Eqs. 14 (tau_xz,p), 17 (sigma_x,q) and 19 (tau_xz,q) have the opposite sign to the Flamant field for a
  traction in +x, while Eq. 18 agrees; no single axis or traction-direction convention makes all four
  printed signs consistent. This module uses the Flamant-consistent signs, which also satisfy the relations
  the paper states, (sigma_z)_q/q0 = (tau_xz)_p/p0 and (tau_xz)_q/q0 = (sigma_x)_p/p0. On the axis x = 0 the
  printed and the consistent fields have identical invariants (so the paper's Figs. 7-8 are unaffected);
  off the axis they differ: at f = 0.1, nu = 0.3 the printed combination has a global von Mises maximum of
  0.591 p0 (x = 0.47 a, z = 0.57 a) and maximum shear 0.322 p0, the consistent field 0.565 p0
  (x = 0.29 a, z = 0.67 a) and 0.305 p0 (x = 0.33 a, z = 0.74 a).
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

Finding: the seed's von Mises values 0.53 p0 (Figs. 7-8) and 0.409 p0 (Table 1)
--------------------------------------------------------------------------------
Table 1 gives von Mises/contact pressure = 1328/3245 = 0.40924, 1095/2675 = 0.40935, 1127/2754 = 0.40922:
the same ratio at the end, the centre and for ideal Hertz, so the values come from one fixed point of the
normalised field (or a closed form), scaled by each p0. Figs. 5-6 state that the curves along the roller
are taken at the contact centre x = 0, z = 0, i.e. at the SURFACE, not at the subsurface maximum.
Candidates (plane strain, sigma_y = nu (sigma_x + sigma_z), nu = 0.3; values / p0), computed by
``seed003_von_mises_candidates``:

* surface centre, f = 0:   (1 - 2 nu)                          = 0.4000  (-2.3 %)
* surface centre, f = 0.1: sqrt((1 - 2 nu)^2 + 3 f^2)          = 0.4359  (+6.5 %)
* surface centre, f = 0.1 with a surface shear of f p0 / 2: sqrt(0.16 + 3 (f/2)^2) = 0.40927, equal to all
  three Table 1 ratios within their rounding (+-0.00015 for values rounded to 1 MPa). This is the only
  candidate found that reproduces 0.409 at the stated point with the stated nu = 0.3 and f = 0.1; it needs a
  factor 1/2 on the friction shear (the McEwen field itself gives tau_xz = f p0 at the surface centre), so
  it is a reproduction of the published number, not a justification of it. (Equivalently, frictionless
  with nu = 0.2954, which the paper does not use.)
* the subsurface von Mises maximum (0.558-0.559 p0) is 36 % higher than 0.409, so Table 1's "von Mises"
  cannot be the maximum; plane stress (sigma_y = 0) gives 1.01 p0 at the surface; sqrt(3) tau_max = 0.521.
  Conclusion: Table 1's von Mises column is the surface value at the contact centre, not a design
  (subsurface) stress; the report's ``von_mises_max_MPa`` is the subsurface maximum instead.

Figs. 7-8 state the von Mises maximum 0.53 p0 at z = 0.7 a1 and the shear maximum 0.301 p0 at z = 0.78 a1
(roller end, x = 0). The shear value and both depths are reproduced (0.3009 p0 at 0.780 a; von Mises
maximum at 0.697 a), but the von Mises maximum at x = 0 is 0.5588 p0 for f = 0.1 (0.5575 for f = 0;
Johnson's classic 0.56 p0 at 0.70 a), 5.4 % above 0.53. Candidates: sqrt(3) tau_max = 0.521 p0 (at 0.78 a,
-1.7 %); von Mises at z = a = 0.534 p0 (+0.8 %, but not the maximum and not at 0.7 a); plane stress
(sigma_y = 0) has its maximum at the surface; nu = 0.40 would be needed for a 0.53 p0 maximum. No candidate
reproduces 0.53 p0 AT 0.7 a; the value is most likely read from the FE curve or a plotting/rounding slip,
and it is not used here. The model is not tuned to any of these values.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from scipy import integrate, optimize

from guide_health.params import SLEWING_MONITOR_DEFAULTS, validate_slewing_params

# ----------------------------------------------------------------------------------------------------
# Constants (parameters and their defaults: guide_health.params.SLEWING_MONITOR_SCHEMA)
# ----------------------------------------------------------------------------------------------------
#: seed 003 Sec. 4 example: 131.32.2000.00Z, E = 210 GPa, nu = 0.3, d = 32 mm, l = 31.3 mm, f = 0.1
SEED003_EXAMPLE_ROLLER_LOAD_N: float = 103_400.0

#: Radial row, line contact, zero clearance: Q_max = F_r / (n J_r(0.5)), J_r = 0.2453 -> 4.08
#: (Stribeck; Harris & Kotzalas, Rolling Bearing Analysis, 5th ed., Essential Concepts, Ch. 7).
RADIAL_ROW_LINE_CONTACT_FACTOR: float = 4.08

#: seed 003 Eq. 2 / Eq. 5 constants (Johnson, Contact Mechanics, 1985, Sec. 5.8)
EQ2_CENTRE_CONSTANT: float = 1.886
EQ5_END_CONSTANT: float = 1.193
#: seed 003 Eq. 6/7: delta = 4.05e-5 P^0.925 / l_e^0.85 [mm, N]; Eq. 7 prints 1/4.05e-5 as 2.47e4
PALMGREN_LOAD_EXPONENT: float = 0.925
PALMGREN_LENGTH_EXPONENT: float = 0.85
PALMGREN_STIFFNESS_EQ7: float = 2.47e4

def _check_load(name: str, value: float, allow_negative: bool = False) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value < 0 and not allow_negative:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


# ----------------------------------------------------------------------------------------------------
# Eq. 1: roller loads of the rows
# ----------------------------------------------------------------------------------------------------
@dataclass(slots=True)
class AxialRowLoads:
    """Maximum roller loads of the two axial rows [N] (seed 003 Eq. 1).

    ``main_row`` is the row that F_a > 0 (compressive, pressing the rings together, INTERFACES.md
    ``force.z``) loads; ``opposite_row`` is the retaining row on the other side. A row whose maximum is
    <= 0 carries no roller at all: the flags say so. ``main_row_partly_unloaded`` is True when the moment
    lifts the main row's rollers on the far side (4 M_T/(n D0) > F_a/n), i.e. the opposite row takes over
    there.
    """

    main_row_max_n: float
    opposite_row_max_n: float
    main_row_unloaded: bool
    opposite_row_unloaded: bool
    main_row_partly_unloaded: bool

    @property
    def max_n(self) -> float:
        """Highest roller load of both axial rows [N]."""
        return max(self.main_row_max_n, self.opposite_row_max_n, 0.0)


def axial_row_roller_loads(axial_load_n: float, tilting_moment_nm: float, roller_count: int,
                           raceway_diameter_m: float) -> AxialRowLoads:
    """Q_max of both axial rows: 4 M_T/(n D0) +- F_a/n [N]; rigid rings, zero clearance.  # seed 003 Eq. 1

    axial_load_n: F_a [N], signed (> 0 loads the main row); tilting_moment_nm: M_T [N m] (its magnitude
    is used: the tilting direction only chooses the azimuth); roller_count: n per axial row;
    raceway_diameter_m: D0 [m]. The roller pair at azimuth psi carries F_a/n + (4 M_T/(n D0)) cos psi;
    positive values press on the main row, negative ones on the opposite row.
    """
    axial = _check_load("axial load", axial_load_n, allow_negative=True)
    moment = abs(_check_load("tilting moment", tilting_moment_nm, allow_negative=True))
    moment_term = 4.0 * moment / (roller_count * raceway_diameter_m)
    axial_term = axial / roller_count
    main = moment_term + axial_term
    opposite = moment_term - axial_term
    return AxialRowLoads(
        main_row_max_n=max(main, 0.0),
        opposite_row_max_n=max(opposite, 0.0),
        main_row_unloaded=main <= 0.0,
        opposite_row_unloaded=opposite <= 0.0,
        main_row_partly_unloaded=main > 0.0 and moment_term > axial_term,
    )


def radial_row_roller_load_max_n(radial_load_n: float, roller_count: int) -> float:
    """Q_r,max = 4.08 F_r / n_r [N] (line contact, zero clearance).  # Harris & Kotzalas Ch. 7 (Stribeck)"""
    return RADIAL_ROW_LINE_CONTACT_FACTOR * abs(_check_load("radial load", radial_load_n, True)) / roller_count


# ----------------------------------------------------------------------------------------------------
# Ideal Hertz line contact
# ----------------------------------------------------------------------------------------------------
def effective_modulus_pa(youngs_modulus_pa: float, poisson: float,
                         youngs_modulus_2_pa: float | None = None, poisson_2: float | None = None) -> float:
    """E* = E1 E2 / (E2 (1-nu1^2) + E1 (1-nu2^2)) [Pa]; E/(2(1-nu^2)) for equal steels.  # seed 003 Eq. 3"""
    e2 = youngs_modulus_pa if youngs_modulus_2_pa is None else youngs_modulus_2_pa
    n2 = poisson if poisson_2 is None else poisson_2
    return youngs_modulus_pa * e2 / (e2 * (1.0 - poisson ** 2) + youngs_modulus_pa * (1.0 - n2 ** 2))


def effective_radius_m(roller_diameter_m: float, raceway_radius_m: float = math.inf) -> float:
    """R = 1/(2/d + 1/R_race) [m]; R_race > 0 convex, < 0 concave, inf flat (axial rows).  # Johnson Sec. 4.2"""
    curvature = 2.0 / roller_diameter_m + (0.0 if math.isinf(raceway_radius_m) else 1.0 / raceway_radius_m)
    if not curvature > 0:
        raise ValueError("raceway curvature must be smaller than the roller's (conforming contact)")
    return 1.0 / curvature


def contact_half_width_m(line_load_n_m: float, effective_radius_m_: float, modulus_pa: float) -> float:
    """a = sqrt(4 P1 R/(pi E*)) = sqrt(2 P1 d/(pi E*)) for a flat raceway [m].  # seed 003 Eq. 3/8"""
    return math.sqrt(4.0 * line_load_n_m * effective_radius_m_ / (math.pi * modulus_pa))


def peak_contact_pressure_pa(line_load_n_m: float, half_width_m: float) -> float:
    """p0 = 2 P1/(pi a) [Pa].  # seed 003 Eq. 10"""
    return 2.0 * line_load_n_m / (math.pi * half_width_m) if half_width_m > 0 else 0.0


def pressure_across_contact_pa(x_m: np.ndarray, line_load_n_m: float, half_width_m: float) -> np.ndarray:
    """p(x) = 2 P1/(pi a^2) sqrt(a^2 - x^2) inside |x| < a, 0 outside [Pa].  # seed 003 Eq. 9"""
    x = np.asarray(x_m, dtype=float)
    inside = np.clip(half_width_m ** 2 - x ** 2, 0.0, None)
    return 2.0 * line_load_n_m / (math.pi * half_width_m ** 2) * np.sqrt(inside)


@dataclass(slots=True)
class HertzLineContact:
    """Ideal (infinitely long) Hertz line contact: line load [N/m], E* [Pa], R [m], a [m], p0 [Pa]."""

    line_load_n_m: float
    modulus_pa: float
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
    load = _check_load("roller load", load_n)
    modulus = effective_modulus_pa(youngs_modulus_pa, poisson)
    radius = effective_radius_m(roller_diameter_m, raceway_radius_m)
    line_load = load / contact_length_m
    half_width = contact_half_width_m(line_load, radius, modulus)
    return HertzLineContact(line_load, modulus, radius, half_width, peak_contact_pressure_pa(line_load, half_width))


# ----------------------------------------------------------------------------------------------------
# Finite roller (seed 003 Eqs. 2-10)
# ----------------------------------------------------------------------------------------------------
def centre_approach_m(load_n: float, half_length_m: float, half_width_m: float, modulus_pa: float) -> float:
    """delta(0,0) = P/(pi l E*) (1.886 + ln(l/a)) [m]; l = half-length.  # seed 003 Eq. 2"""
    return load_n / (math.pi * half_length_m * modulus_pa) * (EQ2_CENTRE_CONSTANT + math.log(half_length_m / half_width_m))


def approach_excess_along_roller_m(y_m: np.ndarray, load_n: float, half_length_m: float,
                                   modulus_pa: float) -> np.ndarray:
    """delta(0,y) - delta(0,0) = -P/(2 pi l E*) ln(1 - (y/l)^2) >= 0 [m], |y| < l.  # seed 003 Eq. 4 (sign: -Delta_y)"""
    ratio = np.clip(np.abs(np.asarray(y_m, dtype=float)) / half_length_m, 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return -load_n / (2.0 * math.pi * half_length_m * modulus_pa) * np.log1p(-ratio ** 2)


def end_approach_excess_m(load_n: float, half_length_m: float, half_width_m: float, modulus_pa: float) -> float:
    """delta(0,l) - delta(0,0) = -Delta_l = P/(2 pi l E*) (1.193 + ln(l/a)) [m].  # seed 003 Eq. 5"""
    return load_n / (2.0 * math.pi * half_length_m * modulus_pa) * (EQ5_END_CONSTANT + math.log(half_length_m / half_width_m))


def palmgren_line_stiffness(effective_length_m: float) -> float:
    """k1 = (2.47e4 l_e^0.85)^(1/0.925) / l_e in N/mm per mm^(1/0.925) (seed units N, mm).  # seed 003 Eq. 7"""
    length_mm = effective_length_m * 1e3
    return (PALMGREN_STIFFNESS_EQ7 * length_mm ** PALMGREN_LENGTH_EXPONENT) ** (1.0 / PALMGREN_LOAD_EXPONENT) / length_mm


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


def _finite_roller_scalars(load_n: float, half_length_m: float, radius_m: float, modulus_pa: float,
                           length_m: float, k1: float) -> FiniteRollerScalars:
    """Eqs. 2, 3, 5, 7, 8, 10 with plain math (fast path and direct path share it)."""
    line_load = load_n / length_m
    hertz_a = math.sqrt(4.0 * line_load * radius_m / (math.pi * modulus_pa))
    hertz = HertzLineContact(line_load, modulus_pa, radius_m, hertz_a, 2.0 * line_load / (math.pi * hertz_a))
    log_ratio = math.log(half_length_m / hertz_a)
    base = load_n / (math.pi * half_length_m * modulus_pa)                      # P/(pi l E*)
    delta_c = base * (EQ2_CENTRE_CONSTANT + log_ratio)                          # Eq. 2
    excess_end = 0.5 * base * (EQ5_END_CONSTANT + log_ratio)                    # Eq. 5
    delta_e = delta_c + excess_end
    exponent = 1.0 / PALMGREN_LOAD_EXPONENT
    p1_c = k1 * (delta_c * 1e3) ** exponent * 1e3                               # Eq. 7 [N/m]
    p1_e = k1 * (delta_e * 1e3) ** exponent * 1e3
    a_c = math.sqrt(4.0 * p1_c * radius_m / (math.pi * modulus_pa))             # Eq. 8
    a_e = math.sqrt(4.0 * p1_e * radius_m / (math.pi * modulus_pa))
    # Eq. 4 reaches the Eq. 5 value where -ln(1-(y/l)^2) = 1.193 + ln(l/a)
    plateau = half_length_m * math.sqrt(-math.expm1(-(EQ5_END_CONSTANT + log_ratio)))
    return FiniteRollerScalars(load_n, hertz, delta_c, delta_e, p1_c, p1_e, a_c, a_e,
                               2.0 * p1_c / (math.pi * a_c), 2.0 * p1_e / (math.pi * a_e), plateau)  # Eq. 10


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
    load = _check_load("roller load", load_n)
    if load == 0:
        raise ValueError("roller load must be > 0 for the finite-roller method")
    modulus = effective_modulus_pa(youngs_modulus_pa, poisson)
    radius = effective_radius_m(roller_diameter_m, raceway_radius_m)
    half_length = 0.5 * roller_length_m
    k1 = palmgren_line_stiffness(roller_length_m)
    s = _finite_roller_scalars(load, half_length, radius, modulus, roller_length_m, k1)
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


# ----------------------------------------------------------------------------------------------------
# McEwen stress field (seed 003 Eqs. 11-24)
# ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StressField:
    """Plane-strain stress field [Pa] on the broadcast (x, z) grid; tension positive.

    sigma_1 >= sigma_2 are the in-plane principal stresses (Eq. 24), sigma_y the third (Eq. 23).
    ``max_shear`` is the seed's maximum shear: half the difference of the in-plane principal stresses,
    (sigma_1 - sigma_2)/2 (Tresca in the x-z plane; "tau_1" of Johnson). ``tresca_shear`` is the 3-D
    Tresca value max|sigma_i - sigma_j|/2 including sigma_y (equal to max_shear below the surface where
    sigma_y is the intermediate principal stress, larger near the surface).
    """

    sigma_x: np.ndarray
    sigma_z: np.ndarray
    tau_xz: np.ndarray
    sigma_y: np.ndarray
    sigma_1: np.ndarray
    sigma_2: np.ndarray
    von_mises: np.ndarray
    max_shear: np.ndarray
    tresca_shear: np.ndarray


def _mcewen_mn(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """McEwen's m, n for a = 1; m >= 0 (sign of z >= 0), n with the sign of x.  # seed 003 Eqs. 15/16

    The smaller of m^2, n^2 is taken from m^2 n^2 = x^2 z^2 to avoid cancellation.
    """
    aux = 1.0 - x * x + z * z
    root = np.sqrt(aux * aux + 4.0 * x * x * z * z)
    xz2 = x * x * z * z
    with np.errstate(divide="ignore", invalid="ignore"):
        big_m = aux >= 0.0
        m2_direct = 0.5 * (root + aux)
        n2_direct = 0.5 * (root - aux)
        m2 = np.where(big_m, m2_direct, np.where(n2_direct > 0, xz2 / n2_direct, 0.0))
        n2 = np.where(big_m, np.where(m2_direct > 0, xz2 / m2_direct, 0.0), n2_direct)
    return np.sqrt(m2), np.sign(x) * np.sqrt(n2)


def mcewen_normalised_field(x_over_a: np.ndarray, z_over_a: np.ndarray, friction: float,
                            poisson: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """sigma_x, sigma_z, tau_xz, sigma_y divided by p0, at (x/a, z/a), z >= 0.  # seed 003 Eqs. 11-23

    Pressure p = p0 sqrt(1 - x^2/a^2) plus traction q = f p (f signed, > 0 acts in +x). Signs are the
    Flamant-consistent ones (module docstring): Eq. 14, 17, 19 enter with the opposite printed sign.
    """
    x = np.asarray(x_over_a, dtype=float)
    z = np.abs(np.asarray(z_over_a, dtype=float))
    x, z = np.broadcast_arrays(x, z)
    m, n = _mcewen_mn(x, z)
    r = m * m + n * n
    with np.errstate(divide="ignore", invalid="ignore"):
        zn = np.where(r > 0, (z * z + n * n) / r, 0.0)
        mz = np.where(r > 0, (m * m - z * z) / r, 0.0)
    bracket_p = m * (1.0 + zn) - 2.0 * z
    sigma_x_p = -bracket_p                                   # Eq. 11
    sigma_z_p = -m * (1.0 - zn)                              # Eq. 12
    tau_p = -n * mz                                          # Eq. 14 (Flamant sign)
    sigma_x_q = n * (2.0 + mz) - 2.0 * x                     # Eq. 17 (Flamant sign); 2 - (z^2-m^2)/r = 2 + mz
    sigma_z_q = tau_p                                        # Eq. 18: (sigma_z)_q/q0 = (tau_xz)_p/p0
    tau_q = sigma_x_p                                        # Eq. 19: (tau_xz)_q/q0 = (sigma_x)_p/p0
    sigma_x = sigma_x_p + friction * sigma_x_q               # Eq. 20
    sigma_z = sigma_z_p + friction * sigma_z_q               # Eq. 21
    tau_xz = tau_p + friction * tau_q                        # Eq. 22
    sigma_y = poisson * (sigma_x + sigma_z)                  # Eq. 23 (plane strain)
    return sigma_x, sigma_z, tau_xz, sigma_y


def _invariants(sigma_x, sigma_z, tau_xz, sigma_y):
    centre = 0.5 * (sigma_x + sigma_z)
    radius = np.sqrt((0.5 * (sigma_x - sigma_z)) ** 2 + tau_xz ** 2)
    sigma_1, sigma_2 = centre + radius, centre - radius                        # Eq. 24
    von_mises = np.sqrt(0.5 * ((sigma_x - sigma_y) ** 2 + (sigma_y - sigma_z) ** 2 + (sigma_z - sigma_x) ** 2)
                        + 3.0 * tau_xz ** 2)
    tresca = 0.5 * np.maximum(sigma_1 - sigma_2, np.maximum(np.abs(sigma_1 - sigma_y), np.abs(sigma_2 - sigma_y)))
    return sigma_1, sigma_2, von_mises, radius, tresca


def mcewen_stress_field(x_m: np.ndarray, z_m: np.ndarray, half_width_m: float, p0_pa: float,
                        friction: float, poisson: float) -> StressField:
    """Stress field [Pa] under a Hertz line contact with friction, vectorised over (x, z) [m].

    x_m, z_m broadcast against each other (e.g. ``np.meshgrid``); z_m is depth into the raceway.
    # seed 003 Eqs. 11-24 (McEwen 1949; Johnson 1985 Sec. 7.2)
    """
    if not half_width_m > 0:
        raise ValueError(f"half width must be > 0, got {half_width_m!r}")
    sx, sz, txz, sy = mcewen_normalised_field(np.asarray(x_m) / half_width_m, np.asarray(z_m) / half_width_m,
                                              friction, poisson)
    s1, s2, vm, tau1, tresca = _invariants(sx, sz, txz, sy)
    return StressField(*(p0_pa * v for v in (sx, sz, txz, sy, s1, s2, vm, tau1, tresca)))


QUANTITIES = ("von_mises", "max_shear", "tresca_shear")


def _normalised_quantity(quantity: str, x: np.ndarray, z: np.ndarray, friction: float, poisson: float) -> np.ndarray:
    sx, sz, txz, sy = mcewen_normalised_field(x, z, friction, poisson)
    s1, s2, vm, tau1, tresca = _invariants(sx, sz, txz, sy)
    return {"von_mises": vm, "max_shear": tau1, "tresca_shear": tresca}[quantity]


@dataclass(frozen=True)
class FieldMaximum:
    """Maximum of a stress quantity: value / p0, position x / a and depth z / a."""

    value_over_p0: float
    x_over_a: float
    z_over_a: float


def field_maximum(quantity: str, friction: float, poisson: float, on_axis: bool = False,
                  x_range: tuple[float, float] = (-1.5, 1.5), z_max_over_a: float = 3.0,
                  grid_points: int = 121) -> FieldMaximum:
    """Locate the maximum of ``quantity`` (von_mises | max_shear | tresca_shear) in the McEwen field.

    Coarse grid over x/a in ``x_range`` and z/a in [0, z_max_over_a] (only x = 0 when ``on_axis``),
    refined with scipy.optimize (bounded scalar search on the axis, bounded Nelder-Mead in the plane).
    # seed 003 Eqs. 20-24
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")
    z_grid = np.linspace(0.0, z_max_over_a, grid_points)
    if on_axis:
        values = _normalised_quantity(quantity, np.zeros_like(z_grid), z_grid, friction, poisson)
        i = int(np.argmax(values))
        lo, hi = z_grid[max(i - 1, 0)], z_grid[min(i + 1, grid_points - 1)]
        res = optimize.minimize_scalar(
            lambda z: -float(_normalised_quantity(quantity, np.zeros(1), np.array([z]), friction, poisson)[0]),
            bounds=(lo, hi), method="bounded", options={"xatol": 1e-9})
        best = (-res.fun, 0.0, float(res.x)) if -res.fun >= values[i] else (values[i], 0.0, z_grid[i])
        return FieldMaximum(float(best[0]), 0.0, float(best[2]))
    x_grid = np.linspace(x_range[0], x_range[1], grid_points)
    xx, zz = np.meshgrid(x_grid, z_grid)
    values = _normalised_quantity(quantity, xx, zz, friction, poisson)
    j = np.unravel_index(int(np.argmax(values)), values.shape)
    start = np.array([xx[j], zz[j]])

    def negative(point: np.ndarray) -> float:
        return -float(_normalised_quantity(quantity, point[:1], point[1:], friction, poisson)[0])

    res = optimize.minimize(negative, start, method="Nelder-Mead",
                            bounds=[x_range, (0.0, z_max_over_a)],
                            options={"xatol": 1e-9, "fatol": 1e-12, "maxiter": 4000})
    if -res.fun >= values[j]:
        return FieldMaximum(float(-res.fun), float(res.x[0]), float(res.x[1]))
    return FieldMaximum(float(values[j]), float(xx[j]), float(zz[j]))


@dataclass(frozen=True)
class McEwenMaxima:
    """Geometry-free McEwen maxima at one (friction, poisson): multiples of p0 and of a."""

    von_mises: FieldMaximum
    max_shear: FieldMaximum
    von_mises_on_axis: FieldMaximum
    max_shear_on_axis: FieldMaximum
    von_mises_surface_centre_over_p0: float


def mcewen_maxima(friction: float, poisson: float) -> McEwenMaxima:
    """All field maxima used by the report (computed, ~10 ms; see ``cached_mcewen_maxima``).  # seed 003 Eqs. 20-24"""
    surface = float(_normalised_quantity("von_mises", np.zeros(1), np.zeros(1), friction, poisson)[0])
    return McEwenMaxima(
        von_mises=field_maximum("von_mises", friction, poisson),
        max_shear=field_maximum("max_shear", friction, poisson),
        von_mises_on_axis=field_maximum("von_mises", friction, poisson, on_axis=True),
        max_shear_on_axis=field_maximum("max_shear", friction, poisson, on_axis=True),
        von_mises_surface_centre_over_p0=surface,
    )


@lru_cache(maxsize=64)
def cached_mcewen_maxima(friction: float, poisson: float) -> McEwenMaxima:
    """``mcewen_maxima`` memoised on (friction, poisson)."""
    return mcewen_maxima(float(friction), float(poisson))


def seed003_von_mises_candidates(friction: float = 0.1, poisson: float = 0.3) -> dict[str, float]:
    """Candidate readings of the seed's von Mises figures (0.53 p0 in Fig. 7, 0.409 p0 in Table 1), / p0.

    Each value is computed from the McEwen field (or stated closed form); see the module docstring.
    """
    zero = np.zeros(1)

    def vm(f: float, nu: float, z: float = 0.0) -> float:
        return float(_normalised_quantity("von_mises", zero, np.array([z]), f, nu)[0])

    sx, sz, txz, _ = (float(v[0]) for v in mcewen_normalised_field(zero, zero, friction, poisson))
    sy = poisson * (sx + sz)
    half_shear = math.sqrt(0.5 * ((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2) + 3.0 * (0.5 * txz) ** 2)
    plane_stress_surface = math.sqrt(sx * sx - sx * sz + sz * sz + 3.0 * txz * txz)
    axis_vm = field_maximum("von_mises", friction, poisson, on_axis=True)
    axis_tau = field_maximum("max_shear", friction, poisson, on_axis=True)
    return {
        "surface_centre_frictionless": vm(0.0, poisson),
        "surface_centre_with_friction": vm(friction, poisson),
        "surface_centre_half_friction_shear": half_shear,
        "surface_centre_plane_stress": plane_stress_surface,
        "von_mises_max_on_axis": axis_vm.value_over_p0,
        "von_mises_max_on_axis_depth_over_a": axis_vm.z_over_a,
        "sqrt3_max_shear_on_axis": math.sqrt(3.0) * axis_tau.value_over_p0,
        "von_mises_on_axis_at_depth_a": vm(friction, poisson, 1.0),
        "von_mises_on_axis_at_depth_0p7a": vm(friction, poisson, 0.7),
    }


# ----------------------------------------------------------------------------------------------------
# Report (INTERFACES.md `contact slewing --json`)
# ----------------------------------------------------------------------------------------------------
def contact_level(p_max_pa: float, allowable_pa: float, warn_fraction: float) -> int:
    """0 OK, 1 WARN above warn_fraction x allowable, 2 ERROR above allowable (judged on p_max)."""
    if not math.isfinite(p_max_pa) or p_max_pa > allowable_pa:
        return 2
    return 1 if p_max_pa > warn_fraction * allowable_pa else 0


def _level_message(level: int, p_max_mpa: float, position_mm: float, allowable_mpa: float) -> str:
    if p_max_mpa <= 0:
        return "no roller loaded"
    share = 100.0 * p_max_mpa / allowable_mpa
    where = "at the roller end" if position_mm > 0 else "at the roller centre"
    word = {0: "contact pressure OK", 1: "contact pressure near the allowable",
            2: "contact pressure above the allowable"}[level]
    return f"{word}: {p_max_mpa:.0f} MPa {where} ({share:.0f} % of {allowable_mpa:.0f} MPa)"


def _assemble(scalars: FiniteRollerScalars | None, maxima: McEwenMaxima, half_length_m: float,
              allowable_pa: float, warn_fraction: float, load_n: float) -> dict[str, Any]:
    """Report dict from the finite-roller scalars and the geometry-free McEwen maxima (plain floats)."""
    allowable_mpa = allowable_pa * 1e-6
    if scalars is None:  # unloaded
        out = {k: 0.0 for k in ("p_max_MPa", "p_max_position_mm", "p0_hertz_MPa", "p0_center_MPa", "p0_end_MPa",
                                "von_mises_max_MPa", "von_mises_depth_mm", "shear_max_MPa", "shear_depth_mm",
                                "von_mises_x_mm", "shear_x_mm", "von_mises_surface_MPa", "half_width_hertz_mm",
                                "half_width_center_mm", "half_width_end_mm", "approach_center_mm",
                                "approach_end_mm", "line_load_center_n_per_mm", "line_load_end_n_per_mm")}
        out.update(roller_load_max_n=load_n, end_stress_ratio=float("nan"), allowable_MPa=allowable_mpa,
                   level=0, message="no roller loaded", stress_model="seed003")
        return out
    p_end, a_end = scalars.p0_end_pa, scalars.end_half_width_m
    vm, tau = maxima.von_mises, maxima.max_shear
    p_max_mpa = p_end * 1e-6
    position_mm = half_length_m * 1e3
    level = contact_level(p_end, allowable_pa, warn_fraction)
    return {
        "roller_load_max_n": load_n,
        "p_max_MPa": p_max_mpa,
        "p_max_position_mm": position_mm,
        "p0_hertz_MPa": scalars.hertz.p0_pa * 1e-6,
        "p0_center_MPa": scalars.p0_centre_pa * 1e-6,
        "p0_end_MPa": p_max_mpa,
        "end_stress_ratio": p_end / scalars.p0_centre_pa,
        "von_mises_max_MPa": vm.value_over_p0 * p_max_mpa,
        "von_mises_depth_mm": vm.z_over_a * a_end * 1e3,
        "von_mises_x_mm": vm.x_over_a * a_end * 1e3,
        "shear_max_MPa": tau.value_over_p0 * p_max_mpa,
        "shear_depth_mm": tau.z_over_a * a_end * 1e3,
        "shear_x_mm": tau.x_over_a * a_end * 1e3,
        "von_mises_max_axis_MPa": maxima.von_mises_on_axis.value_over_p0 * p_max_mpa,
        "von_mises_axis_depth_mm": maxima.von_mises_on_axis.z_over_a * a_end * 1e3,
        "shear_max_axis_MPa": maxima.max_shear_on_axis.value_over_p0 * p_max_mpa,
        "shear_axis_depth_mm": maxima.max_shear_on_axis.z_over_a * a_end * 1e3,
        "von_mises_surface_MPa": maxima.von_mises_surface_centre_over_p0 * p_max_mpa,
        "half_width_hertz_mm": scalars.hertz.half_width_m * 1e3,
        "half_width_center_mm": scalars.centre_half_width_m * 1e3,
        "half_width_end_mm": a_end * 1e3,
        "approach_center_mm": scalars.centre_approach_m * 1e3,
        "approach_end_mm": scalars.end_approach_m * 1e3,
        "line_load_center_n_per_mm": scalars.centre_line_load_n_m * 1e-3,
        "line_load_end_n_per_mm": scalars.end_line_load_n_m * 1e-3,
        "allowable_MPa": allowable_mpa,
        "level": level,
        "message": _level_message(level, p_max_mpa, position_mm, allowable_mpa),
        "stress_model": "seed003",
    }


def _numerical_report(params: dict[str, Any], load_n: float, pressures: dict | None = None) -> dict[str, Any]:
    """stress_model 'numerical': pressures from roller_numerical (solved now, or `pressures` from a
    RollerContactTable lookup), subsurface maxima by McEwen under p_max."""
    if pressures is None:
        try:
            from guide_health.models.roller_numerical import numerical_contact_report
        except ImportError as exc:
            raise ValueError(f"stress_model 'numerical' is not available in this build ({exc})") from exc
        pressures = numerical_contact_report(params, load_n)
    report = dict(pressures)
    maxima = cached_mcewen_maxima(float(params["friction"]), float(params["poisson"]))
    modulus = effective_modulus_pa(params["youngs_modulus_pa"], params["poisson"])
    radius = effective_radius_m(params["roller_diameter_m"])
    p_max_mpa = float(report["p_max_MPa"])
    local_a_mm = 2.0 * radius * p_max_mpa * 1e6 / modulus * 1e3   # Hertz: p0 = E* a / (2 R)
    report.setdefault("p0_hertz_MPa", hertz_line_contact(load_n, params["roller_length_m"],
                                                         params["roller_diameter_m"], params["youngs_modulus_pa"],
                                                         params["poisson"]).p0_pa * 1e-6)
    allowable = float(params["allowable_contact_stress_pa"])
    level = contact_level(p_max_mpa * 1e6, allowable, float(params["warn_fraction"]))
    report.update(
        roller_load_max_n=load_n,
        von_mises_max_MPa=maxima.von_mises.value_over_p0 * p_max_mpa,
        von_mises_depth_mm=maxima.von_mises.z_over_a * local_a_mm,
        shear_max_MPa=maxima.max_shear.value_over_p0 * p_max_mpa,
        shear_depth_mm=maxima.max_shear.z_over_a * local_a_mm,
        subsurface_model="mcewen_on_p_max",
        allowable_MPa=allowable * 1e-6,
        level=level,
        message=_level_message(level, p_max_mpa, float(report.get("p_max_position_mm", 0.0)), allowable * 1e-6),
        stress_model="numerical",
    )
    return report


def slewing_contact_report(params: dict[str, Any], roller_load_n: float | None = None) -> dict[str, Any]:
    """Direct (uncached) roller/raceway report for one roller load [N] (INTERFACES.md keys).

    ``params``: slewing_monitor parameters (validated here); ``roller_load_n`` None = the seed 003
    example load, 103 400 N. The highest pressure (``p_max_MPa``) of the seed model is p0 at the roller
    end (Eq. 5); ``von_mises_max_MPa``/``shear_max_MPa`` are the subsurface maxima of the McEwen field
    (over x and z, friction included) under that pressure, depths in mm below the raceway surface.
    Level: 0 OK, 1 WARN above warn_fraction x allowable, 2 ERROR above allowable. All field maxima are
    recomputed on every call (grid + scipy.optimize, milliseconds): use ``SlewingContactModel`` live.
    # seed 003 Eqs. 2-24
    """
    validate_slewing_params(params)
    load = SEED003_EXAMPLE_ROLLER_LOAD_N if roller_load_n is None else _check_load("roller load", roller_load_n)
    if params["stress_model"] == "numerical":
        return _numerical_report(params, load)
    half_length = 0.5 * params["roller_length_m"]
    maxima = mcewen_maxima(float(params["friction"]), float(params["poisson"]))
    if load == 0:
        return _assemble(None, maxima, half_length, params["allowable_contact_stress_pa"], params["warn_fraction"], 0.0)
    contact = finite_roller_contact(load, params["roller_length_m"], params["roller_diameter_m"],
                                    params["youngs_modulus_pa"], params["poisson"])
    report = _assemble(contact.scalars, maxima, half_length, params["allowable_contact_stress_pa"],
                       params["warn_fraction"], load)
    report["load_balance_ratio"] = contact.load_balance_ratio
    return report


def _loads_extra(rows: AxialRowLoads, radial_max: float) -> tuple[float, dict[str, Any]]:
    candidates = {"axial_main": rows.main_row_max_n, "axial_opposite": rows.opposite_row_max_n, "radial": radial_max}
    worst = max(candidates, key=candidates.get)
    extra = {
        "axial_main_row_max_n": rows.main_row_max_n,
        "axial_opposite_row_max_n": rows.opposite_row_max_n,
        "radial_row_max_n": radial_max,
        "main_row_unloaded": rows.main_row_unloaded,
        "opposite_row_unloaded": rows.opposite_row_unloaded,
        "main_row_partly_unloaded": rows.main_row_partly_unloaded,
        "worst_row": worst,
    }
    return max(candidates[worst], 0.0), extra


def slewing_contact_report_from_loads(params: dict[str, Any], axial_load_n: float, radial_load_n: float,
                                      tilting_moment_nm: float) -> dict[str, Any]:
    """Report for the worst roller under F_a [N], F_r [N] and M_T [N m] (direct path).  # seed 003 Eq. 1

    The worst roller is the highest of both axial rows (Eq. 1) and the radial row (4.08 F_r/n_r); the
    radial row is ASSUMED to have the axial rollers' size (the seed does not give it), n_r =
    ``radial_roller_count`` or ``roller_count`` when 0.
    """
    validate_slewing_params(params)
    rows = axial_row_roller_loads(axial_load_n, tilting_moment_nm, params["roller_count"], params["raceway_diameter_m"])
    n_radial = params["radial_roller_count"] or params["roller_count"]
    load, extra = _loads_extra(rows, radial_row_roller_load_max_n(radial_load_n, n_radial))
    report = slewing_contact_report(params, load)
    report.update(extra)
    return report


class SlewingContactModel:
    """Cached roller-contact model for a live node (microseconds per report).

    Everything that depends only on the parameters is computed once: E*, R, Palmgren's k1, and the
    McEwen maxima (von Mises, maximum shear: value / p0, x / a, z / a) at the configured friction and
    Poisson ratio. Per load only Eq. 1 and the scalar Eqs. 2/3/5/7/8/10 remain (a few ``math`` calls);
    the Eq. 5 end ratio depends weakly on the load (through ln(l/a)) and is evaluated per call.
    Results equal ``slewing_contact_report``/``slewing_contact_report_from_loads`` (without
    ``load_balance_ratio``, which needs a quadrature).
    """

    def __init__(self, params: dict[str, Any]) -> None:
        validate_slewing_params(params)
        self.params = dict(params)
        self.numerical = params["stress_model"] == "numerical"
        self.roller_count = int(params["roller_count"])
        self.radial_roller_count = int(params["radial_roller_count"] or params["roller_count"])
        self.raceway_diameter_m = float(params["raceway_diameter_m"])
        self.length_m = float(params["roller_length_m"])
        self.half_length_m = 0.5 * self.length_m
        self.modulus_pa = effective_modulus_pa(params["youngs_modulus_pa"], params["poisson"])
        self.radius_m = effective_radius_m(params["roller_diameter_m"])
        self.k1 = palmgren_line_stiffness(self.length_m)
        self.allowable_pa = float(params["allowable_contact_stress_pa"])
        self.warn_fraction = float(params["warn_fraction"])
        self.maxima = cached_mcewen_maxima(float(params["friction"]), float(params["poisson"]))
        self.table = None
        if self.numerical:
            from guide_health.models.roller_numerical import build_roller_contact_table

            defaults = SLEWING_MONITOR_DEFAULTS
            self.table = build_roller_contact_table(
                self.params,
                float(params.get("numerical_table_min_load_n", defaults["numerical_table_min_load_n"])),
                float(params.get("numerical_table_max_load_n", defaults["numerical_table_max_load_n"])),
                n_loads=int(params.get("numerical_table_loads", defaults["numerical_table_loads"])),
                check_midpoints=2)

    def report_for_roller_load(self, roller_load_n: float) -> dict[str, Any]:
        """Report for one roller load Q [N] (>= 0, finite)."""
        load = float(roller_load_n)
        if not (load >= 0.0 and math.isfinite(load)):
            raise ValueError(f"roller load must be finite and >= 0, got {roller_load_n!r}")
        if self.numerical and load > 0.0:
            report = _numerical_report(self.params, load, self.table.lookup(load))
            report["table_in_range"] = report.pop("in_range")
            return report
        if load == 0.0:
            return _assemble(None, self.maxima, self.half_length_m, self.allowable_pa, self.warn_fraction, 0.0)
        scalars = _finite_roller_scalars(load, self.half_length_m, self.radius_m, self.modulus_pa,
                                         self.length_m, self.k1)
        return _assemble(scalars, self.maxima, self.half_length_m, self.allowable_pa, self.warn_fraction, load)

    def report_for_loads(self, axial_load_n: float, radial_load_n: float, tilting_moment_nm: float) -> dict[str, Any]:
        """Report for the worst roller under F_a, F_r [N] and M_T [N m].  # seed 003 Eq. 1"""
        rows = axial_row_roller_loads(axial_load_n, tilting_moment_nm, self.roller_count, self.raceway_diameter_m)
        load, extra = _loads_extra(rows, radial_row_roller_load_max_n(radial_load_n, self.radial_roller_count))
        report = self.report_for_roller_load(load)
        report.update(extra)
        return report
