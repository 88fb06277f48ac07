"""Roller loads of the rows of a three-row roller slewing bearing (seed 003 Eq. 1; radial row: Stribeck).

Pure physics, SI units (N, m, N m).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guide_health.models.contact.hertz_line import checked_load_n

#: Radial row, line contact, zero clearance: Q_max = F_r / (n J_r(0.5)), J_r = 0.2453 -> 4.08
#: (Stribeck; Harris & Kotzalas, Rolling Bearing Analysis, 5th ed., Essential Concepts, Ch. 7).
RADIAL_ROW_LINE_CONTACT_FACTOR: float = 4.08


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
    axial = checked_load_n("axial load", axial_load_n, allow_negative=True)
    moment = abs(checked_load_n("tilting moment", tilting_moment_nm, allow_negative=True))
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
    return RADIAL_ROW_LINE_CONTACT_FACTOR * abs(checked_load_n("radial load", radial_load_n, True)) / roller_count



def axial_row_roller_load_distributions(axial_load_n: float, tilting_moment_nm: float, roller_count: int,
                                        raceway_diameter_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Roller loads of both axial rows at the n roller azimuths psi_j = 2 pi j / n [N].  # seed 003 Eq. 1

    Main row: max(F_a/n + (4 M_T/(n D0)) cos psi_j, 0); opposite (retaining) row: max(-(F_a/n + (4 M_T/(n D0))
    cos psi_j), 0): the roller pair at psi presses on one row or the other. Their maxima are those of
    :func:`axial_row_roller_loads`.
    """
    axial = checked_load_n("axial load", axial_load_n, allow_negative=True)
    moment = abs(checked_load_n("tilting moment", tilting_moment_nm, allow_negative=True))
    moment_term = 4.0 * moment / (roller_count * raceway_diameter_m)
    axial_term = axial / roller_count
    signed = axial_term + moment_term * np.cos(2.0 * np.pi * np.arange(roller_count) / roller_count)
    return np.maximum(signed, 0.0), np.maximum(-signed, 0.0)
