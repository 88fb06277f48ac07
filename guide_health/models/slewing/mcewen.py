"""McEwen's plane-strain stress field under a Hertz line-contact pressure plus a proportional friction
traction (seed 003 Eqs. 11-24; McEwen 1949; Johnson 1985 Sec. 7.2), vectorised over (x, z) grids, with
von Mises and maximum-shear maxima located on a grid and refined with scipy.optimize.

Pure physics: numpy/scipy only; fields normalised by p0 and a, or in Pa for a given contact.
Axes: x across the contact (rolling direction), z depth into the raceway (z >= 0). Stresses: tension
positive. ``friction`` f is signed: f > 0 is a surface traction q(x) = f p(x) acting on the raceway in +x.

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
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import optimize


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
    von_mises_surface_seed003_over_p0: float = float("nan")   # the reading of seed 003 Table 1 (0.409 p0)


def seed003_table1_surface_von_mises_over_p0(friction: float, poisson: float) -> float:
    """Seed 003 Table 1's von Mises / p0: the surface centre with half the friction shear,
    sqrt((1 - 2 nu)^2 + 3 (f/2)^2) = 0.40927 for nu = 0.3, f = 0.1 (1328/3245, 1095/2675, 1127/2754 MPa).
    A SURFACE value (the reading that reproduces the table; see the module docstring), to be compared with
    Table 1 only, never with the subsurface maximum (0.559 p0)."""
    return math.sqrt((1.0 - 2.0 * poisson) ** 2 + 3.0 * (0.5 * friction) ** 2)


def mcewen_maxima(friction: float, poisson: float) -> McEwenMaxima:
    """All field maxima used by the report (computed, ~10 ms; see ``cached_mcewen_maxima``).  # seed 003 Eqs. 20-24"""
    surface = float(_normalised_quantity("von_mises", np.zeros(1), np.zeros(1), friction, poisson)[0])
    return McEwenMaxima(
        von_mises=field_maximum("von_mises", friction, poisson),
        max_shear=field_maximum("max_shear", friction, poisson),
        von_mises_on_axis=field_maximum("von_mises", friction, poisson, on_axis=True),
        max_shear_on_axis=field_maximum("max_shear", friction, poisson, on_axis=True),
        von_mises_surface_centre_over_p0=surface,
        von_mises_surface_seed003_over_p0=seed003_table1_surface_von_mises_over_p0(friction, poisson),
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
