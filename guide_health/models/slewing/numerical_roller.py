"""Numerical (non-Hertz) contact of a finite roller on an elastic half-space, and its tabulated form for the
slewing monitor.

Pure physics: numpy/scipy only, SI units (m, N, Pa), no ROS, no I/O. The solver (Love influence
coefficients, DC-FFT, Polonsky & Keer CG) is :mod:`guide_health.models.slewing.half_space`.

Geometry (INTERFACES.md, slewing_monitor): roller of diameter D and length L on a flat raceway
(effective radius R_eff = D/2 unless given), profile drop z(y) from the roller mid-length,
y in [-L/2, L/2]; undeformed gap h0(x, y) = x^2 / (2 R_eff) + z(y); gap h = h0 + u(p) - approach.

Conventions used in the outputs:

* ``peak_pressure_along_roller`` p0(y): the highest pressure across the contact width at each
  axial station y (for a contact symmetric in x this is the centre-line pressure at x = 0).
* ``p0_center``: p0(y) at the roller mid-length (mean of the two middle columns when ny is even).
* ``p0_end``: the maximum of p0(y) in the two end zones |y| >= L/4 (the outer quarter of the
  roller at each end). For a straight roller with end radius r this captures the edge peak that
  sits near |y| = L/2 - r; for a logarithmic profile the shallow peaks towards the ends.
* ``end_stress_ratio`` = p0_end / p0_center.
* contact half-width a(y) = 2 P'(y) / (pi p0(y)), the equivalent elliptical (Hertz) half-width of
  the column's line load P'(y) and peak p0(y) (see :func:`contact_half_width_along_roller`; the
  raw loaded extent is kept as well).

A sharp-edged straight roller (end radius 0) has a singular edge pressure in the continuum
(Johnson 1985, sect. 5.4): the numerical edge value grows without bound under mesh refinement, so
end stresses are flagged unreliable for it.
"""
from __future__ import annotations

import math
import time
import timeit
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from guide_health.models.contact.elastic import effective_modulus_pa
from guide_health.models.contact.hertz_line import hertz_line_pressure_and_half_width
from guide_health.models.slewing.half_space import (
    DcFftDisplacementOperator,
    cached_displacement_operator,
    solve_pressure_polonsky_keer,
)

PROFILES = ("straight", "crowned", "logarithmic")
MIN_END_RADIUS_ELEMENTS = 8.0  # end radius / dy needed before a straight roller's end peak is trusted


# ---------------------------------------------------------------------------------------------
# Roller profiles
# ---------------------------------------------------------------------------------------------
def lundberg_log_profile_coefficient(load_per_length_n_m: float, effective_modulus_pa: float) -> float:
    """Lundberg (1939) logarithmic-profile coefficient [m]: 2 P' / (pi E*).

    With z(y) = coeff ln(1 / (1 - (2y/L)^2)) the line contact of length L carries an (almost)
    axially uniform pressure at the design load P' [N/m]. Lundberg, G., Elastische Berührung
    zweier Halbräume, Forsch. Ing.-Wes. 10 (1939) 201-211.
    """
    return 2.0 * load_per_length_n_m / (math.pi * effective_modulus_pa)


def iso_ts16281_log_profile_coefficient(roller_diameter_m: float) -> float:
    """ISO/TS 16281:2008 logarithmic-profile coefficient [m]: 0.00035 D (D roller diameter [m])."""
    return 0.00035 * roller_diameter_m


#: Default stopping tolerance of the Polonsky-Keer CG in :func:`solve_finite_roller_contact`: the
#: relative pressure change sum|p_k - p_(k-1)| dA / W of the last iteration. Measured on the seed-003 roller
#: (d = 32 mm, L = 31.3 mm; straight r = 2 mm, crowned 10 um, logarithmic 5 um; Q = 20 and 103.4 kN) against
#: tol = 1e-12: p_max moves at most 2.1e-6 relative (1e-9: 3e-9) for 30-45 % less solve time; the
#: documented bound is 1e-4 relative (test_roller_numerical.py::test_default_tolerance_keeps_p_max).
ROLLER_SOLVER_TOL = 1e-6


def roller_profile_drop(
    y_m: np.ndarray,
    roller_length_m: float,
    profile: str,
    end_radius_m: float = 0.0,
    crown_drop_m: float = 0.0,
    log_coeff_m: float = 0.0,
) -> np.ndarray:
    """Profile drop z(y) [m] of the roller surface from its mid-length, y [m] from mid-length.

    Profiles (INTERFACES.md, slewing_monitor):

    * ``straight``: z = r - sqrt(r^2 - (|y| - (L/2 - r))^2) for |y| > L/2 - r, else 0; r = end
      (corner) radius [m], r = 0 a sharp edge.
    * ``crowned``: z = crown_drop (2y/L)^2.
    * ``logarithmic``: z = coeff ln(1 / (1 - (2y/L)^2)) (Lundberg 1939; Johns & Gohar 1981). It
      diverges at |y| = L/2; it is finite at element centres, which is where the solver evaluates it.

    Outside the roller (|y| > L/2) z = +inf (no contact possible).
    """
    y = np.asarray(y_m, dtype=float)
    half = 0.5 * roller_length_m
    ay = np.abs(y)
    inside = ay < half * (1.0 + 1e-12)
    z = np.full(y.shape, np.inf)
    if profile == "straight":
        r = float(end_radius_m)
        if r < 0 or r > half:
            raise ValueError("end radius must lie in [0, L/2]")
        zi = np.zeros(y.shape)
        if r > 0:
            s = np.clip(ay - (half - r), 0.0, r)
            zi = np.where(ay > half - r, r - np.sqrt(np.maximum(r * r - s * s, 0.0)), 0.0)
    elif profile == "crowned":
        zi = crown_drop_m * (2.0 * y / roller_length_m) ** 2
    elif profile == "logarithmic":
        eta = np.clip(2.0 * ay / roller_length_m, 0.0, 1.0)
        with np.errstate(divide="ignore"):
            zi = log_coeff_m * -np.log1p(-(eta ** 2))
    else:
        raise ValueError(f"unknown roller profile {profile!r}; expected one of {PROFILES}")
    z[inside] = zi[inside]
    return z


# ---------------------------------------------------------------------------------------------
# Contact width and the infinitely long roller
# ---------------------------------------------------------------------------------------------
def contact_half_width_along_roller(pressure_pa: np.ndarray, dx_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Contact half-widths per axial column of a pressure field p(x, y) [Pa], x spacing dx [m].

    Returns (a_equivalent [m], a_loaded [m]):

    * a_equivalent = 2 P'(y) / (pi p0(y)), P'(y) = sum_x p dx the column's line load [N/m] and
      p0(y) its peak [Pa]: the half-width of the elliptical (Hertz) distribution with the same load
      and peak -- exact for a Hertzian column, converges with the pressure itself (Johnson 1985
      eq. 4.45, P' = pi a p0 / 2). Used for the reported half-width.
    * a_loaded = (number of loaded elements) dx / 2: the raw discrete extent, resolution dx / 2.

    Both are 0 for unloaded columns.
    """
    p = np.asarray(pressure_pa, dtype=float)
    peak = p.max(axis=0)
    line_load = p.sum(axis=0) * dx_m
    with np.errstate(invalid="ignore", divide="ignore"):
        a_eq = np.where(peak > 0, 2.0 * line_load / (math.pi * np.where(peak > 0, peak, 1.0)), 0.0)
    a_loaded = 0.5 * dx_m * (p > 0).sum(axis=0)
    return a_eq, a_loaded


def solve_plane_strain_line_contact(
    load_per_length_n_m: float,
    effective_radius_m: float,
    effective_modulus_pa: float,
    nx: int = 64,
    x_half_extent_over_b: float = 1.6,
    period_length_m: float | None = None,
    ny: int = 8,
    tol: float = 1e-10,
) -> dict[str, Any]:
    """Infinitely long straight roller (plane-strain line contact) solved with the same elements,
    Love coefficients and Polonsky-Keer CG as the finite roller, but circular (periodic) in y so
    the pressure is uniform along the roller: the numerical counterpart of Hertz's line contact.

    Inputs: line load P' [N/m], effective radius R [m], contact modulus E* [Pa].
    Returns x [m], p(x) [Pa], p_max [Pa], contact half-widths [m] (see
    :func:`contact_half_width_along_roller`), the Hertz p0 and b for comparison, and the load
    check sum(p) dx [N/m]. (The approach is not returned: in 2D it is defined only up to a
    constant that depends on the period length.)
    Johnson (1985) sect. 4.2 (Hertz line contact); Polonsky & Keer (1999); Liu, Wang & Liu (2000).
    """
    p0_h, b_h = hertz_line_pressure_and_half_width(load_per_length_n_m, effective_radius_m, effective_modulus_pa)
    lp = 50.0 * b_h if period_length_m is None else float(period_length_m)
    dy = lp / ny
    x_half = x_half_extent_over_b * b_h
    dx = 2.0 * x_half / nx
    x = -x_half + (np.arange(nx) + 0.5) * dx
    h0 = np.repeat((x ** 2 / (2.0 * effective_radius_m))[:, None], ny, axis=1)
    op = DcFftDisplacementOperator(nx, ny, dx, dy, effective_modulus_pa, periodic_y=True)
    p, _approach, iters, eps = solve_pressure_polonsky_keer(h0, dx * dy, load_per_length_n_m * lp, op, tol=tol)
    px = p.mean(axis=1)
    a_eq, a_loaded = contact_half_width_along_roller(px[:, None], dx)
    return {
        "x_m": x, "pressure_pa": px, "p_max_pa": float(px.max()),
        "half_width_m": float(a_eq[0]), "half_width_loaded_m": float(a_loaded[0]),
        "hertz_p0_pa": p0_h, "hertz_half_width_m": b_h,
        "load_per_length_check_n_m": float(px.sum() * dx), "dx_m": dx, "iterations": iters, "residual": eps,
    }


# ---------------------------------------------------------------------------------------------
# Finite roller on a half-space
# ---------------------------------------------------------------------------------------------
@dataclass
class RollerContactResult:
    """Solution of a finite roller contact (SI units unless the name says otherwise)."""

    x_m: np.ndarray                      # element centres across the contact width [m], (nx,)
    y_m: np.ndarray                      # element centres along the roller from mid-length [m], (ny,)
    pressure_pa: np.ndarray              # pressure field [Pa], (nx, ny)
    approach_m: float                    # rigid approach of the roller axis towards the raceway [m]
    load_n: float                        # applied load [N]
    load_check_n: float                  # sum(p) dx dy [N]
    max_pressure_pa: float               # highest pressure anywhere [Pa]
    max_pressure_y_m: float              # |y| of the highest pressure [m] from mid-length
    peak_pressure_along_roller_pa: np.ndarray  # p0(y) = max over x of p(x, y) [Pa], (ny,)
    half_width_along_roller_m: np.ndarray      # equivalent elliptical half-width 2P'(y)/(pi p0(y)) [m], (ny,)
    loaded_half_width_along_roller_m: np.ndarray  # loaded elements x dx/2 [m], (ny,)
    line_load_along_roller_n_m: np.ndarray     # P'(y) = sum_x p dx [N/m], (ny,)
    p0_center_pa: float                  # p0 at mid-length [Pa]
    p0_end_pa: float                     # max of p0(y) in the end zones |y| >= L/4 [Pa]
    p0_end_y_m: float                    # |y| where p0_end occurs [m]
    end_stress_ratio: float              # p0_end / p0_center
    hertz_p0_pa: float                   # Hertz p0 for the mean line load W/L [Pa]
    hertz_half_width_m: float            # Hertz b for the mean line load [m]
    iterations: int
    residual: float                      # last relative pressure change of the CG
    complementarity_gap_m: float         # max |gap| over loaded elements [m]
    min_gap_outside_m: float             # min gap over unloaded (touchable) elements [m]
    solve_time_s: float
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def dx_m(self) -> float:
        return float(self.x_m[1] - self.x_m[0])

    @property
    def dy_m(self) -> float:
        return float(self.y_m[1] - self.y_m[0])


def solve_finite_roller_contact(
    roller_diameter_m: float,
    roller_length_m: float,
    load_n: float,
    effective_modulus_pa: float,
    profile: str = "straight",
    end_radius_m: float = 0.0,
    crown_drop_m: float = 0.0,
    log_coeff_m: float = 0.0,
    effective_radius_m: float | None = None,
    nx: int = 64,
    ny: int = 256,
    x_half_extent_over_b: float = 1.6,
    tol: float = ROLLER_SOLVER_TOL,
    max_iter: int = 1000,
    auto_extend: bool = True,
) -> RollerContactResult:
    """Pressure under a finite-length roller on a flat raceway (elastic half-spaces).

    Inputs: roller diameter D [m], length L [m] (the whole profiled length), total normal load
    W [N], contact modulus E* [Pa], profile as in :func:`roller_profile_drop`. The effective
    radius across the rolling direction defaults to D/2 (flat raceway); pass
    R_eff = (D/2) R_race / (R_race +- D/2) for a curved raceway.
    Grid: ``nx`` elements across x in [-X, X], X = ``x_half_extent_over_b`` times the Hertz
    half-width of the mean line load; ``ny`` elements exactly tiling y in [-L/2, L/2]. If the
    contact reaches the x border the domain is widened by 1.4x and the problem re-solved
    (``auto_extend``).
    Method: Love influence coefficients, DC-FFT (Liu, Wang & Liu 2000), Polonsky & Keer (1999) CG.
    """
    t_start = time.perf_counter()
    if roller_diameter_m <= 0 or roller_length_m <= 0:
        raise ValueError("roller diameter and length must be positive")
    r_eff = 0.5 * roller_diameter_m if effective_radius_m is None else float(effective_radius_m)
    line_load = load_n / roller_length_m
    p0_h, b_h = hertz_line_pressure_and_half_width(line_load, r_eff, effective_modulus_pa)
    dy = roller_length_m / ny
    y = -0.5 * roller_length_m + (np.arange(ny) + 0.5) * dy
    z = roller_profile_drop(y, roller_length_m, profile, end_radius_m, crown_drop_m, log_coeff_m)
    grid = _solve_on_widening_grid(z, dy, r_eff, load_n, effective_modulus_pa, nx, x_half_extent_over_b, b_h,
                                   tol, max_iter, auto_extend)
    info = {"profile": profile, "end_radius_m": end_radius_m, "crown_drop_m": crown_drop_m,
            "log_coeff_m": log_coeff_m, "effective_radius_m": r_eff, "nx": nx, "ny": ny,
            "x_half_extent_m": grid.x_half_extent_m, "touches_x_border": grid.touches_x_border,
            "converged": grid.residual < tol}
    return _roller_contact_result(grid, y, roller_length_m, load_n, p0_h, b_h, t_start, info)


class _GridSolution(NamedTuple):
    """Pressure on the accepted x grid of :func:`_solve_on_widening_grid` (SI units)."""

    x_m: np.ndarray                      # element centres across the contact width, (nx,)
    dx_m: float
    dy_m: float
    gap_undeformed_m: np.ndarray         # h0(x, y), +inf where no contact is possible, (nx, ny)
    displacement: DcFftDisplacementOperator
    pressure_pa: np.ndarray              # (nx, ny)
    approach_m: float
    iterations: int
    residual: float
    x_half_extent_m: float
    touches_x_border: bool


def _solve_on_widening_grid(profile_drop_m: np.ndarray, dy_m: float, effective_radius_m: float, load_n: float,
                            effective_modulus_pa: float, nx: int, x_half_extent_over_b: float,
                            hertz_half_width_m: float, tol: float, max_iter: int,
                            auto_extend: bool) -> _GridSolution:
    """Polonsky-Keer solve on ``nx`` elements across x in [-X, X], X = factor b (b the Hertz half-width of
    the mean line load, factor from ``x_half_extent_over_b``); while the contact reaches the x border (and
    ``auto_extend``), X is widened by 1.4x and the problem re-solved (at most 6 attempts)."""
    ny = profile_drop_m.size
    factor = float(x_half_extent_over_b)
    for _attempt in range(6):
        x_half = factor * hertz_half_width_m
        dx = 2.0 * x_half / nx
        x = -x_half + (np.arange(nx) + 0.5) * dx
        h0 = x[:, None] ** 2 / (2.0 * effective_radius_m) + profile_drop_m[None, :]
        op = cached_displacement_operator(nx, ny, dx, dy_m, float(effective_modulus_pa))
        p, approach, iters, eps = solve_pressure_polonsky_keer(
            h0, dx * dy_m, load_n, op, tol=tol, max_iter=max_iter
        )
        touches_border = bool((p[0, :] > 0).any() or (p[-1, :] > 0).any())
        if not (auto_extend and touches_border):
            break
        factor *= 1.4
    return _GridSolution(x, dx, dy_m, h0, op, p, approach, iters, eps, x_half, touches_border)


def _centre_and_end_peaks(peak_pa: np.ndarray, y_m: np.ndarray, roller_length_m: float) -> tuple[float, float, int]:
    """(p0 at mid-length, max p0 in the end zones |y| >= L/4, index of that end peak) of p0(y) [Pa]."""
    ny = peak_pa.size
    if ny % 2:
        p0_c = float(peak_pa[ny // 2])
    else:
        p0_c = float(0.5 * (peak_pa[ny // 2 - 1] + peak_pa[ny // 2]))
    end_zone = np.abs(y_m) >= 0.25 * roller_length_m
    j_end = int(np.argmax(np.where(end_zone, peak_pa, -np.inf)))
    return p0_c, float(peak_pa[j_end]), j_end


def _complementarity(grid: _GridSolution) -> tuple[float, float]:
    """(max |gap| over loaded elements, min gap over unloaded touchable elements) [m] of a solution."""
    p = grid.pressure_pa
    h0 = grid.gap_undeformed_m
    gap = np.where(np.isfinite(h0), h0, np.inf) + grid.displacement(p) - grid.approach_m
    loaded = p > 0
    compl = float(np.abs(gap[loaded]).max()) if loaded.any() else 0.0
    unloaded = (~loaded) & np.isfinite(gap)
    min_gap = float(gap[unloaded].min()) if unloaded.any() else float("inf")
    return compl, min_gap


def _roller_contact_result(grid: _GridSolution, y_m: np.ndarray, roller_length_m: float, load_n: float,
                           hertz_p0_pa: float, hertz_half_width_m: float, t_start: float,
                           info: dict[str, Any]) -> RollerContactResult:
    """Peaks, half-widths, line loads and checks of a grid solution (conventions: module docstring)."""
    p, dx = grid.pressure_pa, grid.dx_m
    peak = p.max(axis=0)
    half_width, half_width_loaded = contact_half_width_along_roller(p, dx)
    i_max = np.unravel_index(int(np.argmax(p)), p.shape)
    p0_c, p0_e, j_end = _centre_and_end_peaks(peak, y_m, roller_length_m)
    compl, min_gap = _complementarity(grid)
    return RollerContactResult(
        x_m=grid.x_m, y_m=y_m, pressure_pa=p, approach_m=grid.approach_m, load_n=float(load_n),
        load_check_n=float(p.sum() * (dx * grid.dy_m)),
        max_pressure_pa=float(p[i_max]), max_pressure_y_m=float(abs(y_m[i_max[1]])),
        peak_pressure_along_roller_pa=peak, half_width_along_roller_m=half_width,
        loaded_half_width_along_roller_m=half_width_loaded, line_load_along_roller_n_m=p.sum(axis=0) * dx,
        p0_center_pa=p0_c, p0_end_pa=p0_e, p0_end_y_m=float(abs(y_m[j_end])),
        end_stress_ratio=p0_e / p0_c if p0_c > 0 else float("inf"),
        hertz_p0_pa=hertz_p0_pa, hertz_half_width_m=hertz_half_width_m, iterations=grid.iterations,
        residual=grid.residual, complementarity_gap_m=compl, min_gap_outside_m=min_gap,
        solve_time_s=time.perf_counter() - t_start, info=info,
    )


def mesh_convergence_study(
    grids: Sequence[tuple[int, int]], **solve_kwargs: Any
) -> list[dict[str, float]]:
    """Solve the same roller contact on successive grids (nx, ny) and tabulate p_max, p0_center,
    p0_end, the end/centre ratio (all [Pa] or dimensionless) and the solve time [s] per grid,
    plus the relative change of p_max from the previous grid. Keyword arguments go to
    :func:`solve_finite_roller_contact`. (Richardson-style refinement check; Roache, Verification
    and Validation in Computational Science and Engineering, 1998.)
    """
    rows: list[dict[str, float]] = []
    prev = None
    for nx, ny in grids:
        res = solve_finite_roller_contact(nx=nx, ny=ny, **solve_kwargs)
        row = {
            "nx": nx, "ny": ny, "dx_m": res.dx_m, "dy_m": res.dy_m,
            "p_max_pa": res.max_pressure_pa, "p_max_y_m": res.max_pressure_y_m,
            "p0_center_pa": res.p0_center_pa, "p0_end_pa": res.p0_end_pa,
            "end_stress_ratio": res.end_stress_ratio, "iterations": res.iterations,
            "solve_time_s": res.solve_time_s,
            "p_max_rel_change": float("nan") if prev is None else res.max_pressure_pa / prev - 1.0,
        }
        prev = res.max_pressure_pa
        rows.append(row)
    return rows


# ---------------------------------------------------------------------------------------------
# Slewing-monitor entry points
# ---------------------------------------------------------------------------------------------
def _profile_from_params(params: Any, roller_load_n: float) -> dict[str, Any]:
    """Resolve the roller-profile parameters (SlewingMonitorParams fields) into solver keyword args."""
    d = float(params.roller_diameter_m)
    length = float(params.roller_length_m)
    e_star = effective_modulus_pa(float(params.youngs_modulus_pa), float(params.poisson))
    profile = str(params.roller_profile)
    if profile not in PROFILES:
        raise ValueError(f"roller_profile must be one of {PROFILES}, got {profile!r}")
    log_coeff = float(params.log_profile_coeff_m)
    if profile == "logarithmic" and log_coeff <= 0.0:
        log_coeff = lundberg_log_profile_coefficient(roller_load_n / length, e_star)
    return {
        "roller_diameter_m": d,
        "roller_length_m": length,
        "effective_modulus_pa": e_star,
        "profile": profile,
        "end_radius_m": float(params.roller_end_radius_m),
        "crown_drop_m": float(params.crown_drop_m),
        "log_coeff_m": log_coeff,
    }


def numerical_contact_report(
    params: Any, roller_load_n: float, nx: int = 64, ny: int = 512
) -> dict[str, Any]:
    """Numerical roller/raceway contact for the slewing monitor (roller on a flat raceway).

    ``params``: the slewing_monitor parameters (SlewingMonitorParams), of which ``roller_diameter_m``,
    ``roller_length_m``, ``youngs_modulus_pa``, ``poisson`` (both bodies the same steel), ``roller_profile``
    ('straight' | 'crowned' | 'logarithmic'), ``roller_end_radius_m``, ``crown_drop_m``,
    ``log_profile_coeff_m`` (0 = Lundberg 2P'/(pi E*) for this load) are read. ``roller_load_n`` [N].

    Returns p_max_MPa, p_max_position_mm (|y| from mid-length), p0_center_MPa, p0_end_MPa (max
    of the peak pressure in the end zones |y| >= L/4), end_stress_ratio, p0_hertz_MPa (mean line
    load), contact_half_width_center_mm (equivalent elliptical half-width at mid-length),
    approach_um, load_check_rel_error, end_stress_reliable (False for a sharp-edged straight
    roller, whose edge pressure is a mesh-dependent singularity, and for an end radius spanning
    fewer than ``MIN_END_RADIUS_ELEMENTS`` axial elements), converged, grid and solve time.
    Default grid 64 x 512: for the seed-003 roller (d = 32 mm, L = 31.3 mm, r = 2 mm) p_max is
    within ~1 % of the 128 x 1024 value; a smaller end radius needs a finer ny (dy << r).
    """
    kw = _profile_from_params(params, roller_load_n)
    res = solve_finite_roller_contact(load_n=float(roller_load_n), nx=nx, ny=ny, **kw)
    ny_ = res.y_m.size
    hw_c = float(0.5 * (res.half_width_along_roller_m[(ny_ - 1) // 2] + res.half_width_along_roller_m[ny_ // 2]))
    # A straight roller's end peak sits at the curvature jump |y| = L/2 - r; it is resolved only
    # when the end radius spans enough elements (convergence study, seed-003 roller, r = 0.5/1/2 mm:
    # with r/dy >= 8 halving dy changed p_max by < 3 %; at r/dy ~ 4 p_max was 34 % below the
    # finer grid's). A sharp edge never is. Crowned/logarithmic profiles are smooth: reliable.
    if kw["profile"] == "straight":
        end_radius_elements = kw["end_radius_m"] / res.dy_m
        reliable = end_radius_elements >= MIN_END_RADIUS_ELEMENTS
    else:
        end_radius_elements = float("nan")
        reliable = True
    return {
        "p_max_MPa": res.max_pressure_pa / 1e6,
        "p_max_position_mm": res.max_pressure_y_m * 1e3,
        "p0_hertz_MPa": res.hertz_p0_pa / 1e6,
        "p0_center_MPa": res.p0_center_pa / 1e6,
        "p0_end_MPa": res.p0_end_pa / 1e6,
        "p0_end_position_mm": res.p0_end_y_m * 1e3,
        "end_stress_ratio": res.end_stress_ratio,
        "contact_half_width_center_mm": hw_c * 1e3,
        "hertz_half_width_mm": res.hertz_half_width_m * 1e3,
        "approach_um": res.approach_m * 1e6,
        "load_check_rel_error": abs(res.load_check_n / res.load_n - 1.0),
        "end_stress_reliable": bool(reliable),
        "end_radius_elements": end_radius_elements,
        "converged": bool(res.info["converged"]) and not res.info["touches_x_border"],
        "roller_profile": kw["profile"],
        "log_profile_coeff_m": kw["log_coeff_m"] if kw["profile"] == "logarithmic" else 0.0,
        "grid_nx": nx,
        "grid_ny": ny,
        "iterations": res.iterations,
        "solve_time_s": res.solve_time_s,
    }


_TABLE_KEYS = ("p_max_MPa", "p_max_position_mm", "p0_center_MPa", "p0_end_MPa", "end_stress_ratio",
               "contact_half_width_center_mm", "approach_um")


@dataclass
class RollerContactTable:
    """Tabulated numerical contact results over a log-spaced load grid for a live node.

    Lookups interpolate linearly in ln(load) (``np.interp``; clamped at the table ends, flagged by
    ``in_range``). ``interpolation_error`` holds, per key, the max relative error of the table
    against direct solves at the geometric mid-points between grid loads.
    """

    loads_n: np.ndarray
    values: dict[str, np.ndarray]
    resolved_params: Any        # the parameters with a Lundberg log profile resolved to its coefficient
    end_stress_reliable: bool
    solve_time_per_load_s: float
    interpolation_error: dict[str, float]
    grid: tuple[int, int]

    def lookup(self, roller_load_n: float) -> dict[str, Any]:
        """Interpolated report for ``roller_load_n`` [N] (same keys as the direct report)."""
        lq = math.log(max(float(roller_load_n), 1e-300))
        ll = self._log_loads
        out: dict[str, Any] = {k: float(np.interp(lq, ll, v)) for k, v in self.values.items()}
        out["end_stress_reliable"] = self.end_stress_reliable
        out["in_range"] = bool(self.loads_n[0] <= roller_load_n <= self.loads_n[-1])
        return out

    def __post_init__(self) -> None:
        self._log_loads = np.log(self.loads_n)


def build_roller_contact_table(
    params: Any,
    load_min_n: float,
    load_max_n: float,
    n_loads: int = 24,
    nx: int = 64,
    ny: int = 512,
    design_load_n: float | None = None,
    check_midpoints: int | None = None,
) -> RollerContactTable:
    """Solve the numerical roller contact on ``n_loads`` log-spaced loads [N] once and return a
    :class:`RollerContactTable` for interpolation, with its interpolation error measured against
    direct solves at the geometric mid-points (``check_midpoints`` of them, default all).

    A logarithmic profile with ``log_profile_coeff_m`` = 0 is resolved ONCE to the Lundberg
    coefficient of ``design_load_n`` (default: the geometric mean of the load range), so the
    tabulated roller has a fixed, physical profile at every load.
    The mean direct solve time per load [s] (time.perf_counter) is recorded.
    """
    if not (0 < load_min_n < load_max_n):
        raise ValueError("need 0 < load_min_n < load_max_n")
    resolved = params
    if str(resolved.roller_profile) == "logarithmic" and float(resolved.log_profile_coeff_m) <= 0:
        wd = math.sqrt(load_min_n * load_max_n) if design_load_n is None else float(design_load_n)
        e_star = effective_modulus_pa(float(resolved.youngs_modulus_pa), float(resolved.poisson))
        resolved = replace(resolved, log_profile_coeff_m=lundberg_log_profile_coefficient(
            wd / float(resolved.roller_length_m), e_star))
    loads = np.geomspace(load_min_n, load_max_n, n_loads)
    rows = []
    t0 = time.perf_counter()
    for w in loads:
        rows.append(numerical_contact_report(resolved, float(w), nx=nx, ny=ny))
    per_load = (time.perf_counter() - t0) / n_loads
    values = {k: np.array([r[k] for r in rows], dtype=float) for k in _TABLE_KEYS}
    reliable = all(bool(r["end_stress_reliable"]) for r in rows)
    table = RollerContactTable(loads, values, resolved, reliable, per_load, {}, (nx, ny))
    mids = np.sqrt(loads[:-1] * loads[1:])
    if check_midpoints is not None and check_midpoints < mids.size:
        mids = mids[np.linspace(0, mids.size - 1, check_midpoints).round().astype(int)]
    err = {k: 0.0 for k in _TABLE_KEYS}
    for w in mids:
        direct = numerical_contact_report(resolved, float(w), nx=nx, ny=ny)
        interp = table.lookup(float(w))
        for k in _TABLE_KEYS:
            ref = direct[k]
            scale = abs(ref) if k != "p_max_position_mm" else 1e3 * float(resolved.roller_length_m) / 2
            if scale > 0:
                err[k] = max(err[k], abs(interp[k] - ref) / scale)
    table.interpolation_error = err
    return table


def time_table_lookup(table: RollerContactTable, roller_load_n: float, number: int = 2000) -> float:
    """Mean wall time [s] of one :meth:`RollerContactTable.lookup` (timeit, best of 3 repeats)."""
    timer = timeit.Timer(lambda: table.lookup(roller_load_n))
    return min(timer.repeat(repeat=3, number=number)) / number
