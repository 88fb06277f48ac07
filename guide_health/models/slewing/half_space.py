"""Normal contact of elastic half-spaces solved numerically: the engine of the numerical roller model.

Pure physics: numpy/scipy only, SI units (m, N, Pa), no ROS, no I/O.

The contact plane is discretised into ``nx x ny`` rectangular elements of uniform pressure
(x across the rolling direction / contact width, y along the roller axis). The surface
displacement of one element is Love's (1929) closed form for a uniformly loaded rectangle
on a half-space (Johnson, *Contact Mechanics*, 1985, eq. 3.25). The unknown pressure is found by
the Polonsky & Keer (1999) constrained conjugate-gradient method (non-negative pressure, load
balance with the rigid-body approach as Lagrange multiplier); every displacement evaluation is a
non-periodic discrete convolution done with the DC-FFT of Liu, Wang & Liu (2000): the kernel is
laid out on a 2N grid with its wrap-around, the pressure is zero-padded, and only the first N
outputs are kept, so the result equals the direct summation to round-off.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np
import scipy.fft as sfft


# ---------------------------------------------------------------------------------------------
# Influence coefficients and DC-FFT
# ---------------------------------------------------------------------------------------------
def _love_antiderivative(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """F(s, t) = s asinh(t/|s|) + t asinh(s/|t|), the double antiderivative of 1/sqrt(s^2 + t^2)
    (odd in s and in t, F = 0 on the axes)."""
    s = np.asarray(s, dtype=float)
    t = np.asarray(t, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(s != 0.0, s * np.arcsinh(t / np.abs(s)), 0.0)
        b = np.where(t != 0.0, t * np.arcsinh(s / np.abs(t)), 0.0)
    return a + b


def love_rectangle_influence(
    x_m: np.ndarray, y_m: np.ndarray, dx_m: float, dy_m: float, effective_modulus_pa: float
) -> np.ndarray:
    """Normal surface displacement [m per Pa] at (x, y) [m] of a unit uniform pressure on the
    rectangle |x| <= dx/2, |y| <= dy/2 of an elastic half-space, summed over both bodies.

    u = 1/(pi E*) [F(x + a, y + b) - F(x + a, y - b) - F(x - a, y + b) + F(x - a, y - b)],
    a = dx/2, b = dy/2, F as in :func:`_love_antiderivative`. Boussinesq point-force solution
    integrated over the rectangle: Love, A. E. H., Phil. Trans. R. Soc. A 228 (1929) 377-420;
    Johnson (1985) eq. 3.25.
    """
    a = 0.5 * dx_m
    b = 0.5 * dy_m
    x = np.asarray(x_m, dtype=float)
    y = np.asarray(y_m, dtype=float)
    f = (
        _love_antiderivative(x + a, y + b)
        - _love_antiderivative(x + a, y - b)
        - _love_antiderivative(x - a, y + b)
        + _love_antiderivative(x - a, y - b)
    )
    return f / (math.pi * effective_modulus_pa)


class DcFftDisplacementOperator:
    """Non-periodic discrete convolution u = K * p on an ``nx x ny`` grid via DC-FFT.

    The influence kernel K(i dx, j dy) is built on a (2 nx) x (2 ny) grid with wrap-around order
    (indices nx+1..2nx-1 hold the negative offsets), the pressure is zero-padded to the same size,
    and the first nx x ny outputs of the circular convolution are the exact linear convolution.
    Liu, S., Wang, Q., Liu, G., Wear 243 (2000) 101-111.
    With ``periodic_y`` the y direction is circular instead (period ny dy, kernel truncated to
    one period): a pressure uniform in y then sees the displacement of a strip of length ny dy,
    i.e. the 2D line-contact kernel -2/(pi E*) ln|x| + const up to O((x / (ny dy))^2) -- the
    plane-strain limit of an infinitely long roller.
    Units: pressure [Pa] in, displacement [m] out.
    """

    def __init__(self, nx: int, ny: int, dx_m: float, dy_m: float, effective_modulus_pa: float,
                 workers: int = -1, periodic_y: bool = False) -> None:
        self.nx, self.ny = int(nx), int(ny)
        self.dx, self.dy = float(dx_m), float(dy_m)
        self.workers = workers
        self.periodic_y = bool(periodic_y)
        ix = np.arange(2 * self.nx)
        ox = np.where(ix < self.nx, ix, ix - 2 * self.nx).astype(float) * self.dx
        ox[self.nx] = 0.0  # never reaches the kept outputs; any value works
        if self.periodic_y:
            # circular in y: one period of ny elements, offsets -ny/2 .. ny/2 (plane-strain limit)
            iy = np.arange(self.ny)
            oy = np.where(iy <= self.ny // 2, iy, iy - self.ny).astype(float) * self.dy
            self._shape = (2 * self.nx, self.ny)
        else:
            iy = np.arange(2 * self.ny)
            oy = np.where(iy < self.ny, iy, iy - 2 * self.ny).astype(float) * self.dy
            oy[self.ny] = 0.0
            self._shape = (2 * self.nx, 2 * self.ny)
        kernel = love_rectangle_influence(ox[:, None], oy[None, :], self.dx, self.dy, effective_modulus_pa)
        kernel[self.nx, :] = 0.0
        if not self.periodic_y:
            kernel[:, self.ny] = 0.0
        self.kernel_hat = sfft.rfft2(kernel, workers=workers)
        self.self_influence_m_per_pa = float(kernel[0, 0])

    def __call__(self, pressure_pa: np.ndarray) -> np.ndarray:
        shape = self._shape
        p_hat = sfft.rfft2(pressure_pa, s=shape, workers=self.workers)
        u = sfft.irfft2(p_hat * self.kernel_hat, s=shape, workers=self.workers)
        return u[: self.nx, : self.ny]


@lru_cache(maxsize=16)
def cached_displacement_operator(nx: int, ny: int, dx_m: float, dy_m: float,
                                 effective_modulus_pa: float) -> DcFftDisplacementOperator:
    """:class:`DcFftDisplacementOperator` memoised on the grid and E* (the kernel FFT is the costly part)."""
    return DcFftDisplacementOperator(nx, ny, dx_m, dy_m, effective_modulus_pa)


# ---------------------------------------------------------------------------------------------
# Polonsky-Keer conjugate gradient
# ---------------------------------------------------------------------------------------------
def solve_pressure_polonsky_keer(
    gap_undeformed_m: np.ndarray,
    element_area_m2: float,
    total_load_n: float,
    displacement: Callable[[np.ndarray], np.ndarray],
    tol: float = 1e-9,
    max_iter: int = 1000,
    initial_pressure_pa: np.ndarray | None = None,
) -> tuple[np.ndarray, float, int, float]:
    """Frictionless normal contact with prescribed total load by the Polonsky-Keer CG method.

    Find p >= 0 [Pa] and the rigid approach delta [m] such that the gap
    h = h0 + u(p) - delta is >= 0, p h = 0 elementwise and sum(p) A = W.
    Elements with h0 = +inf can never touch (their pressure stays 0).

    Returns (pressure [Pa], approach [m], iterations, last relative pressure change).
    Polonsky, I. A., Keer, L. M., Wear 231 (1999) 206-219 (Sect. 3, with the approach as the
    Lagrange multiplier of the load balance).
    """
    h0 = np.asarray(gap_undeformed_m, dtype=float)
    can_touch = np.isfinite(h0)
    h0f = np.where(can_touch, h0, 0.0)
    if total_load_n <= 0:
        raise ValueError("total load must be positive")
    if not can_touch.any():
        raise ValueError("no element can come into contact")
    if initial_pressure_pa is None:
        p = np.where(can_touch, total_load_n / (element_area_m2 * can_touch.sum()), 0.0)
    else:
        p = np.where(can_touch, np.maximum(initial_pressure_pa, 0.0), 0.0)
        p *= total_load_n / (element_area_m2 * p.sum())
    t = np.zeros_like(p)
    g_norm_old = 1.0
    conjugate = False
    eps = np.inf
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - `it` (iterations used) is reported after the loop
        g = h0f + displacement(p)
        in_contact = p > 0.0
        g_bar = g[in_contact].mean()
        g -= g_bar
        g_norm = float(np.sum(g[in_contact] ** 2))
        if conjugate:
            t = np.where(in_contact, g + (g_norm / g_norm_old) * t, 0.0)
        else:
            t = np.where(in_contact, g, 0.0)
        g_norm_old = g_norm
        r = displacement(t)
        r -= r[in_contact].mean()
        denom = float(np.sum(r[in_contact] * t[in_contact]))
        if denom == 0.0:
            break
        tau = float(np.sum(g[in_contact] * t[in_contact])) / denom
        p_old = p
        p = np.where(in_contact, p - tau * t, 0.0)
        np.maximum(p, 0.0, out=p)
        overlap = (p == 0.0) & (g < 0.0) & can_touch
        conjugate = not overlap.any()
        if not conjugate:
            p[overlap] -= tau * g[overlap]
        p *= total_load_n / (element_area_m2 * p.sum())
        eps = float(np.abs(p - p_old).sum() * element_area_m2 / total_load_n)
        if eps < tol:
            break
    u = displacement(p)
    in_contact = p > 0.0
    approach = float(np.mean(h0f[in_contact] + u[in_contact]))
    return p, approach, it, eps
