"""Lubrication of the ball/groove contacts of a linear rolling guide (seed 001): Hamrock-Dowson (1977) central and
minimum film of the elliptical contact, entrainment speed from the carriage speed, lambda ratio and regime, and
Johnson-Greenwood-Poon (1972) load sharing with Greenwood-Tripp (1970) asperity contact (asperity load share,
mean-plane separation and real contact area vs speed).

Pure physics: numpy/scipy only, SI units (m, N, Pa, m/s). Elastic constant: the contact modulus E*
(:func:`guide_health.models.contact.elastic.effective_modulus_pa`); the film fits and the asperity pressure are
published with Hamrock's reduced modulus E' = 2 E*, which these formulas form explicitly as ``2 E*``.
Seed 001: the NSK LH45 guide (the reference: docs/physics.md#the-seeds).

Film, kinematics, oil and roughness (assumptions)
-------------------------------------------------
* Kinematics: the rail is fixed, the carriage moves at v. In pure rolling the ball centre moves at v/2
  relative to the rail, and the carriage and rail contacts lie on one line through the ball centre, so
  both contact surfaces move through the contact at |v|/2 relative to the contact point:
  entrainment speed u = (u1 + u2)/2 = |v|/2 at both the ball/rail and the ball/carriage contact. The
  seed's 10 % slide-to-roll ratio changes u1 - u2, not u. (The seed's speed axis is the "slider speed";
  its film numbers look as if it fed that speed directly as the entrainment speed, see below.)
* Oil: either a constant eta_0 (``oil_viscosity_pa_s``; 0.060 Pa s = VG68 at 40 degC) or two catalogue
  viscosities and the guide temperature (Walther/ASTM D341, :mod:`.oil`; seed 000's 68# oil at 21 degC is
  0.1631 Pa s, the seed-001 reading), pressure-viscosity alpha = 2.0e-8 1/Pa (``pressure_viscosity_pa_inv``).
  Isothermal, Newtonian, fully flooded inlet (no starvation, no shear heating): an upper bound on the film
  of an oil-starved guide.
* Roughness: ``roughness_rms_m`` is the COMPOSITE RMS sigma = sqrt(Rq1^2 + Rq2^2) of ball and groove.
  The seed's "RMS = 0.2 um" is taken as composite: the seed defines lambda = mean film / RMS with no
  sqrt(2), and its lambda ~ 1 at 0.5 m/s needs h ~ 200 nm, which is already 2x the smooth film at that
  speed; a per-surface reading (sigma = 0.28 um) would push every regime boundary a further 1.7x in speed.
  (The seed's Fig. 10 pairs, 294.3 nm / 1.18, 232 nm / 0.925, 203 nm / 0.82, imply sigma = 0.25 um.)
* Hamrock & Dowson (1977): H_c = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 e^(-0.73 k)),
  H_min = 3.63 U^0.68 G^0.49 W^-0.073 (1 - e^(-0.68 k)); U = eta_0 u/(E' R_x), G = alpha E',
  W = w/(E' R_x^2), E' = 2 E* = 2/((1-nu1^2)/E1 + (1-nu2^2)/E2), k = b/a (transverse/rolling semi-axis).
  For this guide at 385 N: h_c = 4.7 / 34.8 / 102 / 163 nm at v = 0.005 / 0.1 / 0.5 / 1 m/s
  (lambda = 0.023 / 0.17 / 0.51 / 0.81).  At v < 0.01 m/s U < 1e-12, below the range the fit was made
  for (a low-speed extrapolation of the u^0.67 law).
* lambda = h_c / sigma (central film, like the seed's mean film in 2/3 of the Hertz zone); ``lambda_min``
  = h_min / sigma is reported as well.

Regime thresholds (seed 001 Fig. 8 calibration)
-----------------------------------------------
boundary: lambda < 0.0098;  mixed: 0.0098 <= lambda < 3;  full_film: lambda >= 3 (``LAMBDA_BOUNDARY``,
``LAMBDA_FULL_FILM``; the parameter schema imports these, the one source). Seed 001's Fig. 8 text: boundary
lubrication (contact-area ratio A_c > 80 %) below 0.0005 m/s slider speed, A_c = 73.76 % at 0.001 m/s, falling to
0.05 % at 1 m/s. (Its Fig. 9 text says 0.005 m/s and A_c > 80.25 %; A_c = 73.76 % at 0.001 m/s and A_c falling
with speed rule that out, so Fig. 8 is read.) In the seed-001 reading of the oil (seed 000's 68# oil at 21 degC,
eta_0 = 0.1631 Pa s, the reading that puts lambda = 1 at 0.5 m/s as Fig. 9: :mod:`.oil`), lambda at 0.0005 m/s
and 385 N is 0.00978: LAMBDA_BOUNDARY = 0.0098. (With VG68 at 40 degC, 0.060 Pa s, lambda(0.0005 m/s) = 0.0050,
the value the issue quotes; lambda scales as eta^0.67, so the same threshold then ends boundary lubrication at
0.0014 m/s: a thinner oil needs more speed.) The classical stochastic rule (boundary below 1) would call the whole
range where the seed finds mixed lubrication (0.001-1 m/s) boundary. 3 is kept as the conservative full-film
bound: the Gaussian (Greenwood-Tripp) asperity share falls below 0.1 % only there.

Mixed lubrication: Johnson-Greenwood-Poon + Greenwood-Tripp
----------------------------------------------------------
The load w is shared, w = w/gamma_1 + w/gamma_2 (1/gamma_1 + 1/gamma_2 = 1): the fluid carries w/gamma_1 with
modulus E'/gamma_1, the asperities w/gamma_2 with E'/gamma_2 (both give the same Hertz area A_H = pi a b).
The fluid film is Hamrock-Dowson at (w/gamma_1, E'/gamma_1): h = h_c,smooth gamma_1^(0.67 - 0.53)
= h_c,smooth gamma_1^0.14 (the W exponent cancels). The asperity pressure (Greenwood & Tripp 1970) at
mean-plane separation h = t sigma is
    p_a = (16 sqrt(2)/15) pi (eta_s beta sigma)^2 sqrt(sigma/beta) E' F_5/2(t),
    F_n(t) = int_t^inf (s - t)^n phi(s) ds  (phi: standard normal density; scipy.integrate.quad),
and must equal the asperity share of the mean Hertz pressure, p_a = w/(gamma_2 A_H). One unknown (t) is
solved with brentq. Real (micro-)contact area: A_r/A_H = pi^2 (eta_s beta sigma)^2 F_2(t) (closed form).
Asperity parameters (``asperity_radius_m`` = 2 um, ``asperity_density_per_m2`` = 1.597e11 1/m^2, summit sigma =
composite sigma): eta_s beta sigma = 0.064, sigma/beta = 0.1, as for a finely ground surface measured at
sub-micron sampling (Nayak, isotropic Gaussian: eta beta sigma = sqrt(alpha_B)/(16 sqrt(3 pi)) ~ 0.064 at
bandwidth alpha_B ~ 10, and sigma/beta = 8 sqrt(alpha_B) Dq^2/(3 sqrt(pi)) = 0.1 at RMS slope Dq = 0.14).
Calibration: eta_s = 1.597e11 puts the JGP asperity share at 73.76 % at 0.001 m/s (seed 001
Fig. 8) in the seed-001 oil reading (1.584e11 with the 0.060 Pa s oil: the point is nearly oil-independent).
Why the seed's 80 % at 0.0005 m/s cannot be matched as well: the share is s = K F_5/2(t) with
K = K_GT E'/p_mean and t = lambda (1 - s)^-0.14; the asperity parameters enter ONLY through K (one number), and
at lambda ~ 0.01 the separation t is ~ 0 whatever K, so s(v -> 0) = K F_5/2(0) = 0.762 once s(0.001 m/s) =
0.7376: the share rises only 1.3 points from 0.001 m/s to 0.0005 m/s (0.7466) and never reaches 80 %. The
seed's 80 % -> 73.76 % over a factor 2 of speed (a slope 9x steeper) needs a rough-surface film the Gaussian
model lacks. The boundary regime is therefore set by ``LAMBDA_BOUNDARY`` (above), the A_c point by eta_s. The
textbook Greenwood-Williamson range (eta beta sigma = 0.03-0.05, sigma/beta = 0.01) gives an asperity share of
only 5-15 % at any speed > 0 for this 1.1 GPa mean-pressure contact (never boundary).

``contact_area_ratio`` (the seed's A_c: share of the Hertz area in solid contact in a deterministic model,
which resolves roughness only down to its grid and lets it flatten elastically) has no direct Gaussian
counterpart: the Greenwood-Tripp real area of micro-contacts is a different, much smaller quantity (a few %,
reported as ``asperity_real_area_ratio``). It is estimated by the JGP asperity LOAD share (contact nodes in
a deterministic model carry about the local Hertz-like pressure, so area and load ratios fall together).
Known limits of JGP-GT against the seed: (1) its transition is broader: share 0.74 -> 0.022 from 0.001 to
1 m/s (68# oil at 21 degC), against the seed's 73.76 % -> 0.05 % (Zhu & Wang attribute this
to the Gaussian model ignoring the elastic flattening of asperities inside the EHL zone); (2) at a fixed
speed the share FALLS with load, because the asperity pressure at a given separation does not depend on the
nominal pressure while the EHL film hardly does (W^-0.067): at 1450 N the share never exceeds ~55 %. The
lambda-based regime falls the right way with load.

Smooth-surface Hamrock-Dowson vs the seed's rough-surface numerical mixed-EHL
-----------------------------------------------------------------------------
* The seed does not state the speed of Table 1 / Fig. 10, nor its oil. Its own Fig. 9 (lambda -> 1, i.e.
  h ~ 200 nm, at 0.5 m/s, film ~ u^0.6-0.7) puts Table 1's 294.3 nm at ~0.9-1 m/s slider speed. With VG68 at
  40 degC (0.060 Pa s) Hamrock-Dowson reaches 294.3 nm at 385 N only at v = 2.4 m/s (u = v/2) and lambda(0.5 m/s)
  = 0.51; with seed 000's 68# oil at 21 degC (Walther, 0.1631 Pa s) it reaches 294.3 nm at
  0.88 m/s and lambda = 1.00 at 0.50 m/s: that oil reading reproduces Fig. 9 and Table 1's speed together, with
  u = v/2 (no need to assume the seed fed the slider speed as the entrainment speed).
* The seed's mean film h_a is the mean gap over 2/3 of the Hertz zone between ROUGH surfaces: below ~0.1 m/s
  it is held up by the roughness (it "changes little over three decades" with lambda < 0.4), whereas the
  smooth film keeps falling as u^0.67 (lambda_HD = 0.008 at 0.001 m/s). Above ~0.1 m/s both grow with speed.
* Load: the seed's film falls 38 % from 385 to 635 N (294.3 -> 181.5 nm) and 47 % to 1450 N; EHL theory
  gives W^-0.067: -3.3 % and -8.5 %. Only the direction is reproduced. (The 385 N row equals the seed's
  Gf = 0.515 row, 294.3 nm; Hamrock-Dowson also puts f = 0.515 and 0.52 within 0.1 % of each other.)
* Conformity 0.515 -> 0.6 -> 0.8 at 385 N: R_x and W do not change, only k = b/a (9.63 -> 3.25 -> 1.92), so
  Hamrock-Dowson gives h_c -5.6 % / -15.0 % and h_min -10.8 % / -27.0 % relative to 0.515, against the
  seed's mean film -21 % / -31 %. Direction reproduced; the minimum film comes close, the central film
  falls about half as much (the seed's film also feels the rise of p_max with f: 1.58 -> 2.35 -> 2.91 GPa).
  The JGP asperity share, by contrast, FALLS with f at a fixed speed (limit (2) above); the seed's A_c
  rises (1 % -> 1.5 % -> 3.7 %).
* The seed's lambda = h_a / RMS; its Fig. 10 lambdas imply RMS = 0.25 um, not the stated 0.2 um.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

# --- Hamrock & Dowson (1977) point-contact film fits (dimensionless exponents/coefficients) ---
HD_CENTRAL_COEFF = 2.69
HD_CENTRAL_U_EXP = 0.67
HD_CENTRAL_G_EXP = 0.53
HD_CENTRAL_W_EXP = -0.067
HD_MIN_COEFF = 3.63
HD_MIN_U_EXP = 0.68
HD_MIN_G_EXP = 0.49
HD_MIN_W_EXP = -0.073
# JGP: the fluid film at (w/gamma_1, E'/gamma_1) is h_smooth gamma_1^(0.67 - 0.53)
JGP_FILM_GAMMA_EXP = HD_CENTRAL_U_EXP - HD_CENTRAL_G_EXP

# --- regime thresholds on lambda = h_c / sigma (see module docstring) ---
LAMBDA_BOUNDARY = 0.0098          # lambda at 0.0005 m/s, 385 N, 68# oil at 21 degC (seed 001 Fig. 8)
LAMBDA_FULL_FILM = 3.0
REGIMES = ("boundary", "mixed", "full_film")

_SQRT_2PI = math.sqrt(2.0 * math.pi)
_GT_PRESSURE_COEFF = 16.0 * math.sqrt(2.0) / 15.0 * math.pi


# ----------------------------------------------------------------------------------------------------------
# Film thickness and lambda
# ----------------------------------------------------------------------------------------------------------

def entrainment_speed(carriage_speed_m_s: float) -> float:
    """u = (u1 + u2)/2 = |v|/2 [m/s] for the ball/rail and ball/carriage contacts in pure rolling (see module doc)."""
    return 0.5 * abs(carriage_speed_m_s)


def hamrock_dowson_film(load_n: float, entrainment_speed_m_s: float, radius_x_m: float, ellipticity_k: float,
                        effective_modulus_pa: float, viscosity_pa_s: float,
                        pressure_viscosity_pa_inv: float) -> tuple[float, float]:
    """(central, minimum) film thickness [m] of a smooth elliptical EHL contact (Hamrock & Dowson 1977).

    H_c = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 exp(-0.73 k)), H_min = 3.63 U^0.68 G^0.49 W^-0.073 (1 - exp(-0.68 k)),
    h = H R_x; U = eta_0 u / (E' R_x), G = alpha E', W = w / (E' R_x^2), k = b/a (entrainment along x),
    with Hamrock's reduced modulus E' = 2 E* (E* = ``effective_modulus_pa``).
    """
    if not load_n > 0:
        raise ValueError(f"contact load must be > 0, got {load_n!r}")
    if entrainment_speed_m_s < 0:
        raise ValueError("entrainment speed must be >= 0")
    if entrainment_speed_m_s == 0.0:
        return 0.0, 0.0
    e_prime = 2.0 * effective_modulus_pa                        # Hamrock & Dowson's E'
    u_dim = viscosity_pa_s * entrainment_speed_m_s / (e_prime * radius_x_m)
    g_dim = pressure_viscosity_pa_inv * e_prime
    w_dim = load_n / (e_prime * radius_x_m ** 2)
    h_central = (HD_CENTRAL_COEFF * u_dim ** HD_CENTRAL_U_EXP * g_dim ** HD_CENTRAL_G_EXP * w_dim ** HD_CENTRAL_W_EXP
                 * (1.0 - 0.61 * math.exp(-0.73 * ellipticity_k)))
    h_min = (HD_MIN_COEFF * u_dim ** HD_MIN_U_EXP * g_dim ** HD_MIN_G_EXP * w_dim ** HD_MIN_W_EXP
             * (1.0 - math.exp(-0.68 * ellipticity_k)))
    return h_central * radius_x_m, h_min * radius_x_m


def lubrication_regime(lambda_ratio: float, lambda_boundary: float = LAMBDA_BOUNDARY,
                       lambda_full_film: float = LAMBDA_FULL_FILM) -> str:
    """'boundary' (lambda < lambda_boundary), 'full_film' (lambda >= lambda_full_film) or 'mixed'."""
    if lambda_ratio < lambda_boundary:
        return "boundary"
    if lambda_ratio >= lambda_full_film:
        return "full_film"
    return "mixed"


# ----------------------------------------------------------------------------------------------------------
# Greenwood-Tripp asperity contact and JGP load sharing
# ----------------------------------------------------------------------------------------------------------

def greenwood_tripp_integral(order: float, separation_ratio: float) -> float:
    """F_n(t) = int_t^inf (s - t)^n phi(s) ds (Greenwood & Tripp 1970), phi the standard normal density.

    scipy.integrate.quad over x = s - t in [0, inf), split at the density peak for t < 0.
    """
    from scipy.integrate import quad  # here, not at import: the parameter schema imports this module

    t = separation_ratio

    def integrand(x: float) -> float:
        return x ** order * math.exp(-0.5 * (x + t) ** 2)

    if t < 0.0:
        peak = -t
        value = quad(integrand, 0.0, peak + 12.0, points=(peak,), limit=200)[0]
    else:
        value = quad(integrand, 0.0, math.inf, limit=200)[0]
    return value / _SQRT_2PI


def greenwood_tripp_f2(separation_ratio: float) -> float:
    """F_2(t) = (1 + t^2) Q(t) - t phi(t) (closed form), Q the upper normal tail."""
    t = separation_ratio
    upper_tail = 0.5 * math.erfc(t / math.sqrt(2.0))
    return (1.0 + t * t) * upper_tail - t * math.exp(-0.5 * t * t) / _SQRT_2PI


def greenwood_tripp_pressure_coefficient(composite_rms_m: float, asperity_density_per_m2: float,
                                         asperity_radius_m: float, effective_modulus_pa: float) -> float:
    """K_GT E' [Pa] in p_a = K_GT E' F_5/2(h/sigma), K_GT = (16 sqrt 2 / 15) pi (eta beta sigma)^2 sqrt(sigma/beta).

    Greenwood & Tripp (1970) write the asperity pressure with E' = 2 E* (E* = ``effective_modulus_pa``).
    """
    e_prime = 2.0 * effective_modulus_pa
    eta_beta_sigma = asperity_density_per_m2 * asperity_radius_m * composite_rms_m
    return (_GT_PRESSURE_COEFF * eta_beta_sigma ** 2 * math.sqrt(composite_rms_m / asperity_radius_m)
            * e_prime)


@dataclass(frozen=True)
class MixedLubrication:
    """JGP/GT load sharing result."""

    asperity_load_share: float        # 1/gamma_2 = W_asperity / W
    separation_m: float               # mean-plane separation h = film of the fluid part (may be < 0 at v = 0)
    asperity_real_area_ratio: float   # A_r / A_Hertz, GT micro-contact area


def jgp_greenwood_tripp(smooth_central_film_m: float, mean_contact_pressure_pa: float, composite_rms_m: float,
                        gt_pressure_coefficient_pa: float, asperity_density_per_m2: float, asperity_radius_m: float,
                        f52: Callable[[float], float] | None = None) -> MixedLubrication:
    """Johnson-Greenwood-Poon (1972) load sharing with Greenwood-Tripp asperities (equations: module docstring).

    Unknown t = h/sigma: s(t) = K_GT E' F_5/2(t) / p_mean (asperity share), and the fluid film at
    (w/gamma_1, E'/gamma_1) equals the separation: h_smooth (1 - s)^-0.14 = sigma t. brentq on t in (t_full, t_hi],
    t_full: s(t_full) = 1 (asperities alone). ``f52`` replaces :func:`greenwood_tripp_integral` (e.g. a table).
    """
    if f52 is None:
        def f52(t: float) -> float:
            return greenwood_tripp_integral(2.5, t)
    scale = gt_pressure_coefficient_pa / mean_contact_pressure_pa

    def share(t: float) -> float:
        return scale * f52(t)

    from scipy.optimize import brentq

    lo = -4.0
    while share(lo) < 1.0:
        lo -= 4.0
        if lo < -1e3:
            raise ValueError("asperity contact too compliant: no separation carries the load")
    t_full = brentq(lambda t: share(t) - 1.0, lo, 40.0, xtol=1e-12)
    eta_beta_sigma = asperity_density_per_m2 * asperity_radius_m * composite_rms_m
    area_coeff = math.pi ** 2 * eta_beta_sigma ** 2
    if smooth_central_film_m <= 0.0:
        return MixedLubrication(1.0, t_full * composite_rms_m, area_coeff * greenwood_tripp_f2(t_full))
    lam = smooth_central_film_m / composite_rms_m

    def film_mismatch(t: float) -> float:
        s = min(share(t), 1.0 - 1e-15)
        return lam * (1.0 - s) ** (-JGP_FILM_GAMMA_EXP) - t

    t_lo = t_full + 1e-12 * max(1.0, abs(t_full))
    if film_mismatch(t_lo) <= 0.0:
        # the root sits closer to t_full than double precision resolves (1 - s < 1e-15): asperities carry all
        return MixedLubrication(1.0, t_full * composite_rms_m, area_coeff * greenwood_tripp_f2(t_full))
    t_hi = max(t_full, lam) + 1.0
    while film_mismatch(t_hi) > 0.0:
        t_hi += 2.0
    t = brentq(film_mismatch, t_lo, t_hi, xtol=1e-12)
    return MixedLubrication(min(share(t), 1.0), t * composite_rms_m, area_coeff * greenwood_tripp_f2(t))


@functools.lru_cache(maxsize=1)
def greenwood_tripp_f52_table() -> Callable[[float], float]:
    """Fast F_5/2(t): log F on a 0.001-step grid over t in [-12, 12] (from a cubic spline through 1201 quad
    values), linear interpolation in pure Python (relative error < 1e-6); quad outside the grid. Built once
    per process (a pure function of nothing: every caller shares it)."""
    from scipy.interpolate import CubicSpline

    t_lo, t_hi, step = -12.0, 12.0, 0.001
    knots = np.linspace(t_lo, t_hi, 1201)
    spline = CubicSpline(knots, np.log([greenwood_tripp_integral(2.5, t) for t in knots]))
    log_table = spline(np.linspace(t_lo, t_hi, int(round((t_hi - t_lo) / step)) + 1)).tolist()
    last = len(log_table) - 2
    exp = math.exp

    def f52(t: float) -> float:
        if not t_lo <= t <= t_hi:
            return greenwood_tripp_integral(2.5, t)
        position = (t - t_lo) / step
        i = min(int(position), last)
        frac = position - i
        return exp(log_table[i] + frac * (log_table[i + 1] - log_table[i]))

    return f52
