"""Load ratings, equivalent loads and static safety of the three rows of a three-row roller slewing bearing.

Rows: ``upper_axial`` (the main axial row, loaded by F_a > 0, INTERFACES.md ``force.z`` pressing the rings
together), ``lower_axial`` (the retaining row: F_a < 0 and the far side of a tilting moment) and ``radial``.
Each row is rated as a single-row roller bearing of its own (i = 1): the axial rows as thrust cylindrical
roller bearings (contact angle 90 deg), the radial row as a radial cylindrical roller bearing.

Sources
-------
* Dynamic capacity, ISO 281:2007 Eqs. (7) (radial) and (11) (thrust, alpha = 90 deg), N with mm:
  C_r = b_m f_c (i L_we)^(7/9) Z^(3/4) D_we^(29/27),  C_a = b_m f_c L_we^(7/9) Z^(3/4) D_we^(29/27);
  b_m (ISO 281 Table 1): 1.1 cylindrical radial, 1.0 thrust cylindrical; f_c: ISO 281 Table 7 (radial) and
  Table 9 (thrust, alpha = 90 deg) against D_we / D_pw, linear interpolation as the standard allows.
* Slewing-bearing reduction: induction-hardened raceways are softer than the 58 HRC ISO 281 and ISO 76
  assume. Harris et al. 2009 (NREL DG03 and Harris & Kotzalas, Rolling Bearing Analysis, 5th ed.) reduce the
  two capacities by two different factors:
  - dynamic: C is multiplied by f_H = (HRC / 58)^3.6 (<= 1), a fatigue-life reduction;
  - static: C_0 is multiplied by f_0H = (HV / HV_58)^2 (<= 1) for line contact. ISO 76 defines C_0 as the load
    that takes the heaviest roller contact to 4000 MPa, the stress of a permanent deformation of 1e-4 D_we on
    a 58 HRC raceway. That stress scales with the raceway's yield strength, i.e. with its hardness HV, and a
    line contact's load grows with the square of its Hertz pressure (p_max = sqrt(Q E' / (pi l_e R'))), so
    C_0 scales with HV^2 (a point contact would give HV^3). HV from HRC by Schlecht's conversion
    HV = (223 HRC + 14500) / (100 - HRC) (HV_58 = 653.2).
* Static capacity, ISO 76:2006 (4000 MPa at the heaviest roller contact), N with mm:
  C_0r = 44 (1 - D_we / D_pw) i Z L_we D_we (radial),  C_0a = 220 Z L_we D_we (thrust, alpha = 90 deg).
* Rating life, ISO 281 Eq. (15)/(16) (roller bearings): L10 = (C / P)^(10/3) million revolutions.

Equivalent loads per row (from one F_a, F_r, M_T sample):
* axial rows: the roller loads Q_j at the Z roller azimuths (seed 003 Eq. 1,
  :func:`~guide_health.models.slewing.row_loads.axial_row_roller_load_distributions`) are combined with the
  life exponent p = 10/3 into the central axial load of equal life: P = Z (mean_j Q_j^p)^(1/p) (a raceway
  point passes every azimuth's load once per revolution; Palmgren-Miner over those passes, ISO 281 Sec. 7's
  mean-load rule applied over the azimuth). A pure axial load gives P = |F_a| on the loaded row, 0 on the
  other; a load reversal moves it to the other row.
* radial row: P_r = |F_r| (ISO 281 Eq. (12), X = 1, Y = 0 for cylindrical roller bearings).
Static equivalent loads: axial rows P_0 = Z Q_max (the central axial load with the same heaviest roller,
the load C_0a is defined for); radial row P_0r = |F_r| (ISO 76). Static safety S_0 = C_0 / P_0.

Pure physics: numpy only, SI units at the boundary (m, N, N m); no ROS, no I/O.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from guide_health.models.contact.hertz_line import checked_load_n
from guide_health.models.slewing.row_loads import axial_row_roller_load_distributions

ROWS: tuple[str, ...] = ("upper_axial", "lower_axial", "radial")

#: ISO 281 life exponent of roller bearings (Eq. (15)/(16)): L10 = (C/P)^(10/3) x 10^6 revolutions
ROLLER_LIFE_EXPONENT: float = 10.0 / 3.0
REVOLUTIONS_PER_RATING_UNIT: float = 1.0e6
#: ISO 281 Table 1: b_m of cylindrical roller bearings, radial and thrust
B_M_RADIAL_CYLINDRICAL: float = 1.1
B_M_THRUST_CYLINDRICAL: float = 1.0
#: ISO 281 / ISO 76 reference hardness [HRC] and the dynamic hardness factor's exponent (Harris & Kotzalas)
REFERENCE_HARDNESS_HRC: float = 58.0
HARDNESS_FACTOR_EXPONENT: float = 3.6
#: exponent of HV / HV_58 in the static hardness factor: line contact, Q ~ p_max^2 (module doc)
STATIC_HARDNESS_EXPONENT_LINE_CONTACT: float = 2.0

#: D_we cos(alpha) / D_pw of ISO 281 Table 7 and Table 9
_FC_RATIO = (0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.10)
#: ISO 281 Table 7, radial roller bearings
_FC_RADIAL = (52.1, 60.8, 66.5, 70.7, 74.1, 76.9, 79.2, 81.2, 82.8, 84.2)
#: ISO 281 Table 9, thrust roller bearings, alpha = 90 deg
_FC_THRUST = (105.4, 122.9, 134.5, 143.4, 150.7, 156.9, 162.4, 167.2, 171.7, 175.7)


def _fc(ratio: float, table: tuple[float, ...], name: str) -> float:
    if not _FC_RATIO[0] <= ratio <= _FC_RATIO[-1]:
        raise ValueError(f"D_we/D_pw = {ratio:.4g} outside the {name} f_c table [{_FC_RATIO[0]}, {_FC_RATIO[-1]}]")
    return float(np.interp(ratio, _FC_RATIO, table))


def fc_radial_roller(diameter_ratio: float) -> float:
    """f_c of radial roller bearings for D_we cos(alpha)/D_pw (linear interpolation).  # ISO 281 Table 7"""
    return _fc(diameter_ratio, _FC_RADIAL, "radial-roller (ISO 281 Table 7)")


def fc_thrust_roller(diameter_ratio: float) -> float:
    """f_c of thrust roller bearings, alpha = 90 deg, for D_we/D_pw (linear interpolation).  # ISO 281 Table 9"""
    return _fc(diameter_ratio, _FC_THRUST, "thrust-roller (ISO 281 Table 9)")


def hardness_factor(raceway_hardness_hrc: float) -> float:
    """f_H = min(1, (HRC/58)^3.6): dynamic capacity factor of a raceway softer than 58 HRC.  # Harris & Kotzalas"""
    return min(1.0, (raceway_hardness_hrc / REFERENCE_HARDNESS_HRC) ** HARDNESS_FACTOR_EXPONENT)


def vickers_from_rockwell_c(hardness_hrc: float) -> float:
    """HV = (223 HRC + 14500) / (100 - HRC) (Schlecht's conversion, steel, 20-68 HRC)."""
    return (223.0 * hardness_hrc + 14500.0) / (100.0 - hardness_hrc)


def static_hardness_factor(raceway_hardness_hrc: float) -> float:
    """f_0H = min(1, (HV / HV_58)^2): static capacity factor of a line-contact raceway softer than 58 HRC
    (ISO 76's 4000 MPa scaled with the hardness; module doc)."""
    ratio = vickers_from_rockwell_c(raceway_hardness_hrc) / vickers_from_rockwell_c(REFERENCE_HARDNESS_HRC)
    return min(1.0, ratio ** STATIC_HARDNESS_EXPONENT_LINE_CONTACT)


@dataclass(frozen=True, slots=True)
class SlewingRatings:
    """Dynamic (``dynamic_n``) and static (``static_n``) capacities per row [N], keyed by :data:`ROWS`."""

    dynamic_n: dict[str, float]
    static_n: dict[str, float]
    roller_count: int
    radial_roller_count: int
    raceway_diameter_m: float
    hardness_factor: float              # f_H on the dynamic capacities
    static_hardness_factor: float       # f_0H on the static capacities


def slewing_ratings(roller_count: int, radial_roller_count: int, roller_diameter_m: float, roller_length_m: float,
                    raceway_diameter_m: float, raceway_hardness_hrc: float = REFERENCE_HARDNESS_HRC) -> SlewingRatings:
    """C and C_0 of the three rows (ISO 281 Eqs. (7)/(11), ISO 76; hardness factors f_H on C, f_0H on C_0).

    Rollers of all rows share d and l_e; ``radial_roller_count`` is Z of the radial row. Lengths in m.
    """
    d_mm, l_mm = roller_diameter_m * 1e3, roller_length_m * 1e3
    ratio = roller_diameter_m / raceway_diameter_m
    f_h = hardness_factor(raceway_hardness_hrc)
    f_0h = static_hardness_factor(raceway_hardness_hrc)
    thrust_c = B_M_THRUST_CYLINDRICAL * fc_thrust_roller(ratio) * l_mm ** (7 / 9) * roller_count ** 0.75 \
        * d_mm ** (29 / 27)
    radial_c = B_M_RADIAL_CYLINDRICAL * fc_radial_roller(ratio) * l_mm ** (7 / 9) * radial_roller_count ** 0.75 \
        * d_mm ** (29 / 27)
    thrust_c0 = 220.0 * roller_count * l_mm * d_mm
    radial_c0 = 44.0 * (1.0 - ratio) * radial_roller_count * l_mm * d_mm
    return SlewingRatings(
        dynamic_n={"upper_axial": f_h * thrust_c, "lower_axial": f_h * thrust_c, "radial": f_h * radial_c},
        static_n={"upper_axial": f_0h * thrust_c0, "lower_axial": f_0h * thrust_c0, "radial": f_0h * radial_c0},
        roller_count=int(roller_count), radial_roller_count=int(radial_roller_count),
        raceway_diameter_m=float(raceway_diameter_m), hardness_factor=f_h, static_hardness_factor=f_0h)


def _life_mean(loads_n: np.ndarray) -> float:
    """(mean Q^p)^(1/p), p = 10/3 [N]."""
    return float(np.mean(loads_n ** ROLLER_LIFE_EXPONENT) ** (1.0 / ROLLER_LIFE_EXPONENT))


@dataclass(frozen=True, slots=True)
class RowLoads:
    """Equivalent dynamic (``dynamic_n``) and static (``static_n``) load per row [N] of one sample."""

    dynamic_n: dict[str, float]
    static_n: dict[str, float]


def row_equivalent_loads(ratings: SlewingRatings, axial_load_n: float, radial_load_n: float,
                         tilting_moment_nm: float) -> RowLoads:
    """P and P_0 per row for F_a [N] (signed, > 0 on the upper row), F_r [N], M_T [N m] (see module doc)."""
    upper, lower = axial_row_roller_load_distributions(axial_load_n, tilting_moment_nm, ratings.roller_count,
                                                       ratings.raceway_diameter_m)
    radial = abs(checked_load_n("radial load", radial_load_n, allow_negative=True))
    z = ratings.roller_count
    return RowLoads(
        dynamic_n={"upper_axial": z * _life_mean(upper), "lower_axial": z * _life_mean(lower), "radial": radial},
        static_n={"upper_axial": z * float(upper.max()), "lower_axial": z * float(lower.max()), "radial": radial})


def rating_life_revolutions(capacity_n: float, equivalent_load_n: float) -> float:
    """L10 = 10^6 (C / P)^(10/3) [revolutions]; inf for P = 0.  # ISO 281 Eq. (15)"""
    if equivalent_load_n <= 0.0:
        return math.inf
    return REVOLUTIONS_PER_RATING_UNIT * (capacity_n / equivalent_load_n) ** ROLLER_LIFE_EXPONENT


def damage_per_revolution(ratings: SlewingRatings, loads: RowLoads) -> dict[str, float]:
    """1 / L10 per row [1/revolution] (Palmgren-Miner increment of one revolution at this load)."""
    return {row: 1.0 / rating_life_revolutions(ratings.dynamic_n[row], loads.dynamic_n[row]) for row in ROWS}


def static_safety_factors(ratings: SlewingRatings, loads: RowLoads) -> dict[str, float]:
    """S_0 = C_0 / P_0 per row (inf for an unloaded row).  # ISO 76"""
    return {row: (ratings.static_n[row] / loads.static_n[row] if loads.static_n[row] > 0 else math.inf)
            for row in ROWS}


def limiting_curve_safety(axial_loads_n: tuple[float, ...] | list[float],
                          moments_nm: tuple[float, ...] | list[float], axial_load_n: float,
                          tilting_moment_nm: float) -> float:
    """Safety against a manufacturer's static limiting load curve M_lim(F_a) (a table, F_a ascending):
    M_lim(F_a) / |M_T| (linear interpolation; beyond the table's F_a range: 0, i.e. outside the curve);
    inf for M_T = 0 inside the range."""
    axial = np.asarray(axial_loads_n, dtype=float)
    moments = np.asarray(moments_nm, dtype=float)
    if axial.size < 2 or axial.size != moments.size or np.any(np.diff(axial) <= 0):
        raise ValueError("limiting load curve: need >= 2 points, F_a strictly ascending, one M per F_a")
    if not axial[0] <= axial_load_n <= axial[-1]:
        return 0.0
    allowed = float(np.interp(axial_load_n, axial, moments))
    moment = abs(tilting_moment_nm)
    return math.inf if moment == 0.0 else allowed / moment
