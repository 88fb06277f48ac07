"""Roller/raceway contact of three-row roller slewing bearings (seed 003) and the slewing monitor core.

Source: FENG Jianyou, QI Xiaoli, TONG Jinyu, "Non-Hertz contact characteristics analysis of three-row
roller slewing bearings", China Mechanical Engineering 28(4), 2017, DOI 10.3969/j.issn.1004-132X.2017.04.004
("seed 003" in these modules; equation numbers are the paper's).

Pure physics: numpy/scipy only, SI units at every public boundary (m, N, Pa, N m), no ROS, no I/O.

Contents
--------
* :mod:`.row_loads`: Eq. 1, roller loads of the two axial rows from F_a and M_T (rigid rings, zero
  clearance), and of the radial row from F_r (Stribeck/Harris, line contact, zero clearance:
  Q_r,max = 4.08 F_r / n_r).
* Ideal Hertz line contact (E* = E/(2(1-nu^2)) for two equal steels, Johnson 1985 Sec. 4.2):
  :mod:`guide_health.models.contact.hertz_line`.
* :mod:`.finite_roller`: the seed's finite-roller ("non-Hertz") method, Eqs. 2-10: approach at the roller
  centre (Eq. 2) and at the end (Eq. 5), approach along the roller (Eq. 4), line load from Palmgren's
  stiffness (Eqs. 6/7), half-width and peak pressure along the roller (Eqs. 8-10).
* :mod:`.mcewen`: McEwen's plane-strain stress field under a Hertz pressure plus a proportional friction
  traction (Eqs. 11-24), vectorised over (x, z) grids, with von Mises and maximum-shear maxima located on a
  grid and refined with scipy.optimize; the notes on the seed's printed signs and von Mises figures.
* :mod:`.half_space` and :mod:`.numerical_roller`: the numerical (non-Hertz) finite-roller solver (Love
  influence coefficients, DC-FFT, Polonsky-Keer CG), roller profiles, and its tabulated form for the node.
* :mod:`.monitor`: ``slewing_contact_report`` (direct, uncached) and ``SlewingContactModel`` (geometry-only
  work done once; a report costs microseconds) returning the INTERFACES.md ``contact slewing --json``
  keys, and ``SlewingMonitor``, the ROS-free core of the node.

Sign conventions
----------------
x: across the contact (rolling direction), z: depth into the raceway (z >= 0), y: along the roller axis
from its mid-length. Stresses: tension positive, so the contact pressure gives negative sigma_z.
``friction`` f is signed: f > 0 is a surface traction q(x) = f p(x) acting on the raceway in +x.
"""
